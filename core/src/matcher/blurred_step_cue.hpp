// The blurred step cue of the confidence (docs/method.md, "Confidence"): over
// faint tissue the patches blur a small depth step (a fold's rim a few px
// high) into a ramp one to two patch sides wide, with no jump between
// neighbouring estimates for the edge distance cue to see. The estimates on
// the ramp carry the near side's disparity or one in between, and their
// posteriors are as sure as the flat tissue's. What marks the ramp is its
// slope against the tissue's around it: a surface that is steep within a
// patch's reach and flat a little further out on some side bends more
// sharply than the patches resolve. A uniform slant is steep everywhere and
// keeps its confidence; a slope read across a hole is not a slope, since box
// means over the hole mix the surfaces on its two sides (the left-right
// check leaves holes, not jumps, between an instrument and the tissue).
#pragma once

#include <vector>

#include <opencv2/core.hpp>

namespace bdis {
namespace detail {

class BlurredStepCue {
 public:
  /// Multiplies the confidence of each estimate of `disparity` (level px;
  /// kNoDisparity where none) by agreement() of a blurred step's excess
  /// slope with `halving` (level px). Per 2 x 2 block: the disparity change
  /// across a patch, S = sqrt(`block_slopes_sq`) * `patch_px` (the slant
  /// cue's patch-box slope, SlantCue::blockSlopesSquared()), counts only
  /// where no block within rb blocks holds a pixel without an estimate (rb =
  /// halfPatchInBlocks); excess = max(0, the largest counted S within rb -
  /// `slope_ratio` * the smallest within 2 rb), 0 where none is counted. A
  /// block near a jump is the edge distance cue's: the excess is scaled by
  /// min(1, (2 J + 1/2) / (kEdgeHalvingPatches `patch_px`)), J its distance
  /// in blocks from the nearest jump (EdgeDistanceCue::blockDistances()),
  /// so the gate opens where that cue has halved the confidence. The maxima
  /// and minima are separable; buffers are kept for the next frame of the
  /// same size.
  void apply(const cv::Mat1f& disparity, const cv::Mat1f& block_slopes_sq, const cv::Mat1f& block_edge_distances,
             int patch_px, float slope_ratio, float halving, cv::Mat1f& confidence);

 private:
  cv::Mat1f holes_;      ///< per block: its columns with a hole, then the most within rb
  cv::Mat1f slopes_;     ///< per block: S where counted, 0 where not
  cv::Mat1f flattest_;   ///< per block: S where counted, +inf where not; then the least within 2 rb
  cv::Mat1f steepest_;   ///< the largest counted S within rb
  cv::Mat1f scratch_;    ///< the row passes' results, with the column passes' padding rows
  std::vector<float> padded_, factor_, pixel_factor_;  ///< one row's scratch
};

}  // namespace detail
}  // namespace bdis
