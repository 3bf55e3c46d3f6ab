// The texture centroid correction (docs/method.md, "The texture centroid
// correction"): a patch of one disparity matched to a slanted surface finds,
// to first order, the disparity of its footprint weighted by the texture's
// squared gradient there (the Gauss-Newton step weighs each pixel by it), so
// its estimate belongs where that texture is centred, not at the pixel. Where
// the texture is stronger on one side (shading that fades into the dark
// periphery, a lit fold beside a dim one), the fused estimate on slanted
// tissue is off by the surface's slope times that offset: too far on near,
// grazing walls whose texture fades towards the periphery. The correction
// removes that first-order offset before the variational refinement, which
// then pins the estimates to the images where their texture can.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "box_sums.hpp"
#include "pyramid.hpp"

namespace bdis {
namespace detail {

/// Full-resolution px the correction moves an estimate at most: the
/// outlier threshold; a larger g . c comes from a depth jump in the box.
constexpr float kCentroidShiftLimitPx = 2.0f;

class TextureCentroidCorrection {
 public:
  /// For each estimate of `disparity` (level px; kNoDisparity where none) at
  /// `level`'s scale: c, the offset from the pixel to the centroid of the
  /// squared horizontal gradient of the valid left pixels in the box of side
  /// 2 r + 1 around it (r = `patch_px` / 2; within r of a side the box lies
  /// against it, as the patches covering the pixel do), and g, the surface's
  /// slope there (the slant cue's: central differences of the box means of
  /// the estimates' 2 x 2 blocks, boxes of 2 rb + 1 blocks, rb =
  /// halfPatchInBlocks, rb blocks to each side, one slope per block; within
  /// 3 rb blocks of a side, the slope 3 rb blocks from it, whose boxes clear
  /// the strip the side's patches flatten). The estimate
  /// becomes d - g . c, with g . c limited to +-`max_shift` (level px;
  /// beyond it the slope is a depth jump, not a surface) and the result to
  /// d >= 0. A box without texture
  /// moves nothing; a map under 2 r + 1 px on a side is left as it is.
  /// Buffers are kept for the next frame of the same size.
  void apply(const PyramidLevel& level, int patch_px, float max_shift, cv::Mat1f& disparity);

 private:
  BlockEstimates blocks_;  ///< the estimates' sum and count per 2 x 2 block
  BoxSums sums_;           ///< their box sums
  cv::Mat1f mean_;         ///< the blocks' box means, padded (boxMeansOfBlockEstimates)
  std::vector<float> block_gx_, block_gy_;  ///< one block row's slopes
  std::vector<float> gx_, gy_;              ///< the same on the row's pixels
  std::vector<float> padded_;     ///< a row's squared gradient, r zeros each side
  cv::Mat1f energy_, moment_x_;   ///< a ring of 2r + 1 rows: horizontal box sums of it, and of it times the offset
  std::vector<float> sum_, sum_x_, sum_y_;  ///< one row's box sums: energy, and its moments in x and y
  std::vector<const float*> energy_rows_, moment_rows_;  ///< the ring's rows in the box, top first
};

}  // namespace detail
}  // namespace bdis
