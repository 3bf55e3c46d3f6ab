#include "bdis_stereo/geometry.hpp"

#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#include <xmmintrin.h>
#endif

#include "matcher/patch_kernels.hpp"  // BDIS_ROW_LOOP

namespace bdis {
namespace {
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

void requireDisparity(const cv::Mat& disparity) {
  if (disparity.empty() || disparity.type() != CV_32FC1) {
    throw std::invalid_argument("disparity must be a non-empty CV_32FC1 image, got " +
                                cv::typeToString(disparity.type()));
  }
}
// StereoCamera::depth over a row, without branches so that it vectorises
// (the same operations in the same order: the same values).
BDIS_ROW_LOOP
void depthRow(const float* __restrict d, int width, float offset, float fx_baseline, float* __restrict z) {
  for (int x = 0; x < width; ++x) {
    const float shifted = d[x] - offset;
    const float depth = fx_baseline / shifted;
    z[x] = d[x] >= 0.f && shifted > 0.f ? depth : kNaN;
  }
}

}  // namespace

StereoCamera StereoCamera::symmetric(double fx, double fy, double cx, double cy, double baseline) {
  StereoCamera c;
  c.fx = fx;
  c.fy = fy;
  c.cx = cx;
  c.cy = cy;
  c.cx_right = cx;
  c.baseline = baseline;
  return c;
}

void StereoCamera::validate() const {
  const std::pair<const char*, double> values[] = {{"fx", fx}, {"fy", fy}, {"cx", cx},
                                                   {"cy", cy}, {"cx_right", cx_right},
                                                   {"baseline", baseline}};
  for (const auto& [name, v] : values) {
    if (!std::isfinite(v)) throw std::invalid_argument(std::string("camera ") + name + " is not finite");
  }
  if (fx <= 0.0) throw std::invalid_argument("camera fx must be > 0, got " + std::to_string(fx));
  if (fy <= 0.0) throw std::invalid_argument("camera fy must be > 0, got " + std::to_string(fy));
  if (baseline <= 0.0) {
    throw std::invalid_argument("camera baseline must be > 0, got " + std::to_string(baseline) +
                                ": are the cameras swapped?");
  }
  // Each finite, the product can still overflow: every depth would be infinite.
  if (!std::isfinite(fx * baseline)) {
    throw std::invalid_argument("camera fx * baseline is not finite: fx or baseline is far too large");
  }
}

float StereoCamera::depth(float disparity) const {
  if (!(disparity >= 0.f)) return kNaN;  // also catches NaN
  // In float, as depthRow: four or eight at a time there, 1 ULP from the
  // double quotient (a third of the time of a 1920x1080 frame's in double).
  const float shifted = disparity - static_cast<float>(cx - cx_right);
  if (!(shifted > 0.f)) return kNaN;  // at or beyond infinity
  return static_cast<float>(fx * baseline) / shifted;
}

StereoCamera StereoCamera::subsampled(int stride) const {
  if (stride < 1) throw std::invalid_argument("stride must be >= 1, got " + std::to_string(stride));
  const double s = stride;
  StereoCamera c = *this;
  c.fx /= s;
  c.fy /= s;
  c.cx /= s;
  c.cy /= s;
  c.cx_right /= s;
  return c;
}

namespace {

// Every stride-th pixel of every stride-th row, `bytes` per pixel. With the
// size known at compile time the copy of a pixel is a load and a store, not a
// call to memcpy (a 1920x1080 cloud at stride 3 keeps 230,000 pixels).
template <std::size_t kBytes>
void subsampleFixed(const cv::Mat& source, int stride, std::size_t bytes, cv::Mat& out) {
  const std::size_t size = kBytes != 0 ? kBytes : bytes;
  const std::size_t step = size * static_cast<std::size_t>(stride);
  for (int y = 0; y < out.rows; ++y) {
    const uint8_t* from = source.ptr<uint8_t>(y * stride);
    uint8_t* to = out.ptr<uint8_t>(y);
    for (int x = 0; x < out.cols; ++x, from += step, to += size) std::memcpy(to, from, size);
  }
}

}  // namespace

void subsample(const cv::Mat& image, int stride, cv::Mat& out) {
  if (stride < 1) throw std::invalid_argument("stride must be >= 1, got " + std::to_string(stride));
  if (stride == 1) {
    if (out.data != image.data) image.copyTo(out);
    return;
  }
  // A header of its own keeps the source alive where `out` is `image`: a
  // larger stride gives another size, which create() allocates anew.
  const cv::Mat source = image;
  out.create((source.rows + stride - 1) / stride, (source.cols + stride - 1) / stride, source.type());
  const std::size_t bytes = source.elemSize();
  switch (bytes) {
    case 1:
      return subsampleFixed<1>(source, stride, bytes, out);
    case 3:  // BGR
      return subsampleFixed<3>(source, stride, bytes, out);
    case 4:  // depth, disparity
      return subsampleFixed<4>(source, stride, bytes, out);
    case 12:  // points
      return subsampleFixed<12>(source, stride, bytes, out);
    default:
      return subsampleFixed<0>(source, stride, bytes, out);
  }
}

void disparityToDepth(const cv::Mat& disparity, const StereoCamera& camera, cv::Mat& depth) {
  requireDisparity(disparity);
  camera.validate();
  depth.create(disparity.size(), CV_32FC1);
  const float offset = static_cast<float>(camera.cx - camera.cx_right);
  const float fx_baseline = static_cast<float>(camera.fx * camera.baseline);
  for (int y = 0; y < disparity.rows; ++y) {
    depthRow(disparity.ptr<float>(y), disparity.cols, offset, fx_baseline, depth.ptr<float>(y));
  }
}

void disparityToPoints(const cv::Mat& disparity, const StereoCamera& camera, cv::Mat& points) {
  requireDisparity(disparity);
  camera.validate();
  points.create(disparity.size(), CV_32FC3);
  for (int y = 0; y < disparity.rows; ++y) {
    const float* d = disparity.ptr<float>(y);
    cv::Vec3f* out = points.ptr<cv::Vec3f>(y);
    const double ny = (y - camera.cy) / camera.fy;
    for (int x = 0; x < disparity.cols; ++x) {
      const float z = camera.depth(d[x]);
      if (std::isnan(z)) {
        out[x] = cv::Vec3f(kNaN, kNaN, kNaN);
        continue;
      }
      const double nx = (x - camera.cx) / camera.fx;
      out[x] = cv::Vec3f(static_cast<float>(nx * z), static_cast<float>(ny * z), z);
    }
  }
}

// ---- Point clouds -------------------------------------------------------------

namespace {

void packColour(const cv::Vec3b& bgr, uint8_t* out) {
  const uint32_t packed =
      (static_cast<uint32_t>(bgr[2]) << 16) | (static_cast<uint32_t>(bgr[1]) << 8) | bgr[0];
  std::memcpy(out, &packed, 4);
}

// One organised row without a transform, the common case: no branch per
// point. The same arithmetic as disparityToPoints (x and y in double from the
// float depth), so the same values.
void organisedRow(const float* z, int width, const double* nx, double ny, const cv::Vec3b* bgr,
                  std::size_t point_step, uint8_t* out) {
  int x = 0;
#if defined(__SSE2__)
  if (bgr && point_step == kColouredPointBytes) {
    // Four points at a time: x, y, z and rgb as four vectors, transposed into
    // four 16-byte points. rgb (PCL: 0x00RRGGBB, little-endian) is the B, G,
    // R bytes and a 0: a 4-byte load masked, so the row's last pixel, whose
    // load would pass the row's end, is left to the loop below.
    const __m128 nan = _mm_set1_ps(kNaN);
    const __m128d ny2 = _mm_set1_pd(ny);
    const __m128i rgb_mask = _mm_set1_epi32(0x00FFFFFF);
    const uint8_t* c = bgr[0].val;
    for (; x + 4 < width; x += 4, out += 64) {
      const __m128 zv = _mm_loadu_ps(z + x);
      const __m128 valid = _mm_cmpord_ps(zv, zv);
      const __m128d z_lo = _mm_cvtps_pd(zv), z_hi = _mm_cvtps_pd(_mm_movehl_ps(zv, zv));
      const __m128 xv = _mm_movelh_ps(_mm_cvtpd_ps(_mm_mul_pd(_mm_loadu_pd(nx + x), z_lo)),
                                      _mm_cvtpd_ps(_mm_mul_pd(_mm_loadu_pd(nx + x + 2), z_hi)));
      const __m128 yv =
          _mm_movelh_ps(_mm_cvtpd_ps(_mm_mul_pd(ny2, z_lo)), _mm_cvtpd_ps(_mm_mul_pd(ny2, z_hi)));
      __m128 px = _mm_or_ps(_mm_and_ps(valid, xv), _mm_andnot_ps(valid, nan));
      __m128 py = _mm_or_ps(_mm_and_ps(valid, yv), _mm_andnot_ps(valid, nan));
      __m128 pz = _mm_or_ps(_mm_and_ps(valid, zv), _mm_andnot_ps(valid, nan));
      int32_t colour[4];
      for (int k = 0; k < 4; ++k) std::memcpy(&colour[k], c + 3 * (x + k), 4);
      __m128 pc = _mm_castsi128_ps(
          _mm_and_si128(_mm_loadu_si128(reinterpret_cast<const __m128i*>(colour)), rgb_mask));
      _MM_TRANSPOSE4_PS(px, py, pz, pc);
      _mm_storeu_ps(reinterpret_cast<float*>(out), px);
      _mm_storeu_ps(reinterpret_cast<float*>(out + 16), py);
      _mm_storeu_ps(reinterpret_cast<float*>(out + 32), pz);
      _mm_storeu_ps(reinterpret_cast<float*>(out + 48), pc);
    }
  }
#endif
  for (; x < width; ++x, out += point_step) {
    const bool valid = !std::isnan(z[x]);
    const float xyz[3] = {valid ? static_cast<float>(nx[x] * z[x]) : kNaN,
                          valid ? static_cast<float>(ny * z[x]) : kNaN, valid ? z[x] : kNaN};
    std::memcpy(out, xyz, 12);
    if (bgr) packColour(bgr[x], out + 12);
  }
}

// Any other row: dense (valid points only) and/or transformed. Returns the
// end of what it wrote.
uint8_t* generalRow(const float* z, int width, const double* nx, double ny, const cv::Vec3b* bgr,
                    bool organized, const RigidTransform* transform, std::size_t point_step, uint8_t* out) {
  for (int x = 0; x < width; ++x) {
    const bool valid = !std::isnan(z[x]);
    if (!valid && !organized) continue;
    float xyz[3] = {kNaN, kNaN, kNaN};
    if (valid) {
      xyz[0] = static_cast<float>(nx[x] * z[x]);
      xyz[1] = static_cast<float>(ny * z[x]);
      xyz[2] = z[x];
      if (transform) {
        const double* r = transform->r;
        const double* t = transform->t;
        const float a = xyz[0], b = xyz[1], c = xyz[2];
        xyz[0] = static_cast<float>(r[0] * a + r[1] * b + r[2] * c + t[0]);
        xyz[1] = static_cast<float>(r[3] * a + r[4] * b + r[5] * c + t[1]);
        xyz[2] = static_cast<float>(r[6] * a + r[7] * b + r[8] * c + t[2]);
      }
    }
    std::memcpy(out, xyz, 12);
    if (bgr) packColour(bgr[x], out + 12);
    out += point_step;
  }
  return out;
}

void requireDepth(const cv::Mat& depth) {
  if (depth.type() != CV_32FC1) {
    throw std::invalid_argument("depth must be a CV_32FC1 image, got " + cv::typeToString(depth.type()));
  }
}

}  // namespace

std::size_t pointCount(const cv::Mat& depth, bool organized) {
  requireDepth(depth);
  if (organized) return depth.total();
  std::size_t count = 0;
  for (int y = 0; y < depth.rows; ++y) {
    const float* z = depth.ptr<float>(y);
    for (int x = 0; x < depth.cols; ++x) count += std::isnan(z[x]) ? 0 : 1;
  }
  return count;
}

void writePointCloud(const cv::Mat& depth, const StereoCamera& camera, const cv::Mat& bgr, bool organized,
                     const RigidTransform* transform, std::size_t point_step, uint8_t* out) {
  requireDepth(depth);
  camera.validate();
  const bool colour = !bgr.empty();
  if (colour && (bgr.type() != CV_8UC3 || bgr.size() != depth.size())) {
    throw std::invalid_argument("colour image must be CV_8UC3 of the depth's size");
  }
  if (point_step < (colour ? kColouredPointBytes : kPointBytes)) {
    throw std::invalid_argument("point_step " + std::to_string(point_step) + " is too small for the fields");
  }
  // Per thread and kept: a caller's frame loop allocates it once, not per frame.
  thread_local std::vector<double> nx;
  nx.resize(static_cast<std::size_t>(depth.cols));
  for (int x = 0; x < depth.cols; ++x) nx[x] = (x - camera.cx) / camera.fx;
  for (int y = 0; y < depth.rows; ++y) {
    const float* z = depth.ptr<float>(y);
    const cv::Vec3b* c = colour ? bgr.ptr<cv::Vec3b>(y) : nullptr;
    const double ny = (y - camera.cy) / camera.fy;
    if (organized && !transform) {
      organisedRow(z, depth.cols, nx.data(), ny, c, point_step, out);
      out += static_cast<std::size_t>(depth.cols) * point_step;
    } else {
      out = generalRow(z, depth.cols, nx.data(), ny, c, organized, transform, point_step, out);
    }
  }
}

}  // namespace bdis
