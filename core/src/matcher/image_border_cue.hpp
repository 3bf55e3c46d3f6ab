// The image border cue of the confidence (docs/method.md, "Confidence"): an
// estimate within a patch side of the image's edge is reached only by patches
// lying further in, so it is their disparity carried outward. On a surface
// that keeps rising towards the edge (the near wall at the periphery of an
// endoscopic view) that extrapolation falls short, by about the surface's
// slope times the distance carried. The cue lowers the confidence by that
// expected shortfall, and within two patch sides of the edge (one at the
// next coarser level, whose patches there also lay against the edge) by a
// share for the one-sided start the search refined there.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

namespace bdis {
namespace detail {

class ImageBorderCue {
 public:
  /// Multiplies the confidence of each estimate of `disparity` (level px;
  /// kNoDisparity where none) within `patch_px` of an image edge by
  /// agreement() of slope * (patch_px - distance) with `halving` (level px),
  /// the slope that edge's normal direction shows a patch side in from it:
  /// the difference of the mean estimates in two boxes of side 2 (p / 2) + 1
  /// centred p / 2 and p + p / 2 from the edge, over p (a box without
  /// estimates: no slope).
  /// Within 2 p of the nearest edge (at most half the image's smaller side)
  /// it is also multiplied by kImageBorderKeptAtEdge at the edge, rising
  /// linearly to 1 at 2 p.
  /// Images under 2 p + 1 px on a side are left as they are.
  void apply(const cv::Mat1f& disparity, int patch_px, float halving, cv::Mat1f& confidence);

 private:
  /// The slope towards the edge at row (along_rows) or column `edge`, a
  /// patch side in (`inward` +1 or -1), per position along that edge.
  void edgeSlopes(const cv::Mat1f& disparity, bool along_rows, int edge, int inward, int patch_px,
                  std::vector<float>& slope);

  std::vector<float> sum_, count_, box_sum_, box_count_, padded_;  ///< sums across and along a line
  std::vector<float> near_, far_;                         ///< box means along a line
  std::vector<float> top_, bottom_, left_, right_;  ///< slope per position along each edge
  std::vector<float> from_left_, from_right_;       ///< distance carried from the side edges, per column
  std::vector<float> column_kept_;                  ///< the start's share at the column's distance from the sides
};

}  // namespace detail
}  // namespace bdis
