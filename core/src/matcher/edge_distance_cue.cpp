#include "edge_distance_cue.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "box_sums.hpp"       // blocksToPixels, distanceForwardRow, jumpFlags
#include "patch_kernels.hpp"  // BDIS_ROW_LOOP

namespace bdis {
namespace detail {
namespace {

/// A distance no frame reaches: a frame without a jump keeps its confidence.
constexpr float kFarBlocks = 1e6f;

/// 1 for the pixels of a block row's two rows at a jump: `left_*` hold each
/// row's horizontal pairs shifted by one (entry x: the pair x - 1, x; 0 at
/// both ends), so that entries x and x + 1 are the pixel's two pairs; `above`,
/// `between` and `below` the vertical pairs with the row above, between the
/// two rows and with the row below.
BDIS_ROW_LOOP
void pixelMarks(int w, const unsigned char* __restrict left_0, const unsigned char* __restrict left_1,
                const unsigned char* __restrict above, const unsigned char* __restrict between,
                const unsigned char* __restrict below, unsigned char* __restrict marks) {
  for (int x = 0; x < w; ++x) {
    marks[x] = left_0[x] | left_0[x + 1] | left_1[x] | left_1[x + 1] | above[x] | between[x] | below[x];
  }
}

BDIS_ROW_LOOP
void factorRow(int bw, const float* __restrict blocks, float halving, float* __restrict factor) {
  for (int bx = 0; bx < bw; ++bx) {
    const float distance = 2.f * blocks[bx] + 0.5f;  // level px
    factor[bx] = distance / (distance + halving);
  }
}

BDIS_ROW_LOOP
void multiplyRow(int w, const float* __restrict factor, float* __restrict confidence) {
  for (int x = 0; x < w; ++x) confidence[x] *= factor[x];
}

}  // namespace

void EdgeDistanceCue::markBlockRow(const cv::Mat1f& d, int by, float jump, float* blocks) {
  const int w = d.cols, h = d.rows;
  const int y0 = 2 * by, y1 = y0 + 1;
  unsigned char* left_0 = rows_[kLeft0];
  unsigned char* left_1 = rows_[kLeft1];
  unsigned char* between = rows_[kBetween];
  unsigned char* below = rows_[kBelow];
  unsigned char* marks = rows_[kMarks];
  jumpFlags(w - 1, d[y0], d[y0] + 1, jump, left_0 + 1);
  if (y1 < h) {
    jumpFlags(w - 1, d[y1], d[y1] + 1, jump, left_1 + 1);
    jumpFlags(w, d[y0], d[y1], jump, between);
  }
  if (y1 + 1 < h) jumpFlags(w, d[y1], d[y1 + 1], jump, below);
  // Pairs beyond the last row: none.
  const size_t row_bytes = static_cast<size_t>(flags_.cols);
  if (y1 >= h) {
    std::memset(left_1, 0, row_bytes);
    std::memset(between, 0, row_bytes);
  }
  if (y1 + 1 >= h) std::memset(below, 0, row_bytes);
  pixelMarks(w, left_0, left_1, rows_[kAbove], between, below, marks);
  for (int bx = 0; bx < (w + 1) / 2; ++bx) blocks[bx] = (marks[2 * bx] | marks[2 * bx + 1]) ? 0.f : kFarBlocks;
  // The next block row's pairs with the row above are this one's with the row below.
  std::swap(rows_[kAbove], rows_[kBelow]);
}

void EdgeDistanceCue::apply(const cv::Mat1f& disparity, float jump, float halving, cv::Mat1f& confidence) {
  CV_Assert(confidence.size() == disparity.size());
  const int w = disparity.cols, h = disparity.rows;
  const int bw = (w + 1) / 2, bh = (h + 1) / 2;
  block_distance_.create(bh, bw);
  // One column more than the row: the shifted pairs' last 0, a last odd block's second pixel.
  flags_.create(kFlagRows, w + 1);
  std::memset(flags_.data, 0, flags_.total());  // (Mat::setTo allocates at some widths)
  for (int r = 0; r < kFlagRows; ++r) rows_[r] = flags_[r];
  block_factor_.resize(static_cast<size_t>(bw));
  factor_.resize(static_cast<size_t>(w));
  // Blocks at a jump start at 0, the others far; then the forward pass.
  for (int by = 0; by < bh; ++by) {
    float* row = block_distance_[by];
    markBlockRow(disparity, by, jump, row);
    distanceForwardRow(bw, by > 0 ? block_distance_[by - 1] : nullptr, row);
  }
  // The backward pass, then each block row's factor onto its pixel rows.
  for (int by = bh - 1; by >= 0; --by) {
    float* row = block_distance_[by];
    distanceBackwardRow(bw, by + 1 < bh ? block_distance_[by + 1] : nullptr, row);
    factorRow(bw, row, halving, block_factor_.data());
    blocksToPixels(w, block_factor_.data(), factor_.data());
    for (int y = 2 * by; y < std::min(2 * by + 2, h); ++y) multiplyRow(w, factor_.data(), confidence[y]);
  }
}

}  // namespace detail
}  // namespace bdis
