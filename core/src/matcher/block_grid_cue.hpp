// The block grid cue of the confidence (docs/method.md, "Compressed frames"):
// on block-coded views whose grids align at some disparity, the codec's seams
// give the cost a dip of its own there, and in weak texture a match is pulled
// to it. An estimate close to such a disparity may be the codec's, not the
// tissue's, so its confidence is lowered; more so, and over a wider reach,
// where the codec's seams are most of the texture around it (the dark, whose
// blocks the codec has flattened). Elsewhere, and on views without a grid, it
// is left as it is.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "box_sums.hpp"

namespace bdis {
namespace detail {

/// Where the views' grids align and the left view's seams lie, in input px.
struct BlockGridLayout {
  int aligned = -1;     ///< alignedGridDisparity(): 0..7, or -1 without a grid in both views
  int left_phase = 0;   ///< the left view's seams: between input columns k - 1 and k, k = this modulo 8
};

/// The two reaches and doubts of the cue (input px; shares of the confidence;
/// the matcher's are kBlockGrid* in confidence.hpp).
struct BlockGridDoubts {
  float reach;       ///< the plain term's reach
  float doubt;       ///< the plain term's doubt at an aligned disparity
  float seam_reach;  ///< the seam term's reach
  float seam_doubt;  ///< the seam term's doubt where the seams are all of the texture (0: off)
};

class BlockGridCue {
 public:
  /// Multiplies the confidence of each estimate of `disparity` (level px, the
  /// level `level_scale` = 2^s times coarser than the input; kNoDisparity
  /// where none), r its distance in input px from the nearest disparity
  /// congruent to `layout.aligned` modulo the codec's block, by
  ///   (1 - doubt max(0, 1 - r / reach)) (1 - seam_doubt max(0, 1 - r / seam_reach) seams),
  /// `seams` the share of the left grey steps' energy (`grey`, steps between
  /// valid neighbours, each at most kMaxFlatStep) on the level's seam
  /// columns in a box of side 2 floor(`patch_px` / 2) + 1, above its share
  /// for texture without a grid (the box's seam columns over its columns,
  /// about one in 8 / 2^s), scaled to 0..1.
  /// The seam term needs two columns a block at the level (2^s <= 4); on
  /// coarser levels, or with seam_doubt 0, only the plain term applies.
  /// Buffers are kept for the next frame of the same size.
  void apply(const cv::Mat1f& disparity, int level_scale, const BlockGridLayout& layout, const cv::Mat1f& grey,
             const cv::Mat1b& valid, int patch_px, const BlockGridDoubts& doubts, cv::Mat1f& confidence);

 private:
  BoxSums sums_;  ///< of the seam columns' and all columns' step energy
  std::vector<float> seams_;  ///< one row's seam share, 0..1
  std::vector<float> gridless_share_;  ///< per column, a gridless texture's seam share in its box
  std::vector<float> seam_columns_, line_scratch_;  ///< for gridless_share_
};

}  // namespace detail
}  // namespace bdis
