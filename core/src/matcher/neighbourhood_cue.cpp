#include "neighbourhood_cue.hpp"

#include <algorithm>
#include <cmath>

#include "patch_kernels.hpp"  // BDIS_ROW_LOOP

namespace bdis {
namespace detail {
namespace {

/// c^(3/4) m^(1/4) = sqrt(c sqrt(c m)): two square roots, no pow per pixel.
BDIS_ROW_LOOP
void pooledRow(int w, const float* __restrict sum, const float* __restrict count,
               const float* __restrict disparity, float* __restrict confidence) {
  for (int x = 0; x < w; ++x) {
    const float c = confidence[x];
    // The sliding sums may round a little below 0 where the box holds only zeros.
    const float mean = std::max(sum[x], 0.f) / std::max(count[x], 1.f);
    const float pooled = std::sqrt(c * std::sqrt(c * mean));
    confidence[x] = disparity[x] >= 0.f ? pooled : c;
  }
}

}  // namespace

void NeighbourhoodCue::apply(const cv::Mat1f& disparity, int patch_px, cv::Mat1f& confidence) {
  CV_Assert(confidence.size() == disparity.size());
  const int w = disparity.cols, h = disparity.rows;
  // Every row is summed before it is changed (BoxSums::sweep): the box
  // reads the confidences as the other cues left them.
  sums_.begin(w, h, std::max(1, patch_px / 2));
  sums_.sweep(
      [&](int y, float* value, float* count) { valuesAtEstimatesRow(w, disparity[y], confidence[y], value, count); },
      [&](int y, const float* sum, const float* count) { pooledRow(w, sum, count, disparity[y], confidence[y]); });
}

}  // namespace detail
}  // namespace bdis
