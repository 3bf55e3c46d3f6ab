// Synthetic stereo pairs with exactly known disparity, for the core tests.
//
// The scene is a texture T(x, y) "painted" on a surface seen by the left
// camera; its disparity in left coordinates is linear, d(x) = a + b * x
// (b = 0: a fronto-parallel plane, b != 0: a plane slanted in x). The right
// image shows the same texture at x_right = x_left - d(x_left), so
//   right(xr, y) = T(xl, y) with xl = (xr + a) / (1 - b).
// T is a sum of sinusoids evaluated analytically, so any sub-pixel shift is
// exact: no interpolation of a sampled texture, hence no border artefacts and
// no interpolation bias in the ground truth. The only error left in the images
// is the 8-bit rounding (+-0.5 grey levels), as with a real camera.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace bdis_test {

/// Aperiodic band-limited texture: a sum of plane waves with random
/// orientation, wavelength and phase, centred on `mean`, peak amplitude
/// roughly +-`amplitude` grey levels.
class Texture {
 public:
  explicit Texture(unsigned seed = 1, double mean = 128.0, double amplitude = 60.0,
                   double min_wavelength = 6.0, double max_wavelength = 40.0, int waves = 24)
      : mean_(mean) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    const double pi = 3.14159265358979323846;
    // Equal amplitude per wave; sum of N random-phase waves has std
    // A * sqrt(N / 2), scaled so that +-amplitude is about 2.5 std.
    const double a = amplitude / (2.5 * std::sqrt(0.5 * waves));
    for (int i = 0; i < waves; ++i) {
      // Log-uniform wavelength, orientation in [0, pi).
      const double lambda =
          min_wavelength * std::pow(max_wavelength / min_wavelength, unit(rng));
      const double theta = pi * unit(rng);
      const double k = 2.0 * pi / lambda;
      waves_.push_back({k * std::cos(theta), k * std::sin(theta), 2.0 * pi * unit(rng), a});
    }
  }

  double operator()(double x, double y) const {
    double v = mean_;
    for (const Wave& w : waves_) v += w.amp * std::sin(w.kx * x + w.ky * y + w.phase);
    return v;
  }

  /// operator() + `offset` on the grid xs[i] x {0..height-1}, rounded to
  /// 8 bits. sin(a + b) = sin a cos b + cos a sin b keeps it to
  /// O((W + H) * waves) sines.
  cv::Mat render(const std::vector<double>& xs, int height, double offset = 0.0) const {
    const int W = static_cast<int>(xs.size());
    cv::Mat1d acc(height, W, mean_ + offset);
    std::vector<double> sx(xs.size()), cx(xs.size());
    for (const Wave& w : waves_) {
      for (int i = 0; i < W; ++i) {
        sx[i] = w.amp * std::sin(w.kx * xs[i] + w.phase);
        cx[i] = w.amp * std::cos(w.kx * xs[i] + w.phase);
      }
      for (int y = 0; y < height; ++y) {
        const double cy = std::cos(w.ky * y), sy = std::sin(w.ky * y);
        double* a = acc[y];
        for (int i = 0; i < W; ++i) a[i] += sx[i] * cy + cx[i] * sy;
      }
    }
    cv::Mat out(height, W, CV_8UC1);
    for (int y = 0; y < height; ++y) {
      for (int i = 0; i < W; ++i) out.at<uchar>(y, i) = cv::saturate_cast<uchar>(std::lround(acc(y, i)));
    }
    return out;
  }

 private:
  struct Wave {
    double kx, ky, phase, amp;
  };
  double mean_;
  std::vector<Wave> waves_;
};

inline uchar toByte(double v) { return cv::saturate_cast<uchar>(std::lround(v)); }

/// Linear disparity in left coordinates, d(x, y) = a + b * x + c * y.
struct LinearDisparity {
  double a = 0.0;
  double b = 0.0;
  double c = 0.0;  ///< along the rows
  double at(double x_left, double y = 0.0) const { return a + b * x_left + c * y; }
  /// Left x seen at right x on row y: solves xl - d(xl, y) = xr.
  double leftOf(double x_right, double y = 0.0) const { return (x_right + (a + c * y)) / (1.0 - b); }
};

/// Scene value at a left-image position (the "paint" on the surface).
using Scene = std::function<double(double x, double y)>;

struct StereoPair {
  cv::Mat left;   ///< CV_8UC1
  cv::Mat right;  ///< CV_8UC1
  cv::Mat gt;     ///< CV_32FC1, the true left disparity everywhere
};

/// Renders a rectified pair of `scene` on a plane of disparity `disp`.
/// `right_offset` is added to every right pixel (brightness difference).
inline StereoPair renderPair(int width, int height, const Scene& scene, LinearDisparity disp,
                             double right_offset = 0.0) {
  StereoPair p;
  p.left.create(height, width, CV_8UC1);
  p.right.create(height, width, CV_8UC1);
  p.gt.create(height, width, CV_32FC1);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      p.left.at<uchar>(y, x) = toByte(scene(x, y));
      p.right.at<uchar>(y, x) = toByte(scene(disp.leftOf(x, y), y) + right_offset);
      p.gt.at<float>(y, x) = static_cast<float>(disp.at(x, y));
    }
  }
  return p;
}

/// renderPair() of a Texture(seed) scene, through the fast Texture::render,
/// which renders every row alike: disparity along x only (c = 0).
inline StereoPair texturedPair(int width, int height, LinearDisparity disp, unsigned seed = 1,
                               double right_offset = 0.0) {
  if (disp.c != 0.0) throw std::invalid_argument("texturedPair: disparity varies along x only");
  const Texture tex(seed);
  std::vector<double> xl(static_cast<size_t>(width)), xr(static_cast<size_t>(width));
  StereoPair p;
  p.gt.create(height, width, CV_32FC1);
  for (int x = 0; x < width; ++x) {
    xl[static_cast<size_t>(x)] = x;
    xr[static_cast<size_t>(x)] = disp.leftOf(x);
    p.gt.col(x).setTo(static_cast<float>(disp.at(x)));
  }
  p.left = tex.render(xl, height);
  p.right = tex.render(xr, height, right_offset);
  return p;
}

/// Blurred uniform noise stretched to 20..235 (no pure black, no saturation),
/// and the pair with integer disparity `shift`: left(x) = right(x - shift).
inline void blurredNoisePair(uint64_t rng_seed, int shift, int width, int height, double blur_sigma,
                             cv::Mat& left, cv::Mat& right) {
  cv::Mat noise(height, width + shift, CV_32FC1);
  cv::RNG rng(rng_seed);
  rng.fill(noise, cv::RNG::UNIFORM, 0.0, 1.0);
  cv::GaussianBlur(noise, noise, cv::Size(0, 0), blur_sigma);
  cv::normalize(noise, noise, 20, 235, cv::NORM_MINMAX);
  cv::Mat tex;
  noise.convertTo(tex, CV_8UC1);
  left = tex(cv::Rect(0, 0, width, height)).clone();
  right = tex(cv::Rect(shift, 0, width, height)).clone();
}

/// Values of `m` (CV_32FC1) inside `roi`, optionally only where `mask` != 0.
inline std::vector<float> valuesIn(const cv::Mat& m, const cv::Rect& roi,
                                   const cv::Mat& mask = cv::Mat()) {
  std::vector<float> out;
  for (int y = roi.y; y < roi.y + roi.height; ++y) {
    for (int x = roi.x; x < roi.x + roi.width; ++x) {
      if (!mask.empty() && mask.at<uchar>(y, x) == 0) continue;
      out.push_back(m.at<float>(y, x));
    }
  }
  return out;
}

/// q-quantile (0..1) of a copy of `v`, nearest rank; NaN for an empty vector.
inline double quantile(std::vector<float> v, double q) {
  if (v.empty()) return std::nan("");
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(std::floor(q * (v.size() - 1) + 0.5)));
  std::nth_element(v.begin(), v.begin() + static_cast<long>(k), v.end());
  return v[k];
}

/// Error statistics of an estimate against ground truth over a region.
struct ErrorStats {
  size_t pixels = 0;     ///< pixels in the region
  size_t estimated = 0;  ///< of those, with an estimate (d >= 0)
  double median = std::nan("");
  double p95 = std::nan("");
  double max = std::nan("");
  double mean_signed = std::nan("");  ///< bias
  double density() const { return pixels ? static_cast<double>(estimated) / pixels : 0.0; }
};

inline ErrorStats errorStats(const cv::Mat& disparity, const cv::Mat& gt, const cv::Rect& roi) {
  ErrorStats s;
  std::vector<float> abs_err;
  double signed_sum = 0.0;
  for (int y = roi.y; y < roi.y + roi.height; ++y) {
    for (int x = roi.x; x < roi.x + roi.width; ++x) {
      ++s.pixels;
      const float d = disparity.at<float>(y, x);
      if (!(d >= 0.f)) continue;
      ++s.estimated;
      const float e = d - gt.at<float>(y, x);
      signed_sum += e;
      abs_err.push_back(std::fabs(e));
    }
  }
  if (!abs_err.empty()) {
    s.median = quantile(abs_err, 0.5);
    s.p95 = quantile(abs_err, 0.95);
    s.max = *std::max_element(abs_err.begin(), abs_err.end());
    s.mean_signed = signed_sum / static_cast<double>(abs_err.size());
  }
  return s;
}

/// Interior of a width x height image without `margin` px on top/bottom/right
/// and `margin + left_extra` px on the left.
inline cv::Rect interior(int width, int height, int margin, int left_extra = 0) {
  return cv::Rect(margin + left_extra, margin, width - 2 * margin - left_extra,
                  height - 2 * margin);
}

/// Max of |a - b| over two CV_32F images of equal size, NaNs equal to NaNs;
/// +inf when one is NaN and the other not.
inline double maxAbsDiffNanAware(const cv::Mat& a, const cv::Mat& b) {
  double m = 0.0;
  for (int y = 0; y < a.rows; ++y) {
    for (int x = 0; x < a.cols; ++x) {
      const float va = a.at<float>(y, x), vb = b.at<float>(y, x);
      if (std::isnan(va) || std::isnan(vb)) {
        if (std::isnan(va) != std::isnan(vb)) return INFINITY;
        continue;
      }
      m = std::max(m, static_cast<double>(std::fabs(va - vb)));
    }
  }
  return m;
}

/// Bit-exact equality of two images (type, size and bytes), NaNs included.
inline bool identical(const cv::Mat& a, const cv::Mat& b) {
  if (a.empty() && b.empty()) return true;
  if (a.type() != b.type() || a.size() != b.size()) return false;
  const size_t row_bytes = a.cols * a.elemSize();
  for (int y = 0; y < a.rows; ++y) {
    if (std::memcmp(a.ptr(y), b.ptr(y), row_bytes) != 0) return false;
  }
  return true;
}

/// Runs `f` and returns the message of the std::invalid_argument it throws;
/// "<no exception>" or "<other exception: ...>" otherwise, so that a test can
/// check both the type and a substring in one expectation.
template <typename F>
std::string invalidArgumentMessage(F&& f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  } catch (const std::exception& e) {
    return std::string("<other exception: ") + e.what() + ">";
  } catch (...) {
    return "<other exception>";
  }
  return "<no exception>";
}

/// A unique path under the system temp directory, removed (recursively) on
/// destruction. `suffix` becomes the file extension, e.g. ".yaml".
class TempPath {
 public:
  explicit TempPath(const std::string& suffix = "") {
    static int counter = 0;
    const auto stamp = std::to_string(std::random_device{}()) + "_" + std::to_string(++counter);
    path_ = (std::filesystem::temp_directory_path() / ("bdis_test_" + stamp + suffix)).string();
  }
  ~TempPath() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempPath(const TempPath&) = delete;
  TempPath& operator=(const TempPath&) = delete;
  const std::string& str() const { return path_; }
  /// Writes `text` to the path and returns it.
  const std::string& write(const std::string& text) const {
    std::ofstream(path_, std::ios::binary) << text;
    return path_;
  }

 private:
  std::string path_;
};

inline bool contains(const std::string& haystack, const std::string& needle) {
  return haystack.find(needle) != std::string::npos;
}

/// Disparities over the whole range a consumer must handle: estimates in
/// [0, 80), no estimate (-1), `at_infinity` (cx - cx_right of the test's
/// camera: depth at or beyond infinity) and NaN, each kind at random.
inline cv::Mat mixedDisparity(int rows, int cols, uint64_t seed, float at_infinity) {
  cv::RNG rng(seed);
  cv::Mat d(rows, cols, CV_32FC1);
  for (int y = 0; y < rows; ++y) {
    for (int x = 0; x < cols; ++x) {
      const int kind = rng.uniform(0, 10);
      float v = rng.uniform(0.f, 80.f);
      if (kind == 0) v = -1.f;  // bdis::kNoDisparity
      if (kind == 1) v = at_infinity;
      if (kind == 2) v = std::numeric_limits<float>::quiet_NaN();
      d.at<float>(y, x) = v;
    }
  }
  return d;
}

}  // namespace bdis_test
