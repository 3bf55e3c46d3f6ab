#include "residual_fit_cue.hpp"

#include <algorithm>
#include <cmath>

#include "confidence.hpp"
#include "patch_kernels.hpp"  // BDIS_ROW_LOOP

namespace bdis {
namespace detail {
namespace {

/// sum[x] / count[x] / 2 in place (a finest-level mean in the coarser
/// level's px); -1 where the count is 0.
BDIS_ROW_LOOP
void halvedMeanRow(int w, const float* __restrict count, float* __restrict sum) {
  for (int x = 0; x < w; ++x) sum[x] = count[x] > 0.f ? 0.5f * sum[x] / count[x] : -1.f;
}

/// What one level row contributes to the fit, per pixel: the weight (1 where
/// the residual can be read), g, g^2, the residual r, g r and r^2, all 0 where
/// it cannot: no estimate, an invalid left pixel, a match column outside
/// the right view or next to an invalid right pixel.
void productsRow(int w, const float* disparity, const float* left, const float* gx, const uchar* left_valid,
                 const float* right, const uchar* right_valid, float* const* products) {
  for (int x = 0; x < w; ++x) {
    const float d = disparity[x];
    const float xs = static_cast<float>(x) - d;
    const int x0 = static_cast<int>(std::floor(xs));
    const int xc = std::min(std::max(x0, 0), w - 2);  // a column to read either way
    const bool usable = d >= 0.f && left_valid[x] && x0 == xc && right_valid[xc] && right_valid[xc + 1];
    const float f = xs - static_cast<float>(xc);
    const float residual = usable ? right[xc] + f * (right[xc + 1] - right[xc]) - left[x] : 0.f;
    const float g = usable ? gx[x] : 0.f;
    products[0][x] = usable ? 1.f : 0.f;
    products[1][x] = g;
    products[2][x] = g * g;
    products[3][x] = residual;
    products[4][x] = g * residual;
    products[5][x] = residual * residual;
  }
}

/// Per pixel of a row, from the column sums of the products (each padded
/// with R zeros each side) over the box's rows: the horizontal box sums and
/// their moments in u (the column's offset from the box centre), then the
/// least-squares fit r = o + g a + g u b (the offset o eliminated first, so
/// that float keeps the precision). The factor is agreement() of b as a
/// disparity change across a patch (`patch_px` b, `inv_slant_halving_sq`)
/// times agreement() of the variance a patch's footprint would give the
/// shift, the box's variance of a scaled by its samples over a patch's
/// (`footprint_scale`, to finest-level px^2; `inv_error_halving_sq`). A box
/// with fewer usable pixels than `min_count`, or whose texture cannot tell a
/// shift from a slope, gets 1: no say. R is the box radius; R = 0 takes
/// `radius` instead (a radius not compiled in).
template <int R>
BDIS_ROW_LOOP void factorRow(int w, int radius, const float* const* columns, float min_count, float patch_px,
                             float inv_slant_halving_sq, float footprint_scale, float inv_error_halving_sq,
                             float* __restrict factor) {
  const int r = R > 0 ? R : radius;
  const float *cw = columns[0], *cg = columns[1], *cgg = columns[2], *cr = columns[3], *cgr = columns[4];
  const float* crr = columns[5];
  for (int x = 0; x < w; ++x) {
    float n = 0, sg = 0, sgu = 0, sgg = 0, sggu = 0, sgguu = 0, tr = 0, tgr = 0, tgru = 0, trr = 0;
    // Unrolled, the loop over x vectorises (17 taps are past GCC's own limit).
#pragma GCC unroll 24
    for (int k = 0; k <= 2 * r; ++k) {
      const float u = static_cast<float>(k - r);
      const int i = x + k;  // columns are padded: index x + k is column x + k - r
      n += cw[i];
      sg += cg[i];
      sgu += u * cg[i];
      sgg += cgg[i];
      sggu += u * cgg[i];
      sgguu += u * u * cgg[i];
      tr += cr[i];
      tgr += cgr[i];
      tgru += u * cgr[i];
      trr += crr[i];
    }
    const float inv_n = 1.f / std::max(n, 1.f);
    const float a11 = sgg - sg * sg * inv_n;
    const float a12 = sggu - sg * sgu * inv_n;
    const float a22 = sgguu - sgu * sgu * inv_n;
    const float b1 = tgr - sg * tr * inv_n;
    const float b2 = tgru - sgu * tr * inv_n;
    const float det = a11 * a22 - a12 * a12;
    const bool fitted = n >= min_count && det > 1e-4f * a11 * a22;
    const float inv_det = 1.f / (fitted ? det : 1.f);
    const float a = (a22 * b1 - a12 * b2) * inv_det;
    const float b = (a11 * b2 - a12 * b1) * inv_det;
    const float change = b * patch_px;
    // The residual's variance left after the fit, and a's under it.
    const float unexplained = std::max(trr - tr * tr * inv_n - a * b1 - b * b2, 0.f);
    const float noise = unexplained / std::max(n - 3.f, 1.f);
    const float shift_variance = noise * a22 * inv_det * footprint_scale;
    const float slant = 1.f / (1.f + change * change * inv_slant_halving_sq);
    const float precision = 1.f / (1.f + shift_variance * inv_error_halving_sq);
    factor[x] = fitted ? slant * precision : 1.f;
  }
}

BDIS_ROW_LOOP
void scaleRow(int w, const float* __restrict disparity, const float* __restrict factor, float* __restrict confidence) {
  for (int x = 0; x < w; ++x) confidence[x] *= disparity[x] >= 0.f ? factor[x] : 1.f;
}

}  // namespace

void ResidualFitCue::apply(const cv::Mat1f& disparity, const PyramidLevel& coarser, int patch_px, float slant_halving,
                           float error_halving, cv::Mat1f& confidence) {
  CV_Assert(confidence.size() == disparity.size());
  const int w = disparity.cols, h = disparity.rows;
  const int wc = coarser.width, hc = coarser.height;
  CV_Assert(wc >= 2 && wc <= (w + 1) / 2 && hc >= 1 && hc <= (h + 1) / 2);
  // Every other row of the coarser level: the slope is along x, and the box
  // is tall enough that half its rows measure it nearly as well (the
  // generated scenes and the colon sequences rank within 0.1 of all rows)
  // at half the work.
  const int rows = (hc + 1) / 2;
  const int r = patch_px, ry = patch_px / 2;  // ry in sampled rows: the same height
  const int padded_w = wc + 2 * r;
  products_.create(kProducts * rows, wc);
  columns_.assign(static_cast<size_t>(kProducts * padded_w), 0.f);  // the padding stays 0
  block_disparity_.resize(static_cast<size_t>(wc));
  block_count_.resize(static_cast<size_t>(wc));
  block_factor_.resize(static_cast<size_t>(wc));
  factor_.resize(static_cast<size_t>(w));
  auto product_row = [&](int k, int j) { return products_[k * rows + j]; };
  float* columns[kProducts];
  for (int k = 0; k < kProducts; ++k) columns[k] = columns_.data() + static_cast<size_t>(k * padded_w) + r;

  for (int j = 0; j < rows; ++j) {
    const int y = 2 * j;
    // The block's mean estimate, halved to the coarser level's px; -1 where none.
    blocks_.row(disparity, y, wc, block_disparity_.data(), block_count_.data());
    halvedMeanRow(wc, block_count_.data(), block_disparity_.data());
    float* out[kProducts];
    for (int k = 0; k < kProducts; ++k) out[k] = product_row(k, j);
    productsRow(wc, block_disparity_.data(), coarser.leftRow(y), coarser.gradientRow(y), coarser.leftValidRow(y),
                coarser.rightRow(y), coarser.rightValidRow(y), out);
  }

  const float min_count = static_cast<float>(2 * r + 1);
  const float inv_slant_halving_sq = 1.f / (slant_halving * slant_halving);
  const float inv_error_halving_sq = 1.f / (error_halving * error_halving);
  // a's variance from the box, scaled to a patch's footprint: the box's
  // sampled pixels, each standing for two of the coarser level (every
  // other row), over a patch's (p / 2)^2 pixels there, and from
  // coarser-level px^2 to finest-level px^2. A box with holes has fewer
  // samples and so a wider error: its shift is known less well.
  const float box_samples = static_cast<float>((2 * ry + 1) * (2 * r + 1));
  const float footprint_scale = box_samples * 2.f / (0.25f * static_cast<float>(patch_px * patch_px)) * 4.f;
  const float* padded_columns[kProducts];
  for (int k = 0; k < kProducts; ++k) padded_columns[k] = columns[k] - r;
  for (int j = 0; j < rows; ++j) {
    // The box's rows: the column sums slide down one row in, one row out.
    if (j == 0) {
      for (int i = 0; i < std::min(rows, ry); ++i) {
        for (int k = 0; k < kProducts; ++k) addRow(wc, product_row(k, i), columns[k]);
      }
    }
    for (int k = 0; k < kProducts; ++k) {
      if (j + ry < rows) addRow(wc, product_row(k, j + ry), columns[k]);
      if (j - ry - 1 >= 0) subtractRow(wc, product_row(k, j - ry - 1), columns[k]);
    }
    if (r == 8) {  // the default patch side's box, unrolled
      factorRow<8>(wc, r, padded_columns, min_count, static_cast<float>(patch_px), inv_slant_halving_sq,
                   footprint_scale, inv_error_halving_sq, block_factor_.data());
    } else {
      factorRow<0>(wc, r, padded_columns, min_count, static_cast<float>(patch_px), inv_slant_halving_sq,
                   footprint_scale, inv_error_halving_sq, block_factor_.data());
    }
    // Columns past the last whole block repeat the last block.
    blocksToPixels(std::min(w, 2 * wc), block_factor_.data(), factor_.data());
    std::fill(factor_.begin() + std::min(w, 2 * wc), factor_.end(), block_factor_[static_cast<size_t>(wc - 1)]);
    // Sampled row j serves coarser rows 2j and 2j + 1, finest rows 4j to
    // 4j + 3; the last one also the rows a floor-halved height left over.
    const int yf_end = j + 1 == rows ? h : std::min(4 * j + 4, h);
    for (int yf = 4 * j; yf < yf_end; ++yf) scaleRow(w, disparity[yf], factor_.data(), confidence[yf]);
  }
}

}  // namespace detail
}  // namespace bdis
