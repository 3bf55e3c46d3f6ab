#include "slant_cue.hpp"

#include <algorithm>
#include <cmath>

#include "confidence.hpp"
#include "patch_kernels.hpp"  // BDIS_ROW_LOOP

namespace bdis {
namespace detail {
namespace {

/// The bend of the box means around the centre, r to each side: their
/// discrete Laplacian (px of disparity), 0 unless all four neighbours exist.
inline float bend(float left, float right, float above, float below, float centre) {
  const bool all = left >= 0.f && right >= 0.f && above >= 0.f && below >= 0.f;
  return all ? left + right + above + below - 4.f * centre : 0.f;
}

/// The squared and the absolute gradient of two rows (g1 may be g0 again,
/// with weight 0: the last block row of an odd height) summed per 2 x 2
/// block: columns w of the rows, bw blocks (an odd width's last block has
/// one column).
void blockGradientRow(int w, int bw, const float* g0, const float* g1, float g1_weight, std::vector<float>& pairs,
                      float* squares, float* magnitudes) {
  pairs.resize(static_cast<size_t>(2 * bw));
  for (int x = 0; x < w; ++x) pairs[static_cast<size_t>(x)] = g0[x] * g0[x] + g1_weight * g1[x] * g1[x];
  columnPairsToBlocks(w, bw, pairs.data(), squares);
  for (int x = 0; x < w; ++x) pairs[static_cast<size_t>(x)] = std::fabs(g0[x]) + g1_weight * std::fabs(g1[x]);
  columnPairsToBlocks(w, bw, pairs.data(), magnitudes);
}

/// mean(g^2) / mean(|g|)^2 of a Gaussian texture (or noise): pi / 2.
constexpr float kGaussianPeakedness = 1.5707963f;
/// Below this mean |g| (grey levels per level px, under what 8-bit grey
/// levels resolve) a box counts as flat: no edge in it, peakedness 0.
constexpr float kFlatMeanGradient = 0.05f;

/// The pixels a box of blocks b - rb .. b + rb covers, clipped to n pixels.
inline float clippedPixels(int b, int n, int rb) {
  return static_cast<float>(std::min(2 * (b + rb) + 1, n - 1) - 2 * std::max(b - rb, 0) + 1);
}

/// Per block, the factor of the four agreements, and the squared slope
/// (per level px). `mean`, `above` and `below` point at block 0 of padded
/// block-mean rows (rb blocks of kNoDisparity before and after).
BDIS_ROW_LOOP
void slantFactorRow(int bw, int rb, const float* __restrict above, const float* __restrict mean,
                    const float* __restrict below, float inv_halving_sq, const float* __restrict gradient_sq_sum,
                    const float* __restrict gradient_abs_sum, const float* __restrict inv_box_columns,
                    float inv_box_rows, float inv_misfit_halving_sq, float inv_bend_halving_sq,
                    float inv_lone_edge_halving_sq, float* __restrict factor, float* __restrict slopes_sq) {
  const float inv_step = 1.f / static_cast<float>(2 * rb);
  for (int x = 0; x < bw; ++x) {
    const float gx = slopeAcross(mean[x - rb], mean[x], mean[x + rb], inv_step);
    const float gy = slopeAcross(above[x], mean[x], below[x], inv_step);
    const float slope_sq = gx * gx + gy * gy;
    slopes_sq[x] = slope_sq;
    const float inv_box_pixels = inv_box_columns[x] * inv_box_rows;
    const float gradient_sq = gradient_sq_sum[x] * inv_box_pixels;
    const float gradient_abs = gradient_abs_sum[x] * inv_box_pixels;
    const float b = bend(mean[x - rb], mean[x + rb], above[x], below[x], mean[x]);
    const float peakedness =
        gradient_abs > kFlatMeanGradient ? gradient_sq / (gradient_abs * gradient_abs) : 0.f;
    const float lone_edge = std::max(peakedness - kGaussianPeakedness, 0.f);
    // The four agreements' product over one division: agreement(s, k) = 1 / (1 + s k).
    factor[x] = 1.f / ((1.f + slope_sq * inv_halving_sq) * (1.f + slope_sq * gradient_sq * inv_misfit_halving_sq) *
                       (1.f + b * b * inv_bend_halving_sq) * (1.f + lone_edge * lone_edge * inv_lone_edge_halving_sq));
  }
}

}  // namespace

void SlantCue::apply(const cv::Mat1f& disparity, const cv::Mat1f& gradient, int patch_px, float halving,
                     float misfit_halving, float bend_halving, float lone_edge_halving, cv::Mat1f& confidence) {
  const int w = disparity.cols, h = disparity.rows;
  const int bw = (w + 1) / 2, bh = (h + 1) / 2;  // 2 x 2 blocks
  // The box about a patch side, the slope's step half of one.
  const int rb = halfPatchInBlocks(patch_px);
  boxMeansOfBlockEstimates(disparity, rb, blocks_, sums_, mean_);

  // The box sums of the squared and the absolute gradient, over the clipped
  // box's pixels.
  gradient_sums_.begin(bw, bh, rb, /*with_b=*/true);
  inv_box_columns_.resize(static_cast<size_t>(bw));
  for (int bx = 0; bx < bw; ++bx) inv_box_columns_[static_cast<size_t>(bx)] = 1.f / clippedPixels(bx, w, rb);
  factor_.resize(static_cast<size_t>(bw));
  slopes_sq_.create(bh, bw);

  // agreement(|grad D| * patch_px, halving) = agreement(|grad D|, halving / patch_px),
  // and likewise for the misfit |grad D| * patch_px * g.
  const float slope_halving = halving / static_cast<float>(patch_px);
  const float inv_halving_sq = 1.f / (slope_halving * slope_halving);
  const float slope_gradient_halving = misfit_halving / static_cast<float>(patch_px);
  const float inv_misfit_halving_sq = 1.f / (slope_gradient_halving * slope_gradient_halving);
  const float inv_bend_halving_sq = 1.f / (bend_halving * bend_halving);
  const float inv_lone_edge_halving_sq = 1.f / (lone_edge_halving * lone_edge_halving);
  const float* none = mean_[bh] + rb;
  gradient_sums_.sweep(
      [&](int by, float* gradient_sq, float* gradient_abs) {
        const int y1 = std::min(2 * by + 1, h - 1);
        blockGradientRow(w, bw, gradient[2 * by], gradient[y1], y1 > 2 * by ? 1.f : 0.f, pairs_, gradient_sq,
                         gradient_abs);
      },
      [&](int by, const float* gradient_sq_sum, const float* gradient_abs_sum) {
        slantFactorRow(bw, rb, by >= rb ? mean_[by - rb] + rb : none, mean_[by] + rb,
                       by + rb < bh ? mean_[by + rb] + rb : none, inv_halving_sq, gradient_sq_sum, gradient_abs_sum,
                       inv_box_columns_.data(), 1.f / clippedPixels(by, h, rb), inv_misfit_halving_sq,
                       inv_bend_halving_sq, inv_lone_edge_halving_sq, factor_.data(), slopes_sq_[by]);
        multiplyBlockRowAtEstimates(by, factor_.data(), pixel_factor_, disparity, confidence);
      });
}

}  // namespace detail
}  // namespace bdis
