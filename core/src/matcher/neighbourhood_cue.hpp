// The neighbourhood cue of the confidence (docs/method.md, "Confidence"): one
// estimate's confidence rests on the few patches that cover it, so an estimate
// confident among doubtful neighbours (on the rim of a confident region, or
// alone on dark tissue the matcher mostly fails on) is partly luck, and one
// doubtful among confident neighbours lies on a surface the matcher holds. The
// cue pools each estimate's confidence with the mean of its neighbourhood's,
// a patch-sized box, in a weighted geometric mean that keeps the estimate's
// own the larger share.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "box_sums.hpp"

namespace bdis {
namespace detail {

class NeighbourhoodCue {
 public:
  /// Replaces the confidence c of each estimate of `disparity` (level px;
  /// kNoDisparity where none) by c^(3/4) m^(1/4), m the mean confidence of
  /// the estimates in the slant cue's box around it (2 rb + 1 blocks of 2 x 2
  /// px a side around its block, rb = `patch_px` / 4 rounded half up; the
  /// estimate among them). Pixels without an estimate keep theirs. Buffers
  /// are kept for the next frame of the same size.
  void apply(const cv::Mat1f& disparity, int patch_px, cv::Mat1f& confidence);

 private:
  BlockEstimates blocks_;  ///< the estimates' confidence and count per 2 x 2 block
  BoxSums sums_;           ///< of those, over boxes of blocks
  std::vector<float> block_mean_, mean_;  ///< one row's
};

}  // namespace detail
}  // namespace bdis
