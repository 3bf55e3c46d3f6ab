// The choice between two scales (docs/method.md, "Two scales"): the search
// whose finest level is one coarser sees twice the footprint per patch, which
// dark, flat and block-coded tissue needs and depth edges do not. Both
// results carry a confidence calibrated as the probability of being within
// 2 px, per finest level, so per pixel the one more likely right is kept,
// except near a depth edge, where the coarser patches straddle both surfaces
// and carry the nearer one's depth onto the farther with confidence.
#pragma once

#include <vector>

#include "bdis_stereo/matcher.hpp"

namespace bdis {
namespace detail {

/// A jump larger than this (level px) between 4-neighbouring estimates of
/// the finest level is a depth edge for the choice. The upsampling spreads a
/// jump of J level px into steps of J input px, so this is the outlier
/// threshold (2 input px) between input pixels; 1 level px would take steep
/// slopes for edges too (docs/method.md, "Two scales").
constexpr float kScaleChoiceJumpPx = 2.f;

class ScaleChoice {
 public:
  /// Where both `result` and `coarser` (maps of the same size) have an
  /// estimate, `coarser`'s confidence is higher and no jump of more than
  /// `jump_px` between `result`'s 4-neighbouring estimates lies within
  /// `reach_px` >= 1 (a box of side 2 reach_px + 1: one coarser patch side, so no
  /// coarser patch covering the pixel straddles the edge), `result` takes
  /// `coarser`'s disparity, confidence and (when `result` has one) variance.
  /// Pixels without an estimate in `result` stay without one: the finer
  /// search's check and floors dropped them, and the coarser's lone
  /// estimates there rank worse than its others. Returns the pixels taken.
  /// Buffers are kept for the next frame of the same size.
  int keepMoreConfident(const MatchResult& coarser, float jump_px, int reach_px, MatchResult& result);

 private:
  /// near_row_[x] = 1 where one of marks_ (one row's jump marks, padded by
  /// reach_px zeros each side; overwritten) lies within reach_px columns.
  void dilateRow(int w, int reach_px);

  std::vector<unsigned char> right_, up_, down_;  ///< one row's jumps to its neighbours
  std::vector<unsigned char> marks_, windows_;    ///< one row's marks; ORs over windows of them
  std::vector<unsigned char> near_row_;           ///< one row's marks within reach, along it
  std::vector<int> last_jump_;                    ///< per column, the last row with near_row_ set
};

}  // namespace detail
}  // namespace bdis
