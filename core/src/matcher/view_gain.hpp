// The contrast gain between the two views (docs/method.md, "A gain
// difference between the views"). Mean normalisation cancels an offset, not
// a gain: on a brightness slope (the periphery under the scope's beam) a gain
// leaves a ramp in every patch's residual, which weak texture aligns to. The
// gain is estimated from the pixels the levels above the finest matched and
// divided out of the right views still to be searched.
#pragma once

#include <array>

#include <opencv2/core.hpp>

#include "pyramid.hpp"

namespace bdis {
namespace detail {

/// Levels above the finest whose match re-estimates the gain (what remains of
/// it after the previous correction): each is matched a little closer to the
/// truth once the gain is out, and the next estimate is the better for it.
constexpr int kGainLevelsAboveFinest = 3;
/// Grey levels of the matched pixels: darker ones (in either view) are left
/// out as mostly noise and the rectification seam; a block with a brighter
/// one (a highlight, perhaps clipped) is left out whole.
constexpr float kGainMinGrey = 8.f;
constexpr float kGainMaxGrey = 240.f;
/// Blocks of kGainBlock x kGainBlock level pixels each give one ratio, from
/// at least kGainMinBlockPixels matched pixels whose two views' grey-level
/// variances add up to kGainMinVariance (grey levels squared): below that
/// the ratio is the views' noise.
constexpr int kGainBlock = 4;
constexpr int kGainMinBlockPixels = 8;
constexpr float kGainMinVariance = 8.f;
/// Blocks that must give a ratio, at least and as a share of the level's:
/// fewer say too little about the frame, and the gain stays 1.
constexpr int kGainMinBlocks = 32;
constexpr float kGainMinShare = 0.05f;
/// A remaining gain this close to 1 is left in: the estimate does not resolve
/// it, and the matcher does not notice it.
constexpr float kGainTolerance = 0.005f;
/// The range of gains believed; beyond it the gain is clamped (a larger one is not a camera's).
constexpr float kGainMin = 0.5f, kGainMax = 2.f;

class ViewGainEstimator {
 public:
  /// The contrast gain of the right view over the left: the median over
  /// blocks of kGainBlock^2 pixels of `L` of the ratio of standard
  /// deviations, right over left, of the grey levels of the block's left
  /// pixels and of their matches at `disparity` (level px, dense) in the
  /// right view. Deviations from the block's mean, so that an offset between
  /// the views (which mean normalisation cancels) is not taken for a gain
  /// and a slanted surface (squeezed in one view) is not either; a median
  /// over blocks, so that wrong matches and what one view alone shows do not
  /// move it much. 1 when too few blocks count. Allocates nothing.
  float estimate(const PyramidLevel& L, const cv::Mat1f& disparity);

 private:
  /// Ratios binned by their logarithm over [kGainMin, kGainMax]: 0.14 % a bin.
  static constexpr int kBins = 512;
  std::array<int, kBins> histogram_{};
};

}  // namespace detail
}  // namespace bdis
