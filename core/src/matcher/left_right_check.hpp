// The left-right consistency check (docs/method.md, "Left-right check"): a
// left estimate is kept only where the search from the right image, on the
// mirrored pair, finds its way back to it.
#pragma once

#include <opencv2/core.hpp>

namespace bdis {
namespace detail {

/// Drops (disparity kNoDisparity, confidence 0) every estimate of the finest
/// level's `disparity` whose match column x - d (rounded) has no estimate in
/// `mirrored` (the right-reference search's disparity of the mirrored pair:
/// its column w - 1 - x is right-image column x), or one more than
/// `tolerance` (level px) away. The others keep their confidence times
/// agreement() of the difference (`halving` in level px) and, with a
/// `variance` map (may be null), a variance grown by a share of the squared
/// difference. Rows [0, disparity.rows).
void leftRightCheck(const cv::Mat1f& mirrored, float tolerance, float halving, cv::Mat1f& disparity,
                    cv::Mat1f& confidence, cv::Mat1f* variance);

}  // namespace detail
}  // namespace bdis
