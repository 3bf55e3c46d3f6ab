// Plausibility checks of a stereo pair that the matcher itself cannot make:
// it searches only d >= 0, so a pair with left and right swapped gives few,
// poor estimates rather than an error. Cheap (a coarse row search on small
// images), for a node to run on incoming frames.
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

}  // namespace bdis
