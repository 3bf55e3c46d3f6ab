#include "slant_cue.hpp"

#include <algorithm>

#include "bdis_stereo/matcher.hpp"  // kNoDisparity
#include "confidence.hpp"
#include "patch_kernels.hpp"        // BDIS_ROW_LOOP

namespace bdis {
namespace detail {
namespace {

/// out[x] = sum of padded[x .. x + side - 1], summed in that order.
BDIS_ROW_LOOP
void boxRow(int w, int side, const float* __restrict padded, float* __restrict out) {
  for (int x = 0; x < w; ++x) out[x] = 0.f;
  for (int k = 0; k < side; ++k) {
    for (int x = 0; x < w; ++x) out[x] += padded[x + k];
  }
}

BDIS_ROW_LOOP
void addRow(int w, const float* __restrict row, float* __restrict sum) {
  for (int x = 0; x < w; ++x) sum[x] += row[x];
}

BDIS_ROW_LOOP
void subtractRow(int w, const float* __restrict row, float* __restrict sum) {
  for (int x = 0; x < w; ++x) sum[x] -= row[x];
}

BDIS_ROW_LOOP
void meanRow(int w, const float* __restrict sum, const float* __restrict count, float* __restrict mean) {
  for (int x = 0; x < w; ++x) mean[x] = count[x] > 0.5f ? sum[x] / std::max(count[x], 1.f) : kNoDisparity;
}

/// The derivative along one axis from the values `step` before and after:
/// central where both exist, one-sided against the centre where one does,
/// 0 where neither does. Branch-free.
inline float derivative(float before, float centre, float after, float inv_step) {
  const bool has_before = before >= 0.f, has_after = after >= 0.f;
  const float hi = has_after ? after : centre;
  const float lo = has_before ? before : centre;
  const float halves = has_before && has_after ? 0.5f : 1.f;
  return (hi - lo) * halves * inv_step;
}

/// `mean`, `above` and `below` point at column 0 of padded mean rows (r
/// columns of kNoDisparity before and after).
BDIS_ROW_LOOP
void slantRow(int w, int r, const float* __restrict above, const float* __restrict mean,
              const float* __restrict below, const float* __restrict disparity, float inv_halving_sq,
              float* __restrict confidence) {
  const float inv_step = 1.f / static_cast<float>(r);
  for (int x = 0; x < w; ++x) {
    const float gx = derivative(mean[x - r], mean[x], mean[x + r], inv_step);
    const float gy = derivative(above[x], mean[x], below[x], inv_step);
    const float c = confidence[x] * agreement(gx * gx + gy * gy, inv_halving_sq);
    confidence[x] = disparity[x] >= 0.f ? c : confidence[x];
  }
}

}  // namespace

void SlantCue::apply(const cv::Mat1f& disparity, int patch_px, float halving, cv::Mat1f& confidence) {
  const int w = disparity.cols, h = disparity.rows;
  const int r = std::max(1, patch_px / 2), side = 2 * r + 1;
  // Only the padding is set here; every other element is written below.
  padded_value_.resize(static_cast<size_t>(w + 2 * r));
  padded_count_.resize(static_cast<size_t>(w + 2 * r));
  for (std::vector<float>* padded : {&padded_value_, &padded_count_}) {
    std::fill(padded->begin(), padded->begin() + r, 0.f);
    std::fill(padded->end() - r, padded->end(), 0.f);
  }
  row_sum_.create(h, w);
  row_count_.create(h, w);
  column_sum_.resize(static_cast<size_t>(w));
  column_count_.resize(static_cast<size_t>(w));
  mean_.create(h + 1, w + 2 * r);
  for (int y = 0; y < h; ++y) {
    std::fill(mean_[y], mean_[y] + r, kNoDisparity);
    std::fill(mean_[y] + r + w, mean_[y] + w + 2 * r, kNoDisparity);
  }
  std::fill(mean_[h], mean_[h] + w + 2 * r, kNoDisparity);  // (setTo() would allocate)

  for (int y = 0; y < h; ++y) {
    const float* d = disparity[y];
    for (int x = 0; x < w; ++x) {
      padded_value_[static_cast<size_t>(x + r)] = d[x] >= 0.f ? d[x] : 0.f;
      padded_count_[static_cast<size_t>(x + r)] = d[x] >= 0.f ? 1.f : 0.f;
    }
    boxRow(w, side, padded_value_.data(), row_sum_[y]);
    boxRow(w, side, padded_count_.data(), row_count_[y]);
  }
  // The vertical box slides down: one row in, one row out (the counts stay
  // exact; the sums' rounding is far below what the cue resolves).
  std::fill(column_sum_.begin(), column_sum_.end(), 0.f);
  std::fill(column_count_.begin(), column_count_.end(), 0.f);
  for (int j = 0; j < std::min(h, r); ++j) {
    addRow(w, row_sum_[j], column_sum_.data());
    addRow(w, row_count_[j], column_count_.data());
  }
  for (int y = 0; y < h; ++y) {
    if (y + r < h) {
      addRow(w, row_sum_[y + r], column_sum_.data());
      addRow(w, row_count_[y + r], column_count_.data());
    }
    if (y - r - 1 >= 0) {
      subtractRow(w, row_sum_[y - r - 1], column_sum_.data());
      subtractRow(w, row_count_[y - r - 1], column_count_.data());
    }
    meanRow(w, column_sum_.data(), column_count_.data(), mean_[y] + r);
  }

  // agreement(|grad D| * patch_px, halving) = agreement(|grad D|, halving / patch_px).
  const float slope_halving = halving / static_cast<float>(patch_px);
  const float inv_halving_sq = 1.f / (slope_halving * slope_halving);
  const float* none = mean_[h] + r;
  for (int y = 0; y < h; ++y) {
    slantRow(w, r, y >= r ? mean_[y - r] + r : none, mean_[y] + r, y + r < h ? mean_[y + r] + r : none,
             disparity[y], inv_halving_sq, confidence[y]);
  }
}

}  // namespace detail
}  // namespace bdis
