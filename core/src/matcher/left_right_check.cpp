#include "left_right_check.hpp"

#include <algorithm>
#include <cmath>

#include "bdis_stereo/matcher.hpp"  // kNoDisparity
#include "confidence.hpp"
#include "patch_kernels.hpp"        // BDIS_ROW_LOOP

namespace bdis {
namespace detail {
namespace {

/// One row; branch-free, so it vectorises.
BDIS_ROW_LOOP
void leftRightCheckRow(int w, const float* __restrict mirrored, float tolerance, float inv_halving_sq,
                       float* __restrict disparity, float* __restrict confidence) {
  for (int x = 0; x < w; ++x) {
    const float d = disparity[x];
    const float match = static_cast<float>(x) - d + 0.5f;
    // Truncation is floor for match >= 0; d < 0 (no estimate) reads column w - 1, unused.
    const int xr = std::min(static_cast<int>(std::max(match, 0.f)), w - 1);
    const float back = mirrored[w - 1 - xr];
    const float difference = back - d;
    const float c = confidence[x] * agreement(difference * difference, inv_halving_sq);
    const bool refuted = (d >= 0.f) &
        ((match < 0.f) | (back < 0.f) | (std::fabs(difference) > tolerance));
    disparity[x] = refuted ? kNoDisparity : d;
    confidence[x] = refuted ? 0.f : c;
  }
}

}  // namespace

namespace {

/// The variance of the kept estimates of one row, grown by the squared
/// left-right difference (the disparities after the check).
void addLeftRightVarianceRow(int w, const float* mirrored, const float* disparity, float* variance) {
  for (int x = 0; x < w; ++x) {
    const float d = disparity[x];
    if (d < 0.f) continue;
    const int xr = std::min(static_cast<int>(static_cast<float>(x) - d + 0.5f), w - 1);  // kept: match >= 0
    const float difference = mirrored[w - 1 - xr] - d;
    variance[x] += kLeftRightVarianceShare * difference * difference;
  }
}

}  // namespace

void leftRightCheck(const cv::Mat1f& mirrored, float tolerance, float halving, cv::Mat1f& disparity,
                    cv::Mat1f& confidence, cv::Mat1f* variance) {
  const float inv_halving_sq = 1.f / (halving * halving);
  for (int y = 0; y < disparity.rows; ++y) {
    leftRightCheckRow(disparity.cols, mirrored[y], tolerance, inv_halving_sq, disparity[y], confidence[y]);
    if (variance) addLeftRightVarianceRow(disparity.cols, mirrored[y], disparity[y], (*variance)[y]);
  }
}

}  // namespace detail
}  // namespace bdis
