// The specular lobe cue of the confidence (docs/method.md, "Confidence"): a
// clipped highlight sits in a broad glossy lobe, a brightness ramp that falls
// away from it over many pixels. The lobe belongs to the light's reflection,
// not to the tissue, so it lies at another place on the tissue in each view.
// Where its ramp outweighs the tissue's own texture, a patch matches the lobe
// and takes its disparity: the estimates in a ring around the highlight are
// wrong together, agree with each other and pass the left-right check, so no
// other cue doubts them. The cue lowers the confidence where, near a clipped
// pixel, the image's smooth gradient is stronger than its fine texture.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "box_sums.hpp"

namespace bdis {
namespace detail {

class SpecularLobeCue {
 public:
  /// Multiplies the confidence of each estimate of `disparity` (level px;
  /// kNoDisparity where none) by agreement() of (ratio - 1) * near with
  /// `halving`. Both are taken on 2 x 2 blocks of pixels (as the box cues,
  /// box_sums.hpp), and a block's pixels share its factor:
  /// - the smooth image is the mean grey of the pixels of a box of 2 rs + 1
  ///   blocks, rs = max(1, patch_px / 8), and its gradient the central
  ///   difference of that along the row (one-sided at the ends), in grey
  ///   levels per level px;
  /// - a block's smooth energy is that gradient squared times its valid
  ///   pixels, its texture energy the sum over its valid pixels of
  ///   (`gradient` - that gradient)^2; ratio is the square root of the
  ///   smooth energy over the texture energy, both summed over a box of
  ///   2 rg + 1 blocks, rg = max(1, patch_px / 4) (about a patch);
  /// - near = exp(-2 D / (kFadePatches patch_px)), falling by e every
  ///   kFadePatches patch sides, D the city-block distance in blocks (2 D
  ///   level px) to the nearest block with a clipped pixel: an invalid one
  ///   of grey at least kClippedGreyShare * `saturation_grey` (black frame
  ///   pixels and their dark seam are darker).
  /// Where the smooth energy does not exceed the texture's (or 1e-6), the
  /// factor is 1.
  /// A frame without clipped pixels (or `saturation_grey` above 255) keeps
  /// its confidence, and so does every block row further than kReachFades
  /// fades from a clipped pixel. Boxes are clipped to the map and to
  /// those block rows. Buffers are kept for the next frame.
  void apply(const cv::Mat1f& disparity, const cv::Mat1f& grey, const cv::Mat1b& valid, const cv::Mat1f& gradient,
             int saturation_grey, int patch_px, float halving, cv::Mat1f& confidence);

  /// A level pixel is clipped when invalid and at least this share of the
  /// saturation grey: one clipped input pixel among bright ones reaches it, a
  /// black frame's or its dark seam's pixels do not.
  static constexpr float kClippedGreyShare = 0.75f;
  /// The patch sides over which near falls by e. A lobe's ramp spans several
  /// patches: at one patch side the outer part of the wrong ring kept most
  /// of its confidence.
  static constexpr int kFadePatches = 2;
  /// Block rows further than this many fades from every clipped pixel are
  /// left as they are: there near < exp(-4), under 2 % of the cue.
  static constexpr int kReachFades = 4;

 private:
  /// Marks the blocks holding a clipped pixel (distance 0, the others far)
  /// and returns the first and last block row holding one (first > last: none).
  void markClippedBlocks(const cv::Mat1f& grey, const cv::Mat1b& valid, float clipped_grey, int& first, int& last);
  /// City-block distances in blocks to the nearest clipped block, block rows by0..by1.
  void distanceTransform(int by0, int by1);

  cv::Mat1f distance_;  ///< blocks from the nearest clipped block
  cv::Mat1f smooth_;    ///< the blocks' smoothed grey, in the block rows near clipped pixels
  BoxSums smooth_sums_, energy_sums_;
  std::vector<float> block_factor_, pixel_factor_, near_table_;
  std::vector<float> columns_, column_counts_, block_gradient_, pixel_gradient_;  ///< a row, per column or block
  std::vector<float> block_pixels_;  ///< pixels per block of two rows
  std::vector<uchar> clipped_;  ///< a row's clipped pixels
};

}  // namespace detail
}  // namespace bdis
