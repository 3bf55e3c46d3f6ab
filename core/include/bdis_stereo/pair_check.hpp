// Plausibility checks of a stereo pair that the matcher itself cannot make:
// it searches only d >= 0, so a pair with left and right swapped gives few,
// poor estimates rather than an error; and a view that went through a block
// codec (JPEG, MPEG) has lost texture the matcher needs, which no single
// frame's result shows. Cheap, for a node to run on incoming frames.
#pragma once

#include <opencv2/core.hpp>

namespace bdis {

struct DisparitySignCheck {
  int distinct_patches = 0;   ///< textured patches with a clear best shift
  int negative = 0;           ///< of those, best shift < 0 (right image point to the right)
  /// Share of distinct patches whose best shift is negative; 0 when none.
  double negativeShare() const { return distinct_patches ? double(negative) / distinct_patches : 0.0; }
  /// True when the evidence says the views are swapped: at least
  /// `min_patches` distinct patches and more than `max_negative_share` of
  /// them negative. A rectified pair in the right order has (almost) none.
  bool looksSwapped(int min_patches = 12, double max_negative_share = 0.7) const {
    return distinct_patches >= min_patches && negativeShare() > max_negative_share;
  }
};

/// Searches shifts in [-range, range] (range = a quarter of the image width)
/// for patches on a grid of images reduced to about 160 px wide, both signs
/// alike, and counts the textured patches whose best shift is clearly better
/// than the others. Inputs: equal size, 8-bit mono or BGR; black (0) pixels
/// are ignored. Throws std::invalid_argument on other input.
DisparitySignCheck checkDisparitySign(const cv::Mat& left, const cv::Mat& right);

struct BlockArtefactCheck {
  /// Mean grey-level step between neighbouring pixels across the strongest
  /// of the 8 column (and row) phases, over the median phase's; averaged over
  /// both axes. About 1 for a camera's image; a block codec's 8 x 8 grid,
  /// fixed in the image, makes one phase stand out (JPEG at quality 95: about
  /// 1.5 on generated tissue, 75: 2-3).
  double grid_contrast = 1.0;
  bool looksBlockCompressed(double min_contrast = 1.2) const { return grid_contrast >= min_contrast; }
};

/// The grid contrast of one view (8-bit mono or BGR, luma as the matcher
/// takes it), over the steps of at most 16 grey levels between two pixels
/// inside the view (not black): the flat and weakly textured tissue where a
/// codec's blocks show and the texture is weakest. Without enough such steps
/// (fewer than 256 per phase) the contrast is 1. Throws std::invalid_argument
/// on other input.
BlockArtefactCheck checkBlockArtefacts(const cv::Mat& image);

}  // namespace bdis
