#include "bdis_stereo/geometry.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

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
void depthRow(const float* d, int width, double offset, double fx_baseline, float* z) {
  for (int x = 0; x < width; ++x) {
    const double shifted = static_cast<double>(d[x]) - offset;
    const float depth = static_cast<float>(fx_baseline / shifted);
    z[x] = d[x] >= 0.f && shifted > 0.0 ? depth : kNaN;
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
}

float StereoCamera::depth(float disparity) const {
  if (!(disparity >= 0.f)) return kNaN;  // also catches NaN
  const double shifted = static_cast<double>(disparity) - (cx - cx_right);
  if (shifted <= 0.0) return kNaN;  // at or beyond infinity
  return static_cast<float>(fx * baseline / shifted);
}

void disparityToDepth(const cv::Mat& disparity, const StereoCamera& camera, cv::Mat& depth) {
  requireDisparity(disparity);
  camera.validate();
  depth.create(disparity.size(), CV_32FC1);
  const double offset = camera.cx - camera.cx_right;
  const double fx_baseline = camera.fx * camera.baseline;
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

}  // namespace bdis
