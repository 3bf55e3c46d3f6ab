// The slant cue of the confidence (docs/method.md, "Confidence"): a patch
// matches one disparity over its whole footprint, so where the surface is
// strongly slanted (tissue close to the scope seen at a grazing angle, its
// texture foreshortened differently in the two views) no single disparity
// fits the patch and its optimum is less trustworthy than its posterior
// says. The slope is that of the surface around the pixel: the derivative of
// the disparity averaged over a patch-sized box, not of the pixel's
// neighbours, whose small jitter says nothing about the slant. On strong
// texture a smaller slant already misfits: the patch's grey levels at its
// rim are off by about its disparity change times the texture's gradient,
// and a strong edge inside it (a fold rim, an instrument's outline) then
// pulls the match to the edge's own disparity. Where the surface bends
// within a patch's reach (a fold's rim, the nearest tissue), a patch of one
// disparity, and the mean of the patches around a pixel, miss the bend: short
// on a ridge, past it in a valley. Where one edge carries most of a patch's
// texture (an instrument's outline or a fold's rim beside flat or dark
// tissue) the patch matches that edge alone, and the edge's disparity is
// the occluder's, or that of the shadow or the uncovered tissue the other
// view sees beside it, or in between; not that of the tissue in the patch.
// Its gradient is then peaked: a few large values among small ones.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "box_sums.hpp"

namespace bdis {
namespace detail {

class SlantCue {
 public:
  /// Multiplies the confidence of each estimate of `disparity` (level px;
  /// kNoDisparity where none) by agreement() of the disparity change across
  /// a patch, |grad D| * `patch_px`, with `halving` (level px). The map is
  /// taken in 2 x 2 blocks, and a block's four pixels share its factor: the
  /// cue describes the surface on a patch's scale, not the pixel. grad D is
  /// the central difference, rb blocks (2 rb px) to each side, of the mean
  /// of the estimates in a box of 2 rb + 1 blocks around the block, rb =
  /// `patch_px` / 4 rounded half up (one-sided where one side's box holds no
  /// estimate, 0 along an axis where neither does). Then by agreement() of
  /// the misfit, |grad D| * `patch_px` * g, with `misfit_halving` (grey
  /// levels), g the RMS of `gradient` (the left image's horizontal gradient,
  /// grey levels per level px) over the same box. Then by agreement() of the
  /// bend, the discrete Laplacian of those box means at the same step (B(x -
  /// r) + B(x + r) + B(y - r) + B(y + r) - 4 B, r = rb blocks; 0 unless all
  /// four exist), with `bend_halving` (level px). Then by agreement() of
  /// the lone edge, the texture's peakedness over the same box, mean(g^2) /
  /// mean(|g|)^2 of `gradient`, less pi / 2 (a Gaussian texture's or noise's;
  /// 0 below it and where the box is flat), with `lone_edge_halving`. Buffers
  /// are kept for the next frame of the same size; the box sums are
  /// separable, in row loops that vectorise.
  void apply(const cv::Mat1f& disparity, const cv::Mat1f& gradient, int patch_px, float halving,
             float misfit_halving, float bend_halving, float lone_edge_halving, cv::Mat1f& confidence);

  /// The last apply()'s |grad D|^2 per 2 x 2 block (level px of disparity
  /// per level px, squared): (h + 1) / 2 rows of (w + 1) / 2.
  const cv::Mat1f& blockSlopesSquared() const { return slopes_sq_; }

 private:
  BlockEstimates blocks_;  ///< the estimates' sum and count per 2 x 2 block
  BoxSums sums_;           ///< of those, over boxes of blocks
  BoxSums gradient_sums_;  ///< of the squared and the absolute gradient, per block, over the same boxes
  std::vector<float> inv_box_columns_;  ///< 1 / pixel columns of each block column's box, clipped to the map
  std::vector<float> pairs_, factor_, pixel_factor_;  ///< one row's scratch
  /// Box mean of the estimates per block, kNoDisparity where the box has
  /// none; rb blocks of kNoDisparity each side, and one all-kNoDisparity row
  /// last (stands in for the rows above the first and below the last).
  cv::Mat1f mean_;
  cv::Mat1f slopes_sq_;  ///< blockSlopesSquared()
};

}  // namespace detail
}  // namespace bdis
