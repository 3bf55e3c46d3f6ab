// The support cue of the confidence (docs/method.md, "Confidence"): an
// estimate whose neighbourhood the matcher mostly rejected (the confidence
// floor, the discard tests, the left-right check) survived where matching
// failed around it, and such survivors are often wrong too: the dark
// periphery, an occluded strip, the tissue beside a highlight. The
// neighbourhood is what the patches covering the pixel reach, a box of side
// 2p - 1. Pixels outside the view (black, the frame's seam) do not count:
// nothing could match there. Clipped pixels and those below the dark floor
// count as holes: the measurement failed there, a highlight that moves
// between the views leaves wrong matches around it, and a near-black
// surface's neighbours take its depth.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "box_sums.hpp"

namespace bdis {
namespace detail {

class SupportCue {
 public:
  /// Multiplies the confidence of each estimate of `disparity` (level px;
  /// kNoDisparity where none) by agreement() of the share of the pixels in
  /// the box around it that have no estimate, with `halving_share`. The box
  /// is made of 2 x 2 blocks, 2 floor((`patch_px` - 1) / 2) + 1 of them a
  /// side around the pixel's (about 2 `patch_px` - 1 px); a block's four
  /// pixels share its factor. Counted are the valid pixels (`valid` != 0), the
  /// invalid bright ones (`grey`: clipped) and the invalid dark but not black
  /// ones between the row's first and last valid pixel (below the dark
  /// floor), not the others (outside the view: a frame and its seam reach
  /// the row's end). Buffers are kept for the next frame of the same size.
  void apply(const cv::Mat1f& disparity, const cv::Mat1b& valid, const cv::Mat1f& grey, int patch_px,
             float halving_share, cv::Mat1f& confidence);

 private:
  BoxSums sums_;  ///< of the estimates' count and of the valid pixels', per 2 x 2 block
  std::vector<float> scratch_, factor_, pixel_factor_;  ///< one row's
};

}  // namespace detail
}  // namespace bdis
