#include "outlier_variance.hpp"

#include <algorithm>
#include <cmath>

#include "patch_kernels.hpp"  // BDIS_ROW_LOOP

namespace bdis {
namespace detail {
namespace {

BDIS_ROW_LOOP
void addOutlierVarianceRow(int w, const float* __restrict disparity, const float* __restrict confidence,
                           float outlier_variance, float inv_c_half, float* __restrict variance) {
  for (int x = 0; x < w; ++x) {
    const float q = 1.f / (1.f + std::sqrt(std::max(confidence[x], 0.f) * inv_c_half));
    variance[x] += disparity[x] >= 0.f ? outlier_variance * q : 0.f;
  }
}

}  // namespace

float outlierProbability(float confidence, float c_half) {
  return 1.f / (1.f + std::sqrt(std::max(confidence, 0.f) / c_half));
}

void addOutlierVariance(const cv::Mat1f& disparity, const cv::Mat1f& confidence, float outlier_variance,
                        float c_half, cv::Mat1f& variance) {
  CV_Assert(confidence.size() == disparity.size() && variance.size() == disparity.size() && c_half > 0.f);
  const float inv_c_half = 1.f / c_half;
  for (int y = 0; y < disparity.rows; ++y) {
    addOutlierVarianceRow(disparity.cols, disparity[y], confidence[y], outlier_variance, inv_c_half, variance[y]);
  }
}

}  // namespace detail
}  // namespace bdis
