// The residual fit cues of the confidence (docs/method.md, "Confidence"):
// what the images, warped by the estimates, still say about them. Fitting
// the photometric residual r = R(x - D) - L around each pixel by a brightness
// offset plus the left gradient times a shift and a shift slope,
// r = o + g (a + b u), gives two cues the estimates alone cannot:
//  - the slope b they miss. A patch matches one disparity over its
//    footprint, so on a slanted surface the fused estimates come out flatter
//    than the surface (the fronto-parallel bias), and a wrong match that
//    propagation spread over a few patches is smooth inside;
//  - how precisely the texture pins the shift against the residual's own
//    noise: the standard error of a, the noise measured rather than assumed
//    (the posterior's sigma_r), so weak texture under a codec's or a dark
//    sensor's noise counts as the guess it is.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "box_sums.hpp"
#include "pyramid.hpp"

namespace bdis {
namespace detail {

class ResidualFitCue {
 public:
  /// Multiplies the confidence of each estimate of `disparity` (the finest
  /// level's, level px; kNoDisparity where none) by agreement() of the
  /// disparity change across a patch that its neighbourhood's residual asks
  /// for, |b| `patch_px`, with `slant_halving`, and by agreement() of the
  /// standard error the shift would have over a patch's footprint with the
  /// residual's noise and texture there, with `error_halving` (both
  /// finest-level px). The fit runs on `coarser`, the level above the
  /// finest (its grey levels, gradient and validity; a quarter of the
  /// pixels), with the estimates of each 2 x 2 block averaged, over a box
  /// of 2 `patch_px` + 1 of its pixels, the consensus cue's box; each finest
  /// pixel takes its block's factor. Estimates whose box has too little
  /// texture to fit keep their confidence. Buffers are kept for the next
  /// frame of the same size; the sums are separable, in row loops that
  /// vectorise.
  void apply(const cv::Mat1f& disparity, const PyramidLevel& coarser, int patch_px, float slant_halving,
             float error_halving, cv::Mat1f& confidence);

 private:
  /// What each coarser-level pixel contributes to the fit: the weight (1
  /// where the residual can be read), g, g^2, the residual r, g r and r^2.
  enum Product { kWeight, kG, kGG, kR, kGR, kRR, kProducts };
  cv::Mat1f products_;                 ///< kProducts maps of the level, one below the other
  std::vector<float> columns_;         ///< their sums over the box's rows, padded with zeros
  BlockEstimates blocks_;              ///< the estimates in 2 x 2 blocks
  std::vector<float> block_disparity_;  ///< a row of the blocks' mean estimates
  std::vector<float> block_count_;     ///< and how many each holds
  std::vector<float> block_factor_;    ///< a row of the blocks' factors
  std::vector<float> factor_;          ///< the same per finest-level pixel
};

}  // namespace detail
}  // namespace bdis
