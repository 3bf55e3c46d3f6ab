#include "scale_choice.hpp"

#include <algorithm>

#include "box_sums.hpp"  // BoxSums, jumpFlags

namespace bdis {
namespace detail {
namespace {

/// marks[x] > 0 where pixel x of row y takes part in a jump larger than
/// `jump_px` with a 4-neighbour, both estimates; `pairs` is scratch of w.
void jumpMarksRow(const cv::Mat1f& disparity, int y, float jump_px, unsigned char* pairs, float* marks) {
  const int w = disparity.cols;
  const float* d = disparity[y];
  std::fill(marks, marks + w, 0.f);
  jumpFlags(w - 1, d, d + 1, jump_px, pairs);  // with the right neighbour
  for (int x = 0; x + 1 < w; ++x) {
    marks[x] += pairs[x];
    marks[x + 1] += pairs[x];
  }
  for (const int other : {y - 1, y + 1}) {
    if (other < 0 || other >= disparity.rows) continue;
    jumpFlags(w, d, disparity[other], jump_px, pairs);
    for (int x = 0; x < w; ++x) marks[x] += pairs[x];
  }
}

}  // namespace

int ScaleChoice::keepMoreConfident(const MatchResult& coarser, float jump_px, int reach_px, MatchResult& result) {
  CV_Assert(coarser.disparity.size() == result.disparity.size() && coarser.confidence.size() == result.disparity.size() &&
            result.confidence.size() == result.disparity.size() && result.disparity.type() == CV_32FC1);
  // The sweep changes row y - reach_px after it has read the rows around y:
  // with a reach of 1 px or more, every jump is found on the disparities as
  // they were.
  CV_Assert(reach_px >= 1);
  const bool with_variance = !result.variance.empty();
  CV_Assert(!with_variance || coarser.variance.size() == result.disparity.size());
  const cv::Mat1f disparity = result.disparity;  // a header on the same data
  const int w = disparity.cols;
  pairs_.resize(static_cast<size_t>(w));
  near_jumps_.begin(w, disparity.rows, reach_px, /*with_b=*/false);
  int taken = 0;
  near_jumps_.sweep(
      [&](int y, float* marks, float*) { jumpMarksRow(disparity, y, jump_px, pairs_.data(), marks); },
      [&](int y, const float* jumps_in_box, const float*) {
        const float* cd = coarser.disparity.ptr<float>(y);
        const float* cc = coarser.confidence.ptr<float>(y);
        float* d = result.disparity.ptr<float>(y);
        float* c = result.confidence.ptr<float>(y);
        for (int x = 0; x < w; ++x) {
          if (!(d[x] >= 0.f && cd[x] >= 0.f && cc[x] > c[x]) || jumps_in_box[x] > 0.5f) continue;
          d[x] = cd[x];
          c[x] = cc[x];
          if (with_variance) result.variance.ptr<float>(y)[x] = coarser.variance.ptr<float>(y)[x];
          ++taken;
        }
      });
  return taken;
}

}  // namespace detail
}  // namespace bdis
