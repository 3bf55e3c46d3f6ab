// The block grid cue of the confidence (docs/method.md, "Compressed frames"):
// on block-coded views whose grids align at some disparity, the codec's seams
// give the cost a dip of its own there, and in weak texture a match is pulled
// to it. An estimate close to such a disparity may be the codec's, not the
// tissue's, so its confidence is lowered; elsewhere, and on views without a
// grid, it is left as it is.
#pragma once

#include <opencv2/core.hpp>

namespace bdis {
namespace detail {

/// Multiplies the confidence of each estimate of `disparity` (level px, the
/// level `level_scale` = 2^s times coarser than the input; kNoDisparity where
/// none) by 1 - doubt * max(0, 1 - r / reach), r its distance in input px from
/// the nearest disparity congruent to `aligned` modulo the codec's block
/// (alignedGridDisparity(); -1: nothing to do).
void applyBlockGridCue(const cv::Mat1f& disparity, float level_scale, int aligned, float reach, float doubt,
                       cv::Mat1f& confidence);

}  // namespace detail
}  // namespace bdis
