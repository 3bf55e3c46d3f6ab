// The edge distance cue of the confidence (docs/method.md, "Confidence"): the
// closer an estimate lies to a jump between neighbouring estimates, the more
// often it is wrong. A depth edge fattens or bleeds into the estimates beside
// it, and a wrong match that propagation carried over a few patches is bounded
// by jumps to the surface around it; neither is smooth where it meets its
// surroundings. The cue falls with the distance to the nearest jump over a
// reach of two patch sides, as far as the consensus cue's box.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

namespace bdis {
namespace detail {

class EdgeDistanceCue {
 public:
  /// Multiplies the confidence of each estimate of `disparity` (level px;
  /// kNoDisparity where none) by D / (D + halving), D its distance (level px)
  /// from the nearest jump of more than `jump` between two 4-neighbouring
  /// estimates, plus half a pixel (a jump lies between two pixels, so the
  /// pixels beside it are half a pixel from it). Distances are city-block,
  /// over 2 x 2 blocks of pixels (a block is at a jump when one of its pixels
  /// is; a quarter of the work, and the reach is many blocks), by the two
  /// raster passes of a distance transform. A hole is not a jump. Buffers are
  /// kept for the next frame of the same size.
  void apply(const cv::Mat1f& disparity, float jump, float halving, cv::Mat1f& confidence);

  /// The last apply()'s distance of each 2 x 2 block from the nearest block
  /// at a jump, in blocks (city-block; 1e6 in a frame without a jump):
  /// (h + 1) / 2 rows of (w + 1) / 2.
  const cv::Mat1f& blockDistances() const { return block_distance_; }

 private:
  /// The blocks of block row `by` at a jump of more than `jump` (0) or not
  /// (far), into `blocks`.
  void markBlockRow(const cv::Mat1f& disparity, int by, float jump, float* blocks);

  enum FlagRow { kLeft0, kLeft1, kAbove, kBetween, kBelow, kMarks, kFlagRows };
  cv::Mat1f block_distance_;          ///< blocks from the nearest block at a jump
  cv::Mat1b flags_;                   ///< the rows of pair flags and pixel marks
  unsigned char* rows_[kFlagRows] = {};  ///< flags_'s rows, by role (above / below swap)
  std::vector<float> block_factor_;   ///< a row of the blocks' factors
  std::vector<float> factor_;         ///< the same per pixel
};

}  // namespace detail
}  // namespace bdis
