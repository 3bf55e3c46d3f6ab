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

/// One row's estimates, each with the slope (gx, gy) of its own column.
BDIS_ROW_LOOP
void correctRow(int w, const float* __restrict gx, const float* __restrict gy, const float* __restrict sum,
                const float* __restrict sum_x, const float* __restrict sum_y, float max_shift,
                float* __restrict disparity) {
  for (int x = 0; x < w; ++x) {
    disparity[x] = centroidCorrected(disparity[x], gx[x], gy[x], sum[x], sum_x[x], sum_y[x], max_shift);
  }
}

/// One row of 2 x 2 blocks' slopes from the padded box means of block rows
/// `above`, `mean`, `below` (rb apart), rb blocks (2 rb px) to each side.
/// Along x the blocks within `strip` of a side take the slope of the block
/// the strip ends at (see sideStrip); along y each its own.
BDIS_ROW_LOOP
void blockSlopesRow(int bw, int rb, int strip, const float* __restrict above, const float* __restrict mean,
                    const float* __restrict below, float* __restrict gx, float* __restrict gy) {
  const float inv_step = 1.f / static_cast<float>(2 * rb);
  for (int bx = 0; bx < bw; ++bx) gy[bx] = slopeAcross(above[bx], mean[bx], below[bx], inv_step);
  for (int bx = strip; bx < bw - strip; ++bx) gx[bx] = slopeAcross(mean[bx - rb], mean[bx], mean[bx + rb], inv_step);
  for (int bx = 0; bx < strip; ++bx) {
    gx[bx] = gx[strip];
    gx[bw - 1 - bx] = gx[bw - 1 - strip];
  }
}

/// The blocks nearer a side than `3 r` (r: the box radius and the slope's
/// step, in blocks) take the slope there. Within a half patch of the side
/// the estimates lean towards the inside (the patches covering them all lie
/// further in, so they flatten a slope towards the side: what this
/// correction undoes), and every box mean whose box reaches that strip
/// carries it into the slope, as does a box clipped by the side. From 3 r
/// in, the central difference's boxes (r either way, radius r) reach
/// neither. 0 where the map is too small to have both sides' blocks apart:
/// every block its own slope.
int sideStrip(int size, int r) { return size > 6 * r + 1 ? 3 * r : 0; }

}  // namespace

void TextureCentroidCorrection::apply(const PyramidLevel& level, int patch_px, float max_shift,
                                      cv::Mat1f& disparity) {
  const int w = disparity.cols, h = disparity.rows;
  CV_Assert(level.left_gx.size() == disparity.size() && level.left_valid.size() == disparity.size());
  const int r = std::max(1, patch_px / 2);
  const int ring = 2 * r + 1;
  if (w < ring || h < ring) return;  // no whole box: nothing to correct against
  // The slope from box means of 2 x 2 blocks: a surface's, smooth enough at
  // a block's step (as the slant cue's).
  const int bw = (w + 1) / 2, bh = (h + 1) / 2, rb = halfPatchInBlocks(patch_px);
  boxMeansOfBlockEstimates(disparity, rb, blocks_, sums_, mean_);  // before any estimate moves
  block_gx_.resize(static_cast<size_t>(bw));
  block_gy_.resize(static_cast<size_t>(bw));
  gx_.resize(static_cast<size_t>(w));
  gy_.resize(static_cast<size_t>(w));
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
  const float* none = mean_[bh] + rb;
  const int strip_columns = sideStrip(bw, rb), strip_rows = sideStrip(bh, rb);
  int next = 0;  // the next row whose horizontal sums the ring gets
  for (int y = 0; y < h; ++y) {
    if (y % 2 == 0) {
      // The slopes of block rows within the strip by a side are those of
      // the row the strip ends at, for the same reason as the columns'.
      const int by = std::min(std::max(y / 2, strip_rows), bh - 1 - strip_rows);
      blockSlopesRow(bw, rb, strip_columns, by >= rb ? mean_[by - rb] + rb : none, mean_[by] + rb,
                     by + rb < bh ? mean_[by + rb] + rb : none, block_gx_.data(), block_gy_.data());
      blocksToPixels(w, block_gx_.data(), gx_.data());
      blocksToPixels(w, block_gy_.data(), gy_.data());
    }
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
    correctRow(w, gx_.data(), gy_.data(), sum_.data(), sum_x_.data(), sum_y_.data(), max_shift, disparity[y]);
  }
}

}  // namespace detail
}  // namespace bdis
