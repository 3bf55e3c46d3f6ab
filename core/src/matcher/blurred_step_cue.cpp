#include "blurred_step_cue.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>

#include "box_sums.hpp"       // columnPairsToBlocks, halfPatchInBlocks, multiplyBlockRowAtEstimates
#include "confidence.hpp"     // agreement, kEdgeHalvingPatches
#include "patch_kernels.hpp"  // BDIS_ROW_LOOP

namespace bdis {
namespace detail {
namespace {

constexpr float kNotCounted = std::numeric_limits<float>::infinity();

/// out[x] = the largest (kLargest) or the smallest of base[x + k step], k =
/// 0..side-1: along a padded row (step 1) or down padded rows (step: the row
/// stride). The side known when compiling keeps the running value in a
/// register: a load and a max per term, one store per value.
template <bool kLargest, int kSide>
BDIS_ROW_LOOP void extremumOfSide(int n, const float* __restrict base, std::ptrdiff_t step, float* __restrict out) {
  for (int x = 0; x < n; ++x) {
    float m = base[x];
    for (int k = 1; k < kSide; ++k) m = kLargest ? std::max(m, base[x + k * step]) : std::min(m, base[x + k * step]);
    out[x] = m;
  }
}

template <bool kLargest>
BDIS_ROW_LOOP void extremumOfAnySide(int n, int side, const float* __restrict base, std::ptrdiff_t step,
                                     float* __restrict out) {
  for (int x = 0; x < n; ++x) out[x] = base[x];
  for (int k = 1; k < side; ++k) {
    for (int x = 0; x < n; ++x) out[x] = kLargest ? std::max(out[x], base[x + k * step]) : std::min(out[x], base[x + k * step]);
  }
}

/// The boxes of the default patch side, 8: rb = 2, so 5 and 9 blocks.
template <bool kLargest>
void extremumOf(int n, int side, const float* base, std::ptrdiff_t step, float* out) {
  switch (side) {
    case 5: return extremumOfSide<kLargest, 5>(n, base, step, out);
    case 9: return extremumOfSide<kLargest, 9>(n, base, step, out);
    default: return extremumOfAnySide<kLargest>(n, side, base, step, out);
  }
}

/// The largest (kLargest) or smallest value of `in` within r blocks each way
/// (a (2r + 1)^2 box clipped to the map) into `out` (may be `in`): a pass
/// along the rows into `rows` (at least h + 2r rows of w: r rows of padding
/// above and below, set here), then one down them.
template <bool kLargest>
void boxExtremum(const cv::Mat1f& in, int r, cv::Mat1f& rows, std::vector<float>& padded, cv::Mat1f& out) {
  const int w = in.cols, h = in.rows, side = 2 * r + 1;
  CV_Assert(rows.cols == w && rows.rows >= h + 2 * r);
  // Outside the map: a value that never wins.
  const float neutral = kLargest ? -std::numeric_limits<float>::infinity() : kNotCounted;
  for (int y = 0; y < r; ++y) {
    std::fill(rows[y], rows[y] + w, neutral);
    std::fill(rows[h + r + y], rows[h + r + y] + w, neutral);
  }
  padded.assign(static_cast<size_t>(w + 2 * r), neutral);
  for (int y = 0; y < h; ++y) {
    std::copy(in[y], in[y] + w, padded.begin() + r);
    extremumOf<kLargest>(w, side, padded.data(), 1, rows[y + r]);
  }
  out.create(h, w);
  const std::ptrdiff_t stride = static_cast<std::ptrdiff_t>(rows.step1());
  for (int y = 0; y < h; ++y) extremumOf<kLargest>(w, side, rows[y], stride, out[y]);
}

/// Per column, 1 where row a or row b has no estimate, else 0.
BDIS_ROW_LOOP
void holeColumns(int w, const float* __restrict a, const float* __restrict b, float* __restrict holes) {
  for (int x = 0; x < w; ++x) holes[x] = (a[x] < 0.f) | (b[x] < 0.f) ? 1.f : 0.f;
}

/// Per block of block row `by`, the count of its columns with a pixel
/// without an estimate (0: none). `columns` is scratch of 2 bw values.
void holeBlockRow(const cv::Mat1f& d, int by, std::vector<float>& columns, float* holes) {
  const int w = d.cols, bw = (w + 1) / 2;
  columns.resize(static_cast<size_t>(2 * bw));
  holeColumns(w, d[2 * by], d[std::min(2 * by + 1, d.rows - 1)], columns.data());
  columnPairsToBlocks(w, bw, columns.data(), holes);
}

/// Per block, S where counted (no hole within rb: `near_holes` 0) into
/// `slopes` (0 where not) and `flattest` (+inf where not).
BDIS_ROW_LOOP
void countedSlopeRow(int bw, const float* __restrict slopes_sq, const float* __restrict near_holes, float patch_px,
                     float* __restrict slopes, float* __restrict flattest) {
  for (int x = 0; x < bw; ++x) {
    const float s = std::sqrt(slopes_sq[x]) * patch_px;
    const bool counted = near_holes[x] < 0.5f;
    slopes[x] = counted ? s : 0.f;
    flattest[x] = counted ? s : kNotCounted;
  }
}

/// Per block, agreement() of the excess slope, gated by the distance from the nearest jump.
BDIS_ROW_LOOP
void factorRow(int bw, const float* __restrict steepest, const float* __restrict flattest,
               const float* __restrict edge_blocks, float slope_ratio, float inv_edge_reach, float inv_halving_sq,
               float* __restrict factor) {
  for (int x = 0; x < bw; ++x) {
    // flattest is +inf where nothing within 2 rb is counted: no excess.
    const float excess = std::max(steepest[x] - slope_ratio * flattest[x], 0.f);
    const float gate = std::min(1.f, (2.f * edge_blocks[x] + 0.5f) * inv_edge_reach);
    const float e = excess * gate;
    factor[x] = agreement(e * e, inv_halving_sq);
  }
}

}  // namespace

void BlurredStepCue::apply(const cv::Mat1f& disparity, const cv::Mat1f& block_slopes_sq,
                           const cv::Mat1f& block_edge_distances, int patch_px, float slope_ratio, float halving,
                           cv::Mat1f& confidence) {
  const int w = disparity.cols, h = disparity.rows;
  const int bw = (w + 1) / 2, bh = (h + 1) / 2;
  CV_Assert(block_slopes_sq.rows == bh && block_slopes_sq.cols == bw);
  CV_Assert(block_edge_distances.rows == bh && block_edge_distances.cols == bw);
  CV_Assert(confidence.size() == disparity.size());
  CV_Assert(slope_ratio > 0.f && halving > 0.f);  // (0 x the uncounted +inf is no excess)
  const int rb = halfPatchInBlocks(patch_px);
  const float p = static_cast<float>(patch_px);

  // Room for the widest box's padding rows, 2 rb above and below.
  scratch_.create(bh + 4 * rb, bw);
  // The blocks with a hole (a count above 0), then those with one within rb.
  holes_.create(bh, bw);
  for (int by = 0; by < bh; ++by) holeBlockRow(disparity, by, padded_, holes_[by]);
  boxExtremum<true>(holes_, rb, scratch_, padded_, holes_);
  // The counted slopes, the steepest within rb and the flattest within 2 rb.
  slopes_.create(bh, bw);
  flattest_.create(bh, bw);
  for (int by = 0; by < bh; ++by) {
    countedSlopeRow(bw, block_slopes_sq[by], holes_[by], p, slopes_[by], flattest_[by]);
  }
  boxExtremum<true>(slopes_, rb, scratch_, padded_, steepest_);
  boxExtremum<false>(flattest_, 2 * rb, scratch_, padded_, flattest_);

  factor_.resize(static_cast<size_t>(bw));
  // The gate opens where the edge distance cue has halved the confidence.
  const float inv_edge_reach = 1.f / (kEdgeHalvingPatches * p);
  const float inv_halving_sq = 1.f / (halving * halving);
  for (int by = 0; by < bh; ++by) {
    factorRow(bw, steepest_[by], flattest_[by], block_edge_distances[by], slope_ratio, inv_edge_reach,
              inv_halving_sq, factor_.data());
    multiplyBlockRowAtEstimates(by, factor_.data(), pixel_factor_, disparity, confidence);
  }
}

}  // namespace detail
}  // namespace bdis
