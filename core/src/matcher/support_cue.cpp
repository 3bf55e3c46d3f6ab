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

/// The two rows the box sums count: 1 where a pixel has an estimate, and 1
/// where it could have had one (valid, or invalid but bright: clipped).
BDIS_ROW_LOOP
void indicatorRows(int w, const float* __restrict disparity, const uchar* __restrict valid,
                   const float* __restrict grey, float* __restrict estimates, float* __restrict valid_pixels) {
  for (int x = 0; x < w; ++x) {
    estimates[x] = disparity[x] >= 0.f ? 1.f : 0.f;
    valid_pixels[x] = (valid[x] != 0) | (grey[x] >= kBrightInvalidGrey) ? 1.f : 0.f;  // | : no branch
  }
}

BDIS_ROW_LOOP
void supportRow(int w, const float* __restrict estimates, const float* __restrict valid,
                const float* __restrict disparity, float inv_halving_sq, float* __restrict confidence) {
  for (int x = 0; x < w; ++x) {
    // agreement(missing share^2), the share (v - e) / v multiplied out: one division, not two.
    const float v = std::max(valid[x], 1.f);
    const float missing = std::max(0.f, v - estimates[x]);
    const float c = confidence[x] * (v * v) / (v * v + missing * missing * inv_halving_sq);
    confidence[x] = disparity[x] >= 0.f ? c : confidence[x];
  }
}

}  // namespace

void SupportCue::apply(const cv::Mat1f& disparity, const cv::Mat1b& valid, const cv::Mat1f& grey, int patch_px,
                       float halving_share, cv::Mat1f& confidence) {
  CV_Assert(valid.size() == disparity.size() && confidence.size() == disparity.size());
  const int w = disparity.cols, h = disparity.rows;
  sums_.begin(w, h, std::max(1, patch_px - 1));
  const float inv_halving_sq = 1.f / (halving_share * halving_share);
  sums_.sweep(
      [&](int y, float* estimates, float* valid_pixels) {
        indicatorRows(w, disparity[y], valid[y], grey[y], estimates, valid_pixels);
      },
      [&](int y, const float* n_estimates, const float* n_valid) {
        supportRow(w, n_estimates, n_valid, disparity[y], inv_halving_sq, confidence[y]);
      });
}

}  // namespace detail
}  // namespace bdis
