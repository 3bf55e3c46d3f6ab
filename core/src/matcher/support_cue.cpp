#include "support_cue.hpp"

#include <algorithm>

#include "confidence.hpp"
#include "patch_kernels.hpp"  // BDIS_ROW_LOOP

namespace bdis {
namespace detail {
namespace {

// An invalid pixel is outside the view (black, or the dark seam next to a
// rectification frame: grey 20 or less) or clipped (a highlight at the
// saturation grey or brighter); at a level it is the mean of 2^s x 2^s
// such pixels and valid ones. Mid-grey tells the two kinds apart.
constexpr float kBrightInvalidGrey = 128.f;

/// The row's valid span [begin, end): from its first valid pixel to its
/// last; empty (begin == end) when it has none.
void validSpan(const uchar* valid, int w, int& begin, int& end) {
  begin = 0;
  while (begin < w && !valid[begin]) ++begin;
  end = w;
  while (end > begin && !valid[end - 1]) --end;
}

/// The two rows the box sums count: `weight` where a pixel has an estimate,
/// and `weight` where it could have had one: valid; invalid but bright
/// (clipped); or invalid, not black and inside the row's valid span (below
/// the dark floor: a frame and its seam reach the row's end).
BDIS_ROW_LOOP
void indicatorRows(int w, const float* __restrict disparity, const uchar* __restrict valid,
                   const float* __restrict grey, int span_begin, int span_end, float weight,
                   float* __restrict estimates, float* __restrict valid_pixels) {
  for (int x = 0; x < w; ++x) {
    estimates[x] = disparity[x] >= 0.f ? weight : 0.f;
    const bool dark_hole = (x >= span_begin) & (x < span_end) & (grey[x] > 0.f);
    valid_pixels[x] = (valid[x] != 0) | (grey[x] >= kBrightInvalidGrey) | dark_hole ? weight : 0.f;  // | : no branch
  }
}

void indicatorRows(int w, const float* disparity, const uchar* valid, const float* grey, float weight,
                   float* estimates, float* valid_pixels) {
  int begin = 0, end = 0;
  validSpan(valid, w, begin, end);
  indicatorRows(w, disparity, valid, grey, begin, end, weight, estimates, valid_pixels);
}

/// Per block, the factor agreement(missing share) of its box's counts.
BDIS_ROW_LOOP
void supportFactorRow(int bw, const float* __restrict estimates, const float* __restrict valid, float inv_halving_sq,
                      float* __restrict factor) {
  for (int x = 0; x < bw; ++x) {
    // agreement(missing share^2), the share (v - e) / v multiplied out: one division, not two.
    const float v = std::max(valid[x], 1.f);
    const float missing = std::max(0.f, v - estimates[x]);
    factor[x] = (v * v) / (v * v + missing * missing * inv_halving_sq);
  }
}

/// Per 2 x 2 block of rows y0 and y1 (y1 may be y0 again, with weight 0:
/// the last block row of an odd height), the count of its estimates and of
/// its countable pixels; bw blocks (an odd width's last block has one column).
void blockIndicatorRow(int w, int bw, int y0, int y1, float y1_weight, const cv::Mat1f& disparity,
                       const cv::Mat1b& valid, const cv::Mat1f& grey, std::vector<float>& scratch, float* estimates,
                       float* valid_pixels) {
  scratch.resize(static_cast<size_t>(8 * bw));
  float* e0 = scratch.data();
  float* p0 = e0 + 2 * bw;
  float* e1 = p0 + 2 * bw;
  float* p1 = e1 + 2 * bw;
  indicatorRows(w, disparity[y0], valid[y0], grey[y0], 1.f, e0, p0);
  indicatorRows(w, disparity[y1], valid[y1], grey[y1], y1_weight, e1, p1);
  addRow(w, e1, e0);
  addRow(w, p1, p0);
  columnPairsToBlocks(w, bw, e0, estimates);
  columnPairsToBlocks(w, bw, p0, valid_pixels);
}

}  // namespace

void SupportCue::apply(const cv::Mat1f& disparity, const cv::Mat1b& valid, const cv::Mat1f& grey, int patch_px,
                       float halving_share, cv::Mat1f& confidence) {
  CV_Assert(valid.size() == disparity.size() && confidence.size() == disparity.size());
  const int w = disparity.cols, h = disparity.rows;
  const int bw = (w + 1) / 2, bh = (h + 1) / 2;  // 2 x 2 blocks
  // A box of about 2 patch_px - 1 pixels: what the patches covering the pixel reach.
  sums_.begin(bw, bh, std::max(1, (patch_px - 1) / 2));
  factor_.resize(static_cast<size_t>(bw));
  const float inv_halving_sq = 1.f / (halving_share * halving_share);
  sums_.sweep(
      [&](int by, float* estimates, float* valid_pixels) {
        const int y1 = std::min(2 * by + 1, h - 1);
        blockIndicatorRow(w, bw, 2 * by, y1, y1 > 2 * by ? 1.f : 0.f, disparity, valid, grey, scratch_, estimates,
                          valid_pixels);
      },
      [&](int by, const float* n_estimates, const float* n_valid) {
        supportFactorRow(bw, n_estimates, n_valid, inv_halving_sq, factor_.data());
        multiplyBlockRowAtEstimates(by, factor_.data(), pixel_factor_, disparity, confidence);
      });
}

}  // namespace detail
}  // namespace bdis
