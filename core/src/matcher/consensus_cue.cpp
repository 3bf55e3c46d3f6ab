#include "consensus_cue.hpp"

#include <algorithm>

#include "confidence.hpp"
#include "patch_kernels.hpp"  // BDIS_ROW_LOOP

namespace bdis {
namespace detail {
namespace {

BDIS_ROW_LOOP
void consensusRow(int w, const float* __restrict mean, const float* __restrict disparity, float inv_halving_sq,
                  float* __restrict confidence) {
  for (int x = 0; x < w; ++x) {
    const float deviation = disparity[x] - mean[x];
    const float c = confidence[x] * agreement(deviation * deviation, inv_halving_sq);
    confidence[x] = disparity[x] >= 0.f ? c : confidence[x];
  }
}

}  // namespace

void ConsensusCue::apply(const cv::Mat1f& disparity, int patch_px, float halving, cv::Mat1f& confidence) {
  CV_Assert(confidence.size() == disparity.size());
  const int w = disparity.cols, h = disparity.rows;
  const int bw = (w + 1) / 2, bh = (h + 1) / 2;  // 2 x 2 blocks
  block_mean_.resize(static_cast<size_t>(bw));
  mean_.resize(static_cast<size_t>(w));
  // A box of patch_px blocks each way: two patch sides, in pixels.
  sums_.begin(bw, bh, patch_px);
  const float inv_halving_sq = 1.f / (halving * halving);
  sums_.sweep(
      [&](int by, float* block_sum, float* block_count) { blocks_.row(disparity, by, bw, block_sum, block_count); },
      [&](int by, const float* box_sum, const float* box_count) {
        // count >= 1 wherever the block holds an estimate; elsewhere the mean is not read.
        boxMeanRow(bw, box_sum, box_count, block_mean_.data());
        blocksToPixels(w, block_mean_.data(), mean_.data());
        for (int y = 2 * by; y < std::min(2 * by + 2, h); ++y) {
          consensusRow(w, mean_.data(), disparity[y], inv_halving_sq, confidence[y]);
        }
      });
}

}  // namespace detail
}  // namespace bdis
