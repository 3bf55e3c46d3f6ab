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
  /// the estimates in the box of side 2 (`patch_px` / 2) + 1 around it (the
  /// estimate among them). Pixels without an estimate keep theirs. Buffers
  /// are kept for the next frame of the same size.
  void apply(const cv::Mat1f& disparity, int patch_px, cv::Mat1f& confidence);

 private:
  BoxSums sums_;  ///< of the estimates' confidence and of their count
};

}  // namespace detail
}  // namespace bdis
