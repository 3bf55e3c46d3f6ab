#include "neighbourhood_cue.hpp"

#include <algorithm>
#include <cmath>

#include "patch_kernels.hpp"  // BDIS_ROW_LOOP

namespace bdis {
namespace detail {
namespace {

/// c^(3/4) m^(1/4) = sqrt(c sqrt(c m)): two square roots, no pow per pixel.
BDIS_ROW_LOOP
void pooledRow(int w, const float* __restrict mean, const float* __restrict disparity, float* __restrict confidence) {
  for (int x = 0; x < w; ++x) {
    const float c = confidence[x];
    const float pooled = std::sqrt(c * std::sqrt(c * mean[x]));
    confidence[x] = disparity[x] >= 0.f ? pooled : c;
  }
}

BDIS_ROW_LOOP
void meanRow(int w, const float* __restrict sum, const float* __restrict count, float* __restrict mean) {
  // The sliding sums may round a little below 0 where the box holds only zeros.
  for (int x = 0; x < w; ++x) mean[x] = std::max(sum[x], 0.f) / std::max(count[x], 1.f);
}

}  // namespace

void NeighbourhoodCue::apply(const cv::Mat1f& disparity, int patch_px, cv::Mat1f& confidence) {
  CV_Assert(confidence.size() == disparity.size());
  const int w = disparity.cols, h = disparity.rows;
  const int bw = (w + 1) / 2, bh = (h + 1) / 2;  // 2 x 2 blocks
  block_mean_.resize(static_cast<size_t>(bw));
  mean_.resize(static_cast<size_t>(w));
  // Every block row is summed before its pixels change (BoxSums::sweep):
  // the box reads the confidences as the other cues left them. A box of
  // about a patch side.
  sums_.begin(bw, bh, halfPatchInBlocks(patch_px));
  sums_.sweep([&](int by, float* sum, float* count) { blocks_.row(disparity, confidence, by, bw, sum, count); },
              [&](int by, const float* sum, const float* count) {
                meanRow(bw, sum, count, block_mean_.data());
                blocksToPixels(w, block_mean_.data(), mean_.data());
                for (int y = 2 * by; y < std::min(2 * by + 2, h); ++y) {
                  pooledRow(w, mean_.data(), disparity[y], confidence[y]);
                }
              });
}

}  // namespace detail
}  // namespace bdis
