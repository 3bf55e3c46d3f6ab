// libFuzzer target over the ROS-free core: bdis::Matcher::compute and the
// geometry (disparityToDepth, disparityToPoints) on inputs decoded from the
// fuzzer's bytes: image size (mostly 32..96 px a side, sometimes from 1 px),
// type (mostly 8-bit mono or BGR, sometimes a type the matcher must refuse or
// mismatched sides), contents (the input's bytes repeated as the left image,
// its copy shifted by up to 40 px as the right one, black rectangles in
// either), every MatcherParams field through bdis::paramFields() (mostly in
// range, sometimes out of range, NaN or infinite), a second parameter set and
// a cropped view for a second frame on the same matcher, and a stereo camera.
//
// Contract checked: invalid parameters, inputs or cameras throw
// std::invalid_argument, valid ones never throw, and the outputs keep their
// documented ranges. Any other exception, a crash, or an ASan/UBSan report
// is a finding (the fuzzer stops and writes the input).
//
// Built by scripts/fuzz.sh (fuzz/CMakeLists.txt, clang, -fsanitize=fuzzer).
#include <fuzzer/FuzzedDataProvider.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "bdis_stereo/geometry.hpp"
#include "bdis_stereo/matcher.hpp"
#include "bdis_stereo/params.hpp"

namespace {

constexpr int kMaxSide = 96;  // small images: many runs per second
/// Patch pixel-steps one search pass may take (about 4 times the default
/// parameters at 96x96): see capIterations.
constexpr double kPassBudget = 2e6;

[[noreturn]] void finding(const std::string& what) {
  std::fprintf(stderr, "FINDING: %s\n", what.c_str());
  std::fflush(stderr);
  std::abort();
}

void check(bool ok, const std::string& what) {
  if (!ok) finding(what);
}

/// A value that no field accepts, or that breaks a conversion: NaN, infinities,
/// beyond the int range, just outside the field's range, a fraction for an int.
double unusualValue(FuzzedDataProvider& in, const bdis::ParamField& f) {
  const double span = f.max_value - f.min_value;
  switch (in.ConsumeIntegralInRange<int>(0, 7)) {
    case 0: return std::numeric_limits<double>::quiet_NaN();
    case 1: return std::numeric_limits<double>::infinity();
    case 2: return -std::numeric_limits<double>::infinity();
    case 3: return in.ConsumeBool() ? 1e300 : -1e300;
    case 4: return in.ConsumeBool() ? 2147483648.0 : -2147483649.0;
    case 5: return f.min_value - span * in.ConsumeProbability<double>() - 1e-6;
    case 6: return f.max_value + span * in.ConsumeProbability<double>() + 1e-6;
    default: return in.ConsumeFloatingPoint<double>();
  }
}

/// Every field set through paramFields(): in range, except with probability
/// 1/8 per parameter set, where a few fields get an unusual value. Pyramid
/// levels are mostly ordered (finest <= coarsest) so most sets are valid.
bdis::MatcherParams decodeParams(FuzzedDataProvider& in) {
  bdis::MatcherParams p;
  for (const bdis::ParamField& f : bdis::paramFields()) {
    if (in.ConsumeIntegralInRange<int>(0, 3) == 0) continue;  // keep the default
    double v = f.min_value + (f.max_value - f.min_value) * in.ConsumeProbability<double>();
    if (f.type != bdis::ParamField::Type::Float) v = std::round(v);
    f.set(p, v);
  }
  if (in.ConsumeIntegralInRange<int>(0, 7) != 0 && p.finest_level > p.coarsest_level) {
    std::swap(p.finest_level, p.coarsest_level);
  }
  if (in.ConsumeIntegralInRange<int>(0, 7) == 7) {
    const auto& fields = bdis::paramFields();
    const int corrupted = in.ConsumeIntegralInRange<int>(1, 3);
    for (int i = 0; i < corrupted; ++i) {
      const bdis::ParamField& f =
          fields[in.ConsumeIntegralInRange<size_t>(0, fields.size() - 1)];
      f.set(p, unusualValue(in, f));
    }
  }
  return p;
}

bool paramsValid(const bdis::MatcherParams& p) {
  try {
    p.validate();
    return true;
  } catch (const std::invalid_argument&) {
    return false;
  }
}

/// Iterations are a loop bound: past a few, more only costs time. So that no
/// input takes seconds (many small patches, many iterations, a wide window),
/// they are lowered until one pass fits kPassBudget patch pixel-steps.
/// Invalid sets are left as they are (capping could make them valid).
void capIterations(bdis::MatcherParams& p, cv::Size size) {
  if (!paramsValid(p)) return;
  const int stride = std::max(1, static_cast<int>(std::lround(p.patch_size * (1.0 - p.overlap))));
  const int finest = std::clamp(p.finestLevelFor(size.width), 0, 10);
  // Patches of the finest level, plus a third for the coarser ones.
  const double patches = 4.0 / 3.0 * (1.0 + (size.width >> finest) / stride) *
                         (1.0 + (size.height >> finest) / stride);
  const double window = 2.0 * std::clamp(p.window_half_width, 0, 100) + 1.0;
  const double steps = kPassBudget / (patches * p.patch_size * p.patch_size) - window;
  p.iterations = std::min(p.iterations, std::max(1, static_cast<int>(steps)));
}

/// Left: the pixel bytes repeated over the image (or a constant), with a
/// black rectangle; right: the left shifted by `shift` px, with its own black
/// rectangle and the uncovered columns from the bytes again.
struct Images {
  cv::Mat left, right;
  bool valid_input = false;  ///< what the matcher must accept
};

cv::Rect decodeRect(FuzzedDataProvider& in, cv::Size size) {
  if (in.ConsumeIntegralInRange<int>(0, 2) != 2) return {};  // mostly none
  const int x = in.ConsumeIntegralInRange<int>(0, size.width);
  const int y = in.ConsumeIntegralInRange<int>(0, size.height);
  const int w = in.ConsumeIntegralInRange<int>(0, size.width - x);
  const int h = in.ConsumeIntegralInRange<int>(0, size.height - y);
  return {x, y, w, h};
}

int decodeUnsupportedType(FuzzedDataProvider& in) {
  static const int types[] = {CV_16UC1, CV_16UC3, CV_32FC1, CV_32FC3, CV_8UC2,
                              CV_8UC4,  CV_8SC1,  CV_64FC1, CV_16SC3};
  return types[in.ConsumeIntegralInRange<size_t>(0, std::size(types) - 1)];
}

Images decodeImages(FuzzedDataProvider& in) {
  Images img;
  // Mostly kMinImageSide..kMaxSide (32 when the input is used up); 1 in 16
  // sizes from 1 px, which the matcher must refuse below kMinImageSide.
  const bool any_size = in.ConsumeIntegralInRange<int>(0, 15) == 15;
  auto side = [&] {
    return any_size ? in.ConsumeIntegralInRange<int>(1, kMaxSide)
                    : in.ConsumeIntegralInRange<int>(bdis::kMinImageSide, kMaxSide);
  };
  const cv::Size size(side(), side());
  const int channels = in.ConsumeBool() ? 3 : 1;
  int left_type = CV_8UC(channels), right_type = left_type;
  cv::Size right_size = size;
  switch (in.ConsumeIntegralInRange<int>(0, 15)) {
    case 13: left_type = right_type = decodeUnsupportedType(in); break;
    case 14: right_type = channels == 3 ? CV_8UC1 : CV_8UC3; break;  // mono with colour
    case 15:
      right_size = cv::Size(in.ConsumeIntegralInRange<int>(1, kMaxSide),
                            in.ConsumeIntegralInRange<int>(1, kMaxSide));
      break;
    default: break;
  }
  const int shift = in.ConsumeIntegralInRange<int>(0, 40);
  const cv::Rect left_black = decodeRect(in, size), right_black = decodeRect(in, right_size);
  const bool constant = in.ConsumeIntegralInRange<int>(0, 15) == 15;
  const std::vector<uint8_t> bytes = in.ConsumeRemainingBytes<uint8_t>();

  // Fill as 8-bit first, then convert: any depth gets the same structure.
  // 0 is black (outside the rectified view): only the rectangles make it.
  auto byteAt = [&](size_t i) -> uint8_t {
    if (bytes.empty()) return 128;
    const uint8_t b = constant ? bytes[0] : bytes[i % bytes.size()];
    return b == 0 ? 1 : b;
  };
  cv::Mat left8(size, CV_8UC(channels)), right8(right_size, CV_8UC(channels));
  size_t next = 0;
  for (int y = 0; y < size.height; ++y) {
    uint8_t* row = left8.ptr<uint8_t>(y);
    for (int i = 0; i < size.width * channels; ++i) row[i] = byteAt(next++);
  }
  for (int y = 0; y < right_size.height; ++y) {
    uint8_t* row = right8.ptr<uint8_t>(y);
    for (int x = 0; x < right_size.width; ++x) {
      const int xl = x + shift;  // right(x) = left(x + d)
      for (int c = 0; c < channels; ++c) {
        row[x * channels + c] = xl < size.width && y < size.height
                                    ? left8.ptr<uint8_t>(y)[xl * channels + c]
                                    : byteAt(next++);
      }
    }
  }
  left8(left_black & cv::Rect({}, size)).setTo(0);
  right8(right_black & cv::Rect({}, right_size)).setTo(0);

  auto convert = [](const cv::Mat& src8, int type) {
    cv::Mat out;
    if (CV_MAT_CN(type) == src8.channels()) {
      src8.convertTo(out, type);
    } else {
      // Channel count changes: take channel 0 (or replicate it).
      cv::Mat first;
      cv::extractChannel(src8, first, 0);
      std::vector<cv::Mat> planes(static_cast<size_t>(CV_MAT_CN(type)), first);
      cv::Mat merged;
      cv::merge(planes, merged);
      merged.convertTo(out, type);
    }
    return out;
  };
  img.left = convert(left8, left_type);
  img.right = convert(right8, right_type);
  img.valid_input = left_type == right_type && size == right_size &&
                    (left_type == CV_8UC1 || left_type == CV_8UC3) &&
                    size.width >= bdis::kMinImageSide && size.height >= bdis::kMinImageSide;
  return img;
}

/// The documented ranges of a result for inputs of `size`.
void checkResult(const bdis::MatchResult& r, const cv::Mat& left, const bdis::MatcherParams& params) {
  const bool variance = params.compute_variance;
  const cv::Size size = left.size();
  check(r.disparity.type() == CV_32FC1 && r.disparity.size() == size, "disparity type/size");
  check(r.confidence.type() == CV_32FC1 && r.confidence.size() == size, "confidence type/size");
  check(variance ? r.variance.type() == CV_32FC1 && r.variance.size() == size : r.variance.empty(),
        "variance present iff compute_variance");
  for (int y = 0; y < size.height; ++y) {
    const float* d = r.disparity.ptr<float>(y);
    const float* c = r.confidence.ptr<float>(y);
    const float* v = variance ? r.variance.ptr<float>(y) : nullptr;
    const uint8_t* px = left.ptr<uint8_t>(y);
    for (int x = 0; x < size.width; ++x) {
      // Messages built only on failure: this loop runs for every pixel.
      auto fail = [&](const std::string& what, float value) {
        finding(what + " " + std::to_string(value) + " at (" + std::to_string(x) + ", " +
                std::to_string(y) + ")");
      };
      bool black = true;
      for (int ch = 0; ch < left.channels(); ++ch) black &= px[x * left.channels() + ch] == 0;
      if (d[x] == bdis::kNoDisparity) {
        if (c[x] != 0.f) fail("confidence without an estimate:", c[x]);
        if (v && !std::isnan(v[x])) fail("variance without an estimate:", v[x]);
        continue;
      }
      if (black) fail("estimate on a black (outside the view) pixel:", d[x]);
      if (!(d[x] >= 0.f && d[x] <= static_cast<float>(size.width))) {
        fail("disparity outside [0, width]:", d[x]);
      }
      if (!(c[x] >= 0.f && c[x] <= 1.f + 1e-5f)) fail("confidence outside [0, 1]:", c[x]);
      if (c[x] < params.min_confidence) fail("estimate below min_confidence:", c[x]);
      if (v && !(std::isfinite(v[x]) && v[x] >= 0.f)) fail("variance not finite or < 0:", v[x]);
    }
  }
}

/// Must throw std::invalid_argument when `expect_throw`, and not throw otherwise.
template <typename F>
void expectInvalidArgument(bool expect_throw, const char* what, F&& call) {
  try {
    call();
  } catch (const std::invalid_argument& e) {
    if (!expect_throw) finding(std::string(what) + " rejected a valid input: " + e.what());
    return;
  }
  if (expect_throw) finding(std::string(what) + " accepted an invalid input");
}

bdis::StereoCamera decodeCamera(FuzzedDataProvider& in, bool& valid) {
  bdis::StereoCamera cam = bdis::StereoCamera::symmetric(
      in.ConsumeFloatingPointInRange<double>(1.0, 4000.0),
      in.ConsumeFloatingPointInRange<double>(1.0, 4000.0),
      in.ConsumeFloatingPointInRange<double>(-100.0, 200.0),
      in.ConsumeFloatingPointInRange<double>(-100.0, 200.0),
      in.ConsumeFloatingPointInRange<double>(1e-4, 1.0));
  cam.cx_right = cam.cx + in.ConsumeFloatingPointInRange<double>(-50.0, 50.0);
  valid = true;
  if (in.ConsumeIntegralInRange<int>(0, 5) == 5) {
    // One field anything at all: 0, negative, huge, NaN, infinite.
    double* fields[] = {&cam.fx, &cam.fy, &cam.cx, &cam.cy, &cam.cx_right, &cam.baseline};
    double& f = *fields[in.ConsumeIntegralInRange<size_t>(0, std::size(fields) - 1)];
    f = in.ConsumeFloatingPoint<double>();
    if (in.ConsumeIntegralInRange<int>(0, 3) == 3) f = std::numeric_limits<double>::quiet_NaN();
    valid = std::isfinite(cam.fx) && std::isfinite(cam.fy) && std::isfinite(cam.cx) &&
            std::isfinite(cam.cy) && std::isfinite(cam.cx_right) &&
            std::isfinite(cam.baseline) && cam.fx > 0 && cam.fy > 0 && cam.baseline > 0 &&
            std::isfinite(cam.fx * cam.baseline);  // each finite, the product may still overflow
  }
  return cam;
}

void checkGeometry(const cv::Mat& disparity, const bdis::StereoCamera& cam, bool camera_valid) {
  const bool disparity_valid = !disparity.empty() && disparity.type() == CV_32FC1;
  cv::Mat depth, points;
  expectInvalidArgument(!(camera_valid && disparity_valid), "disparityToDepth",
                        [&] { bdis::disparityToDepth(disparity, cam, depth); });
  expectInvalidArgument(!(camera_valid && disparity_valid), "disparityToPoints",
                        [&] { bdis::disparityToPoints(disparity, cam, points); });
  if (!(camera_valid && disparity_valid)) return;
  check(depth.size() == disparity.size() && points.size() == disparity.size(), "geometry size");
  for (int y = 0; y < disparity.rows; ++y) {
    for (int x = 0; x < disparity.cols; ++x) {
      const float z = depth.at<float>(y, x);
      const cv::Vec3f p = points.at<cv::Vec3f>(y, x);
      // NaN where unknown, else >= 0 (0 and infinity only at the float limits,
      // e.g. an infinite disparity).
      if (!(std::isnan(z) || z >= 0.f)) finding("negative depth " + std::to_string(z));
      const bool point_ok =
          std::isnan(z) ? std::isnan(p[0]) && std::isnan(p[1]) && std::isnan(p[2]) : p[2] == z;
      if (!point_ok) finding("point z differs from depth " + std::to_string(z));
    }
  }
}

/// Disparity images that did not come from the matcher: any float value (NaN,
/// infinite, negative), sometimes empty or of the wrong type.
cv::Mat decodeDisparity(FuzzedDataProvider& in) {
  const int rows = in.ConsumeIntegralInRange<int>(0, 8), cols = in.ConsumeIntegralInRange<int>(0, 8);
  const int type = in.ConsumeIntegralInRange<int>(0, 5) == 5 ? CV_64FC1 : CV_32FC1;
  cv::Mat d(rows, cols, type);
  for (int y = 0; y < rows; ++y) {
    for (int x = 0; x < cols; ++x) {
      const float v = in.ConsumeIntegralInRange<int>(0, 3) == 3
                          ? std::numeric_limits<float>::quiet_NaN()
                          : in.ConsumeFloatingPoint<float>();
      if (type == CV_32FC1) d.at<float>(y, x) = v; else d.at<double>(y, x) = v;
    }
  }
  return d;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  FuzzedDataProvider in(data, size);
  // Integral values come from the end of the input, the pixel bytes (last
  // decoded) from the front: the two do not fight over the same bytes. Once
  // the input is used up every choice reads 0, so 0 picks the common case
  // (32x32 px mono, default parameters, a valid camera).
  bdis::MatcherParams params = decodeParams(in);
  bdis::MatcherParams second_params = decodeParams(in);
  bool camera_valid = false;
  const bdis::StereoCamera camera = decodeCamera(in, camera_valid);
  const cv::Mat foreign_disparity = decodeDisparity(in);
  const bool crop = in.ConsumeBool();
  const int crop_x = in.ConsumeIntegralInRange<int>(0, kMaxSide),
            crop_y = in.ConsumeIntegralInRange<int>(0, kMaxSide);
  const Images img = decodeImages(in);
  capIterations(params, img.left.size());
  capIterations(second_params, img.left.size());

  const bool valid = paramsValid(params);
  expectInvalidArgument(!valid, "Matcher(params)", [&] { bdis::Matcher m(params); });
  checkGeometry(foreign_disparity, camera, camera_valid);
  if (!valid) return 0;

  bdis::Matcher matcher(params);
  bdis::MatchResult result;
  expectInvalidArgument(!img.valid_input, "compute",
                        [&] { matcher.compute(img.left, img.right, result); });
  if (img.valid_input) {
    checkResult(result, img.left, params);
    checkGeometry(result.disparity, camera, camera_valid);
  }

  // The same matcher and result again: other parameters, and a sub-image
  // (a view with a row pitch wider than its row) of another size.
  const bool second_valid = paramsValid(second_params);
  expectInvalidArgument(!second_valid, "setParams", [&] { matcher.setParams(second_params); });
  cv::Mat left = img.left, right = img.right;
  if (crop && img.valid_input) {
    const cv::Rect roi(std::min(crop_x, left.cols - 1), std::min(crop_y, left.rows - 1),
                       left.cols, left.rows);
    left = left(roi & cv::Rect({}, left.size()));
    right = right(roi & cv::Rect({}, right.size()));
  }
  const bool second_input_valid = img.valid_input && left.cols >= bdis::kMinImageSide &&
                                  left.rows >= bdis::kMinImageSide;
  expectInvalidArgument(!second_input_valid, "compute (second frame)",
                        [&] { matcher.compute(left, right, result); });
  if (second_input_valid) {
    checkResult(result, left, matcher.params());
  }
  return 0;
}
