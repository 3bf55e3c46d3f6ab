#include "view_gain.hpp"

#include <algorithm>
#include <cmath>

namespace bdis {
namespace detail {

float ViewGainEstimator::estimate(const PyramidLevel& L, const cv::Mat1f& disparity) {
  CV_Assert(disparity.rows == L.height && disparity.cols == L.width && L.first_row == 0);
  const float log_min = std::log(kGainMin);
  const float bins_per_log = static_cast<float>(kBins) / (std::log(kGainMax) - log_min);
  histogram_.fill(0);
  const int blocks_x = L.width / kGainBlock, blocks_y = L.height / kGainBlock;
  int counted = 0;
  for (int by = 0; by < blocks_y; ++by) {
    for (int bx = 0; bx < blocks_x; ++bx) {
      // Sums of the block's left grey levels and of their matches' in the
      // right view.
      float sum_left = 0.f, sq_left = 0.f, sum_right = 0.f, sq_right = 0.f;
      bool bright = false;
      int n = 0;
      for (int y = by * kGainBlock; y < (by + 1) * kGainBlock; ++y) {
        const float* left = L.leftRow(y);
        const float* right = L.rightRow(y);
        const uchar* left_valid = L.leftValidRow(y);
        const uchar* right_valid = L.rightValidRow(y);
        const float* d = disparity[y];
        for (int x = bx * kGainBlock; x < std::min(L.width, (bx + 1) * kGainBlock); ++x) {
          if (!left_valid[x] || !(left[x] >= kGainMinGrey)) continue;
          // The nearest right pixel, not an interpolated one: interpolation
          // smooths one view only; the nearest is off by at most half a
          // pixel, either way alike.
          const float at = static_cast<float>(x) - d[x] + 0.5f;
          if (!(at >= 0.f && at < static_cast<float>(L.width))) continue;  // also NaN
          const int xr = static_cast<int>(at);  // rounded: `at` is not negative
          if (!right_valid[xr]) continue;
          const float l = left[x];
          const float r = right[xr];
          if (!(r >= kGainMinGrey)) continue;  // as the left: the dark is noise
          bright |= l > kGainMaxGrey || r > kGainMaxGrey;
          sum_left += l;
          sq_left += l * l;
          sum_right += r;
          sq_right += r * r;
          ++n;
        }
      }
      // A highlight in either view is no gain.
      if (bright || n < kGainMinBlockPixels) continue;
      const float inv_n = 1.f / static_cast<float>(n);
      // Rounding can leave a flat block's variance a hair below 0.
      const float var_left = std::max(0.f, sq_left * inv_n - (sum_left * inv_n) * (sum_left * inv_n));
      const float var_right = std::max(0.f, sq_right * inv_n - (sum_right * inv_n) * (sum_right * inv_n));
      // Selected on both views' contrast alike, so that noise in one view
      // does not pick the blocks where it happens to be large.
      if (!(var_left + var_right >= kGainMinVariance) || !(var_left > 0.f)) continue;
      // Clamped before the logarithm: a flat right block gives 0.
      const float ratio = std::clamp(std::sqrt(var_right / var_left), kGainMin, kGainMax);
      const int bin = static_cast<int>((std::log(ratio) - log_min) * bins_per_log);
      ++histogram_[static_cast<size_t>(std::clamp(bin, 0, kBins - 1))];
      ++counted;
    }
  }
  if (counted < kGainMinBlocks || static_cast<float>(counted) < kGainMinShare * static_cast<float>(blocks_x * blocks_y)) {
    return 1.f;
  }
  // The median, interpolated within its bin.
  int below = 0;
  for (int b = 0; b < kBins; ++b) {
    const int in_bin = histogram_[static_cast<size_t>(b)];
    if (2 * (below + in_bin) >= counted) {
      const float within = (0.5f * static_cast<float>(counted) - static_cast<float>(below)) / static_cast<float>(in_bin);
      return std::exp(log_min + (static_cast<float>(b) + within) / bins_per_log);
    }
    below += in_bin;
  }
  return 1.f;  // not reached: the bins hold every counted ratio
}

}  // namespace detail
}  // namespace bdis
