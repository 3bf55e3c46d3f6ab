#include "block_grid_cue.hpp"

#include <algorithm>
#include <cmath>

#include "block_grid.hpp"
#include "patch_kernels.hpp"  // BDIS_ROW_LOOP

namespace bdis {
namespace detail {

namespace {

/// One row of the cue; `shift` = 1.5 blocks - aligned, so that the blocks'
/// count below is positive for any estimate (d >= 0) and truncation rounds.
BDIS_ROW_LOOP
void blockGridRow(int w, const float* __restrict d, float scale, float shift, float inv_reach, float doubt,
                  float* __restrict c) {
  const float block = static_cast<float>(kCodecBlock), inv_block = 1.f / block;
  for (int x = 0; x < w; ++x) {
    // One block and a half more than the distance from the aligned disparity
    // below (0 for kNoDisparity, whose result is not used).
    const float t = std::max(0.f, d[x] * scale + shift);
    const float nearest = block * static_cast<float>(static_cast<int>(t * inv_block));
    const float r = std::fabs(t - nearest - 0.5f * block);
    const float factor = 1.f - doubt * std::max(0.f, 1.f - r * inv_reach);
    c[x] = d[x] >= 0.f ? c[x] * factor : c[x];  // kNoDisparity: no estimate
  }
}

}  // namespace

void applyBlockGridCue(const cv::Mat1f& disparity, float level_scale, int aligned, float reach, float doubt,
                       cv::Mat1f& confidence) {
  if (aligned < 0) return;
  CV_Assert(confidence.size() == disparity.size() && reach > 0.f);
  const float shift = 1.5f * static_cast<float>(kCodecBlock) - static_cast<float>(aligned);
  for (int y = 0; y < disparity.rows; ++y) {
    blockGridRow(disparity.cols, disparity[y], level_scale, shift, 1.f / reach, doubt, confidence[y]);
  }
}

}  // namespace detail
}  // namespace bdis
