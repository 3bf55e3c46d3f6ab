#include "specular_lobe_cue.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "confidence.hpp"     // agreement
#include "patch_kernels.hpp"  // BDIS_ROW_LOOP

namespace bdis {
namespace detail {
namespace {

/// A distance no frame reaches.
constexpr float kFarBlocks = 1e6f;

/// 1 where a pixel of the row is clipped (invalid and at least
/// `clipped_grey`), 0 elsewhere; returns whether any is.
BDIS_ROW_LOOP
bool clippedRow(int w, const float* __restrict grey, const uchar* __restrict valid, float clipped_grey,
                uchar* __restrict clipped) {
  uchar any = 0;
  for (int x = 0; x < w; ++x) {
    clipped[x] = static_cast<uchar>((valid[x] == 0) & (grey[x] >= clipped_grey));
    any |= clipped[x];
  }
  return any != 0;
}

/// columns[x] = a[x] + b[x], or a[x] alone on an odd last row.
BDIS_ROW_LOOP
void columnSumsRow(int w, const float* __restrict a, const float* __restrict b, bool two_rows,
                   float* __restrict columns) {
  const float take_b = two_rows ? 1.f : 0.f;
  for (int x = 0; x < w; ++x) columns[x] = a[x] + take_b * b[x];
}

/// The smooth gradient of each block (grey levels per level px: blocks are 2
/// px apart), central, one-sided at the row's ends.
void smoothGradientRow(int bw, const float* smooth, float* gradient) {
  if (bw < 2) {
    gradient[0] = 0.f;
    return;
  }
  gradient[0] = 0.5f * (smooth[1] - smooth[0]);
  for (int bx = 1; bx + 1 < bw; ++bx) gradient[bx] = 0.25f * (smooth[bx + 1] - smooth[bx - 1]);
  gradient[bw - 1] = 0.5f * (smooth[bw - 1] - smooth[bw - 2]);
}

/// Per column of the block row: the valid pixels and the sum of their
/// squared texture gradients (`gradient` less their block's smooth one,
/// given per pixel in `smooth`).
BDIS_ROW_LOOP
void textureColumnsRow(int w, const float* __restrict smooth, const float* __restrict gx0,
                       const float* __restrict gx1, const uchar* __restrict v0, const uchar* __restrict v1,
                       bool two_rows, float* __restrict valid_count, float* __restrict texture) {
  const float take_1 = two_rows ? 1.f : 0.f;
  for (int x = 0; x < w; ++x) {
    const float m0 = v0[x] ? 1.f : 0.f, m1 = v1[x] ? take_1 : 0.f;
    const float d0 = gx0[x] - smooth[x], d1 = gx1[x] - smooth[x];
    valid_count[x] = m0 + m1;
    texture[x] = m0 * d0 * d0 + m1 * d1 * d1;
  }
}

/// The blocks' valid pixel counts in `energy` times their smooth gradient squared.
BDIS_ROW_LOOP
void smoothEnergyRow(int bw, const float* __restrict gradient, float* __restrict energy) {
  for (int bx = 0; bx < bw; ++bx) energy[bx] *= gradient[bx] * gradient[bx];
}

}  // namespace

void SpecularLobeCue::markClippedBlocks(const cv::Mat1f& grey, const cv::Mat1b& valid, float clipped_grey,
                                        int& first, int& last) {
  const int w = grey.cols, h = grey.rows;
  first = distance_.rows;
  last = -1;
  for (int by = 0; by < distance_.rows; ++by) std::fill(distance_[by], distance_[by] + distance_.cols, kFarBlocks);
  clipped_.resize(static_cast<size_t>(w));
  for (int y = 0; y < h; ++y) {
    const uchar* v = valid[y];
    // Most rows hold no invalid pixel at all.
    if (std::memchr(v, 0, static_cast<size_t>(w)) == nullptr) continue;
    if (!clippedRow(w, grey[y], v, clipped_grey, clipped_.data())) continue;
    float* blocks = distance_[y / 2];
    for (int x = 0; x < w; ++x) {
      if (clipped_[static_cast<size_t>(x)]) blocks[x / 2] = 0.f;
    }
    first = std::min(first, y / 2);
    last = y / 2;
  }
}

void SpecularLobeCue::distanceTransform(int by0, int by1) {
  const int bw = distance_.cols;
  for (int by = by0; by <= by1; ++by) distanceForwardRow(bw, by > by0 ? distance_[by - 1] : nullptr, distance_[by]);
  for (int by = by1; by >= by0; --by) distanceBackwardRow(bw, by < by1 ? distance_[by + 1] : nullptr, distance_[by]);
}

void SpecularLobeCue::apply(const cv::Mat1f& disparity, const cv::Mat1f& grey, const cv::Mat1b& valid,
                            const cv::Mat1f& gradient, int saturation_grey, int patch_px, float halving,
                            cv::Mat1f& confidence) {
  CV_Assert(grey.size() == disparity.size() && valid.size() == disparity.size() &&
            gradient.size() == disparity.size() && confidence.size() == disparity.size());
  if (saturation_grey > 255 || patch_px < 1) return;  // no pixel is clipped
  const int w = disparity.cols, h = disparity.rows;
  const int bw = (w + 1) / 2, bh = (h + 1) / 2;
  distance_.create(bh, bw);
  int first = 0, last = 0;
  markClippedBlocks(grey, valid, kClippedGreyShare * static_cast<float>(saturation_grey), first, last);
  if (first > last) return;
  const int fade_px = kFadePatches * patch_px;  // level px
  const int reach = std::max(1, kReachFades * fade_px / 2);  // blocks
  const int by0 = std::max(0, first - reach), by1 = std::min(bh - 1, last + reach), rows = by1 - by0 + 1;
  distanceTransform(by0, by1);
  // exp(-2 D / fade) at the whole block distances within reach, 0 beyond: no exp per block.
  near_table_.resize(static_cast<size_t>(reach) + 2);
  for (int d = 0; d <= reach; ++d) {
    near_table_[static_cast<size_t>(d)] = std::exp(-2.f * static_cast<float>(d) / static_cast<float>(fade_px));
  }
  near_table_.back() = 0.f;
  block_factor_.resize(static_cast<size_t>(bw));
  smooth_.create(bh, bw);  // the whole level's blocks: the band's rows vary from frame to frame

  // The lobe's scale: the blocks' grey over a box of about a quarter patch each way.
  columns_.resize(static_cast<size_t>(2 * bw + 1));
  column_counts_.resize(static_cast<size_t>(2 * bw + 1));
  block_gradient_.resize(static_cast<size_t>(bw));
  pixel_gradient_.resize(static_cast<size_t>(w));
  // Pixels per block: 4, 2 in an odd width's last column; half that on an odd height's last row.
  block_pixels_.assign(static_cast<size_t>(bw), 4.f);
  if (w % 2 != 0) block_pixels_.back() = 2.f;
  smooth_sums_.begin(bw, rows, std::max(1, patch_px / 8));
  smooth_sums_.sweep(
      [&](int r, float* sum, float* count) {
        const int y0 = 2 * (by0 + r), y1 = std::min(y0 + 1, h - 1);
        columnSumsRow(w, grey[y0], grey[y1], y1 > y0, columns_.data());
        columnPairsToBlocks(w, bw, columns_.data(), sum);
        const float row_share = y1 > y0 ? 1.f : 0.5f;
        for (int b = 0; b < bw; ++b) count[b] = row_share * block_pixels_[static_cast<size_t>(b)];
      },
      [&](int r, const float* sum, const float* count) {
        float* s = smooth_[by0 + r];
        for (int bx = 0; bx < bw; ++bx) s[bx] = sum[bx] / count[bx];
      });

  // Smooth against texture energy over a box of about a patch.
  const float inv_halving_sq = 1.f / (halving * halving);
  energy_sums_.begin(bw, rows, std::max(1, patch_px / 4));
  energy_sums_.sweep(
      [&](int r, float* smooth_energy, float* texture_energy) {
        const int y0 = 2 * (by0 + r), y1 = std::min(y0 + 1, h - 1);
        smoothGradientRow(bw, smooth_[by0 + r], block_gradient_.data());
        blocksToPixels(w, block_gradient_.data(), pixel_gradient_.data());
        textureColumnsRow(w, pixel_gradient_.data(), gradient[y0], gradient[y1], valid[y0], valid[y1], y1 > y0,
                          column_counts_.data(), columns_.data());
        columnPairsToBlocks(w, bw, columns_.data(), texture_energy);
        columnPairsToBlocks(w, bw, column_counts_.data(), smooth_energy);  // the valid pixels, for now
        smoothEnergyRow(bw, block_gradient_.data(), smooth_energy);
      },
      [&](int r, const float* smooth_energy, const float* texture_energy) {
        const float* dist = distance_[by0 + r];
        bool any = false;
        for (int bx = 0; bx < bw; ++bx) {
          block_factor_[static_cast<size_t>(bx)] = 1.f;
          // The sliding sums round (box_sums.hpp): a box of zero energy may
          // sum to a little below 0.
          const float texture = std::max(texture_energy[bx], 1e-6f);
          if (!(smooth_energy[bx] > texture)) continue;
          const int k = std::min(static_cast<int>(dist[bx]), reach + 1);
          const float ratio = std::sqrt(smooth_energy[bx] / texture);
          const float excess = (ratio - 1.f) * near_table_[static_cast<size_t>(k)];
          block_factor_[static_cast<size_t>(bx)] = agreement(excess * excess, inv_halving_sq);
          any = true;
        }
        if (any) multiplyBlockRowAtEstimates(by0 + r, block_factor_.data(), pixel_factor_, disparity, confidence);
      });
}

}  // namespace detail
}  // namespace bdis
