// The residual slant cue of the confidence (docs/method.md, "Confidence"):
// the slant the published estimates leave in the photometric residual. A
// patch matches one disparity over its footprint, so on a slanted surface
// the fused estimates come out flatter than the surface (the fronto-parallel
// bias), and a wrong match that propagation spread over a few patches is
// smooth inside. Neither shows in the estimates themselves; both show in the
// images: warped by the estimates, the right view still differs from the
// left by a shift that changes across the neighbourhood. Fitting that
// residual by a brightness offset plus the left gradient times a shift and
// a shift slope, r = o + g (a + b u), gives b, the slope the estimates miss.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "pyramid.hpp"

namespace bdis {
namespace detail {

class ResidualSlantCue {
 public:
  /// Multiplies the confidence of each estimate of `disparity` (the finest
  /// level's, level px; kNoDisparity where none) by agreement() of the
  /// disparity change across a patch that its neighbourhood's residual asks
  /// for, |b| `patch_px`, with `halving` (finest-level px). The fit runs on
  /// `coarser`, the level above the finest (its grey levels, gradient and
  /// validity; a quarter of the pixels), with the estimates of each 2 x 2
  /// block averaged, over a box of 2 `patch_px` + 1 of its pixels, the
  /// consensus cue's box; each finest pixel takes its block's factor.
  /// Estimates whose box has too little texture to fit keep their
  /// confidence. Buffers are kept for the next frame of the same size; the
  /// sums are separable, in row loops that vectorise.
  void apply(const cv::Mat1f& disparity, const PyramidLevel& coarser, int patch_px, float halving,
             cv::Mat1f& confidence);

 private:
  /// What each coarser-level pixel contributes to the fit: the weight (1
  /// where the residual can be read), g, g^2, the residual r and g r.
  enum Product { kWeight, kG, kGG, kR, kGR, kProducts };
  cv::Mat1f products_;                 ///< kProducts maps of the level, one below the other
  std::vector<float> columns_;         ///< their sums over the box's rows, padded with zeros
  std::vector<float> block_disparity_;  ///< a row of the blocks' estimates
  std::vector<float> block_factor_;    ///< a row of the blocks' factors
  std::vector<float> factor_;          ///< the same per finest-level pixel
};

}  // namespace detail
}  // namespace bdis
