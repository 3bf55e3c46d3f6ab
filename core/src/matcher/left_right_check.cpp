#include "left_right_check.hpp"

#include <algorithm>
#include <cmath>

#include "bdis_stereo/matcher.hpp"  // kNoDisparity
#include "patch_kernels.hpp"        // BDIS_ROW_LOOP

namespace bdis {
namespace detail {
namespace {

/// One row; branch-free, so it vectorises.
BDIS_ROW_LOOP
void leftRightCheckRow(int w, const float* __restrict mirrored, float tolerance,
                       float* __restrict disparity, float* __restrict confidence) {
  for (int x = 0; x < w; ++x) {
    const float d = disparity[x];
    const float match = static_cast<float>(x) - d + 0.5f;
    // Truncation is floor for match >= 0; d < 0 (no estimate) reads column w - 1, unused.
    const int xr = std::min(static_cast<int>(std::max(match, 0.f)), w - 1);
    const float back = mirrored[w - 1 - xr];
    const bool refuted = (d >= 0.f) & ((match < 0.f) | (back < 0.f) | (std::fabs(back - d) > tolerance));
    disparity[x] = refuted ? kNoDisparity : d;
    confidence[x] = refuted ? 0.f : confidence[x];
  }
}

}  // namespace

void leftRightCheck(const cv::Mat1f& mirrored, float tolerance, cv::Mat1f& disparity, cv::Mat1f& confidence) {
  for (int y = 0; y < disparity.rows; ++y) {
    leftRightCheckRow(disparity.cols, mirrored[y], tolerance, disparity[y], confidence[y]);
  }
}

}  // namespace detail
}  // namespace bdis
