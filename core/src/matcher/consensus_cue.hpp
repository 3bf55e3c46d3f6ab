// The consensus cue of the confidence (docs/method.md, "Confidence"): an
// estimate that stands apart from the estimates around it is more often
// wrong than its own patches can tell. A wrong match that propagation has
// spread over a few patches (a blob a few px off in the dark periphery, on
// foreshortened tissue) and the estimates next to a depth edge both differ
// from the mean of their wider neighbourhood, while on a smooth surface,
// slanted or not, a pixel lies close to the mean of a box centred on it.
// The neighbourhood reaches two patch sides each way: about as far as
// propagation carries a wrong match, and wide enough that the blob does not
// make up its own mean.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "box_sums.hpp"

namespace bdis {
namespace detail {

class ConsensusCue {
 public:
  /// Multiplies the confidence of each estimate of `disparity` (level px;
  /// kNoDisparity where none) by agreement() of its distance from the mean
  /// of the estimates in a box reaching two patch sides each way, with
  /// `halving` (level px). The box is summed over 2 x 2 blocks of pixels:
  /// 2 `patch_px` + 1 blocks each way around the pixel's block (a quarter
  /// of the work; the box is wide enough that it need not be centred on the
  /// pixel). Buffers are kept for the next frame of the same size; the box
  /// sums are separable, in row loops that vectorise.
  void apply(const cv::Mat1f& disparity, int patch_px, float halving, cv::Mat1f& confidence);

 private:
  BoxSums sums_;                              ///< of the blocks' estimates and of their count
  BlockEstimates blocks_;                     ///< the estimates in 2 x 2 blocks
  std::vector<float> block_mean_;             ///< a row of the box means, per block
  std::vector<float> mean_;                   ///< the same, per pixel
};

}  // namespace detail
}  // namespace bdis
