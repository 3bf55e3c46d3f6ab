#include "texture_centroid_correction.hpp"

#include <algorithm>

#include "patch_kernels.hpp"  // BDIS_ROW_LOOP

namespace bdis {
namespace detail {
namespace {

/// The squared gradient where the pixel is valid, 0 where it is not.
BDIS_ROW_LOOP
void energyRow(int w, const float* __restrict gx, const uchar* __restrict valid, float* __restrict energy) {
  for (int x = 0; x < w; ++x) energy[x] = valid[x] ? gx[x] * gx[x] : 0.f;
}

/// Over the 2r + 1 columns around each pixel of a padded row (column x at
/// padded[x + r]): the sum, and the sum times the column's offset. R > 0 is
/// r known when compiling (the default patch side's), whose unrolled taps
/// let the loop over x vectorise; R = 0 takes `radius`.
template <int R>
BDIS_ROW_LOOP void horizontalMomentsRow(int w, int radius, const float* __restrict padded, float* __restrict sum,
                                        float* __restrict moment) {
  const int r = R > 0 ? R : radius;
  for (int x = 0; x < w; ++x) {
    float s = 0.f, m = 0.f;
#pragma GCC unroll 16
    for (int k = 0; k <= 2 * r; ++k) {
      s += padded[x + k];
      m += static_cast<float>(k - r) * padded[x + k];
    }
    sum[x] = s;
    moment[x] = m;
  }
}

/// The box's rows summed in place, n of them at offsets first, first + 1,
/// ... from the centre row: the energy, its x moment, and the energy times
/// the row's offset. Each output is one sum over the rows, with no sliding
/// sum whose rounding the large sums of textured rows would leave behind.
/// N > 0 is n known when compiling (the whole box of the default patch side).
template <int N>
BDIS_ROW_LOOP void verticalMomentsRow(int w, int rows, int first, const float* const* energy,
                                      const float* const* moment_x, float* __restrict sum,
                                      float* __restrict sum_x, float* __restrict sum_y) {
  const int n = N > 0 ? N : rows;
  for (int x = 0; x < w; ++x) {
    float s = 0.f, sx = 0.f, sy = 0.f;
#pragma GCC unroll 16
    for (int j = 0; j < n; ++j) {
      s += energy[j][x];
      sx += moment_x[j][x];
      sy += static_cast<float>(first + j) * energy[j][x];
    }
    sum[x] = s;
    sum_x[x] = sx;
    sum_y[x] = sy;
  }
}

/// An estimate d moved back along the slope (gx, gy) by its box's texture
/// centroid offset (sum_x, sum_y) / sum, by at most max_shift; holes stay.
inline float centroidCorrected(float d, float gx, float gy, float sum, float sum_x, float sum_y, float max_shift) {
  // No texture, no centroid: a box whose squared gradients sum to less
  // than 1e-3 (grey levels per px, squared) moves nothing.
  const bool textured = sum > 1e-3f;
  const float inv_sum = 1.f / (textured ? sum : 1.f);
  const float offset = textured ? (gx * sum_x + gy * sum_y) * inv_sum : 0.f;
  const float shift = std::min(std::max(offset, -max_shift), max_shift);
  return d >= 0.f ? std::max(d - shift, 0.f) : d;
}

/// Columns [begin, end) of one row, each with the slope at its own column.
/// `mean`, `above` and `below` point at column 0 of padded box-mean rows.
BDIS_ROW_LOOP
void correctRow(int begin, int end, int r, const float* __restrict above, const float* __restrict mean,
                const float* __restrict below, const float* __restrict sum, const float* __restrict sum_x,
                const float* __restrict sum_y, float max_shift, float* __restrict disparity) {
  const float inv_step = 1.f / static_cast<float>(r);
  for (int x = begin; x < end; ++x) {
    const float gx = slopeAcross(mean[x - r], mean[x], mean[x + r], inv_step);
    const float gy = slopeAcross(above[x], mean[x], below[x], inv_step);
    disparity[x] = centroidCorrected(disparity[x], gx, gy, sum[x], sum_x[x], sum_y[x], max_shift);
  }
}

/// Columns [begin, end) of one row with the slope along x of column
/// `slope_column` (along y each its own).
void correctColumnsWithSlopeOf(int slope_column, int begin, int end, int r, const float* above, const float* mean,
                               const float* below, const float* sum, const float* sum_x, const float* sum_y,
                               float max_shift, float* disparity) {
  const float inv_step = 1.f / static_cast<float>(r);
  const float gx = slopeAcross(mean[slope_column - r], mean[slope_column], mean[slope_column + r], inv_step);
  for (int x = begin; x < end; ++x) {
    const float gy = slopeAcross(above[x], mean[x], below[x], inv_step);
    disparity[x] = centroidCorrected(disparity[x], gx, gy, sum[x], sum_x[x], sum_y[x], max_shift);
  }
}

/// The pixels nearer a side than `3 r` take the slope there. Within r of
/// the side the estimates lean towards the inside (the patches covering
/// them all lie further in, so they flatten a slope towards the side:
/// what this correction undoes), and every box mean whose box reaches that
/// strip carries it into the slope, as does a box clipped by the side.
/// From 3 r in, the central difference's boxes (r either way, radius r)
/// reach neither. 0 where the map is too small to have both sides' columns
/// apart: every pixel its own slope.
int sideStrip(int size, int r) { return size > 6 * r + 1 ? 3 * r : 0; }

}  // namespace

void TextureCentroidCorrection::apply(const PyramidLevel& level, int patch_px, float max_shift,
                                      cv::Mat1f& disparity) {
  const int w = disparity.cols, h = disparity.rows;
  CV_Assert(level.left_gx.size() == disparity.size() && level.left_valid.size() == disparity.size());
  const int r = std::max(1, patch_px / 2);
  const int ring = 2 * r + 1;
  if (w < ring || h < ring) return;  // no whole box: nothing to correct against
  boxMeansOfEstimates(disparity, r, sums_, mean_);  // before any estimate moves
  padded_.assign(static_cast<size_t>(w + 2 * r), 0.f);
  energy_.create(ring, w);
  moment_x_.create(ring, w);
  sum_.resize(static_cast<size_t>(w));
  sum_x_.resize(static_cast<size_t>(w));
  sum_y_.resize(static_cast<size_t>(w));
  energy_rows_.resize(static_cast<size_t>(ring));
  moment_rows_.resize(static_cast<size_t>(ring));
  auto horizontal = [&](int y) {
    float* sum = energy_[y % ring];
    float* moment = moment_x_[y % ring];
    energyRow(w, level.left_gx[y], level.left_valid[y], padded_.data() + r);
    if (r == 4) {
      horizontalMomentsRow<4>(w, r, padded_.data(), sum, moment);
    } else {
      horizontalMomentsRow<0>(w, r, padded_.data(), sum, moment);
    }
    // Within r of a side, the box lies against it, as the patches covering
    // the pixel do: the window of the first (last) whole box, its moment
    // taken about the pixel.
    for (int x = 0; x < r; ++x) {
      sum[x] = sum[r];
      moment[x] = moment[r] + static_cast<float>(r - x) * sum[r];
    }
    for (int x = w - r; x < w; ++x) {
      sum[x] = sum[w - 1 - r];
      moment[x] = moment[w - 1 - r] + static_cast<float>(w - 1 - r - x) * sum[w - 1 - r];
    }
  };
  const float* none = mean_[h] + r;
  const int strip_columns = sideStrip(w, r), strip_rows = sideStrip(h, r);
  int next = 0;  // the next row whose horizontal sums the ring gets
  for (int y = 0; y < h; ++y) {
    // The box's rows, likewise against the top or bottom within r of them.
    const int top = std::min(std::max(0, y - r), h - ring);
    for (; next < top + ring; ++next) horizontal(next);  // overwrites rows above the box
    for (int j = 0; j < ring; ++j) {
      energy_rows_[static_cast<size_t>(j)] = energy_[(top + j) % ring];
      moment_rows_[static_cast<size_t>(j)] = moment_x_[(top + j) % ring];
    }
    if (r == 4) {
      verticalMomentsRow<9>(w, ring, top - y, energy_rows_.data(), moment_rows_.data(), sum_.data(), sum_x_.data(),
                            sum_y_.data());
    } else {
      verticalMomentsRow<0>(w, ring, top - y, energy_rows_.data(), moment_rows_.data(), sum_.data(), sum_x_.data(),
                            sum_y_.data());
    }
    // The slopes of rows within the strip by a side are those of the row
    // the strip ends at, for the same reason as the columns'.
    const int ys = std::min(std::max(y, strip_rows), h - 1 - strip_rows);
    const float* above = ys >= r ? mean_[ys - r] + r : none;
    const float* mean = mean_[ys] + r;
    const float* below = ys + r < h ? mean_[ys + r] + r : none;
    correctRow(strip_columns, w - strip_columns, r, above, mean, below, sum_.data(), sum_x_.data(), sum_y_.data(),
               max_shift, disparity[y]);
    if (strip_columns > 0) {
      correctColumnsWithSlopeOf(strip_columns, 0, strip_columns, r, above, mean, below, sum_.data(), sum_x_.data(),
                                sum_y_.data(), max_shift, disparity[y]);
      correctColumnsWithSlopeOf(w - 1 - strip_columns, w - strip_columns, w, r, above, mean, below, sum_.data(),
                                sum_x_.data(), sum_y_.data(), max_shift, disparity[y]);
    }
  }
}

}  // namespace detail
}  // namespace bdis
