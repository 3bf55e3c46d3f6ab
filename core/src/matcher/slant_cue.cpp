#include "slant_cue.hpp"

#include <algorithm>

#include "confidence.hpp"
#include "patch_kernels.hpp"        // BDIS_ROW_LOOP

namespace bdis {
namespace detail {
namespace {

BDIS_ROW_LOOP
void squaredRow(int w, const float* __restrict values, float* __restrict squares) {
  for (int x = 0; x < w; ++x) squares[x] = values[x] * values[x];
}

/// How many of the indices i - r .. i + r lie in 0 .. n-1.
inline float clippedSpan(int i, int n, int r) {
  return static_cast<float>(std::min(i + r, n - 1) - std::max(i - r, 0) + 1);
}

/// The bend of the box means around the centre, r to each side: their
/// discrete Laplacian (px of disparity), 0 unless all four neighbours exist.
inline float bend(float left, float right, float above, float below, float centre) {
  const bool all = left >= 0.f && right >= 0.f && above >= 0.f && below >= 0.f;
  return all ? left + right + above + below - 4.f * centre : 0.f;
}

/// `mean`, `above` and `below` point at column 0 of padded mean rows (r
/// columns of kNoDisparity before and after).
BDIS_ROW_LOOP
void slantRow(int w, int r, const float* __restrict above, const float* __restrict mean,
              const float* __restrict below, const float* __restrict disparity, float inv_halving_sq,
              const float* __restrict gradient_sq_sum, const float* __restrict inv_box_columns,
              float inv_box_rows, float inv_misfit_halving_sq, float inv_bend_halving_sq,
              float* __restrict confidence) {
  const float inv_step = 1.f / static_cast<float>(r);
  for (int x = 0; x < w; ++x) {
    const float gx = slopeAcross(mean[x - r], mean[x], mean[x + r], inv_step);
    const float gy = slopeAcross(above[x], mean[x], below[x], inv_step);
    const float slope_sq = gx * gx + gy * gy;
    const float gradient_sq = gradient_sq_sum[x] * (inv_box_columns[x] * inv_box_rows);
    const float b = bend(mean[x - r], mean[x + r], above[x], below[x], mean[x]);
    // The three agreements' product over one division: agreement(s, k) = 1 / (1 + s k).
    const float c = confidence[x] / ((1.f + slope_sq * inv_halving_sq) *
                                     (1.f + slope_sq * gradient_sq * inv_misfit_halving_sq) *
                                     (1.f + b * b * inv_bend_halving_sq));
    confidence[x] = disparity[x] >= 0.f ? c : confidence[x];
  }
}

}  // namespace

void SlantCue::apply(const cv::Mat1f& disparity, const cv::Mat1f& gradient, int patch_px, float halving,
                     float misfit_halving, float bend_halving, cv::Mat1f& confidence) {
  const int w = disparity.cols, h = disparity.rows;
  const int r = std::max(1, patch_px / 2);
  boxMeansOfEstimates(disparity, r, sums_, mean_);

  // The box sums of the squared gradient, over the clipped box's area
  // clippedSpan(x) * clippedSpan(y): its columns' and rows' reciprocals.
  gradient_sums_.begin(w, h, r, /*with_b=*/false);
  inv_box_columns_.resize(static_cast<size_t>(w));
  for (int x = 0; x < w; ++x) inv_box_columns_[static_cast<size_t>(x)] = 1.f / clippedSpan(x, w, r);

  // agreement(|grad D| * patch_px, halving) = agreement(|grad D|, halving / patch_px),
  // and likewise for the misfit |grad D| * patch_px * g.
  const float slope_halving = halving / static_cast<float>(patch_px);
  const float inv_halving_sq = 1.f / (slope_halving * slope_halving);
  const float slope_gradient_halving = misfit_halving / static_cast<float>(patch_px);
  const float inv_misfit_halving_sq = 1.f / (slope_gradient_halving * slope_gradient_halving);
  const float inv_bend_halving_sq = 1.f / (bend_halving * bend_halving);
  const float* none = mean_[h] + r;
  gradient_sums_.sweep([&](int y, float* gradient_sq, float*) { squaredRow(w, gradient[y], gradient_sq); },
                       [&](int y, const float* gradient_sq_sum, const float*) {
                         slantRow(w, r, y >= r ? mean_[y - r] + r : none, mean_[y] + r,
                                  y + r < h ? mean_[y + r] + r : none, disparity[y], inv_halving_sq,
                                  gradient_sq_sum, inv_box_columns_.data(), 1.f / clippedSpan(y, h, r),
                                  inv_misfit_halving_sq,
                                  inv_bend_halving_sq, confidence[y]);
                       });
}

}  // namespace detail
}  // namespace bdis
