#include "scale_choice.hpp"

#include <algorithm>
#include <cmath>


namespace bdis {
namespace detail {
namespace {

/// 1 at both pixels of each jump larger than `jump_px` between 4-neighbours
/// that both have an estimate.
void markJumps(const cv::Mat& disparity, float jump_px, cv::Mat1b& jumps) {
  jumps.create(disparity.size());
  for (int y = 0; y < jumps.rows; ++y) std::fill(jumps[y], jumps[y] + jumps.cols, uchar{0});
  for (int y = 0; y < disparity.rows; ++y) {
    const float* d = disparity.ptr<float>(y);
    const float* below = y + 1 < disparity.rows ? disparity.ptr<float>(y + 1) : nullptr;
    uchar* j = jumps[y];
    uchar* j_below = below ? jumps[y + 1] : nullptr;
    for (int x = 0; x < disparity.cols; ++x) {
      if (!(d[x] >= 0.f)) continue;
      if (x + 1 < disparity.cols && d[x + 1] >= 0.f && std::fabs(d[x + 1] - d[x]) > jump_px) j[x] = j[x + 1] = 1;
      if (below && below[x] >= 0.f && std::fabs(below[x] - d[x]) > jump_px) j[x] = j_below[x] = 1;
    }
  }
}

/// The integral image of `marks`: sums(y, x) = marks over [0, y) x [0, x).
/// Here rather than cv::integral, which allocates a buffer per call.
void integrate(const cv::Mat1b& marks, cv::Mat1i& sums) {
  sums.create(marks.rows + 1, marks.cols + 1);
  std::fill(sums[0], sums[0] + sums.cols, 0);
  for (int y = 0; y < marks.rows; ++y) {
    const uchar* m = marks[y];
    const int* above = sums[y];
    int* row = sums[y + 1];
    int run = 0;
    row[0] = 0;
    for (int x = 0; x < marks.cols; ++x) {
      run += m[x];
      row[x + 1] = above[x + 1] + run;
    }
  }
}

}  // namespace

int ScaleChoice::keepMoreConfident(const MatchResult& coarser, float jump_px, int reach_px, MatchResult& result) {
  CV_Assert(coarser.disparity.size() == result.disparity.size() && coarser.confidence.size() == result.disparity.size() &&
            result.confidence.size() == result.disparity.size() && reach_px >= 0);
  const bool with_variance = !result.variance.empty();
  CV_Assert(!with_variance || coarser.variance.size() == result.disparity.size());
  markJumps(result.disparity, jump_px, jumps_);
  integrate(jumps_, sums_);
  const int w = result.disparity.cols, h = result.disparity.rows;
  int taken = 0;
  for (int y = 0; y < h; ++y) {
    const int top = std::max(0, y - reach_px), bottom = std::min(h, y + reach_px + 1);
    const int* s_top = sums_[top];
    const int* s_bottom = sums_[bottom];
    const float* cd = coarser.disparity.ptr<float>(y);
    const float* cc = coarser.confidence.ptr<float>(y);
    float* d = result.disparity.ptr<float>(y);
    float* c = result.confidence.ptr<float>(y);
    for (int x = 0; x < w; ++x) {
      if (!(d[x] >= 0.f && cd[x] >= 0.f && cc[x] > c[x])) continue;
      const int left = std::max(0, x - reach_px), right = std::min(w, x + reach_px + 1);
      if (s_bottom[right] - s_bottom[left] - s_top[right] + s_top[left] > 0) continue;  // near a depth edge
      d[x] = cd[x];
      c[x] = cc[x];
      if (with_variance) result.variance.ptr<float>(y)[x] = coarser.variance.ptr<float>(y)[x];
      ++taken;
    }
  }
  return taken;
}

}  // namespace detail
}  // namespace bdis
