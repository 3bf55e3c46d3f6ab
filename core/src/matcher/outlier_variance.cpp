#include "outlier_variance.hpp"

#include "patch_kernels.hpp"  // BDIS_ROW_LOOP

namespace bdis {
namespace detail {
namespace {

BDIS_ROW_LOOP
void addOutlierVarianceRow(int w, const float* __restrict disparity, const float* __restrict confidence,
                           float outlier_variance, float c_half, float* __restrict variance) {
  for (int x = 0; x < w; ++x) {
    variance[x] += disparity[x] >= 0.f ? outlier_variance * outlierProbability(confidence[x], c_half) : 0.f;
  }
}

}  // namespace

void addOutlierVariance(const cv::Mat1f& disparity, const cv::Mat1f& confidence, float outlier_variance,
                        float c_half, cv::Mat1f& variance) {
  CV_Assert(confidence.size() == disparity.size() && variance.size() == disparity.size() && c_half > 0.f);
  for (int y = 0; y < disparity.rows; ++y) {
    addOutlierVarianceRow(disparity.cols, disparity[y], confidence[y], outlier_variance, c_half, variance[y]);
  }
}

}  // namespace detail
}  // namespace bdis
