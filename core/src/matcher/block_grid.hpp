// A block codec's grid in the input (docs/method.md, "Compressed frames"):
// JPEG and MPEG code each view in 8 x 8 blocks fixed in the image, and in weak
// texture the grey steps across the blocks' seams stand out from the steps
// between other pixels. Where the two views' grids align, every patch sees the
// same seams at the same shift, so the cost has a dip of the codec's own at
// the disparities that align them: a match is pulled there.
#pragma once

#include <opencv2/core.hpp>

namespace bdis {
namespace detail {

constexpr int kCodecBlock = 8;  ///< px: JPEG's and MPEG's transform blocks
/// Grey levels: steps above are texture or edges, not block seams.
constexpr int kMaxFlatStep = 16;

/// Per phase k (the step between pixel k-1 and k, modulo the block), the sum
/// and count of the flat steps (at most kMaxFlatStep) between two pixels
/// inside the view.
struct PhaseSteps {
  double sum[kCodecBlock] = {};
  long count[kCodecBlock] = {};

  void add(int phase, int a, int b, bool both_valid);
  /// The steps along one row (grey levels and validity, `width` px), phase x % 8.
  void addRow(const uchar* grey, const uchar* valid, int width);
  /// The strongest phase's mean step over the median of the other seven's; 1
  /// without enough steps (256 a phase).
  double contrast() const;
  /// The phase whose mean step is the largest (0 without steps).
  int strongestPhase() const;
};

/// Where the views' column grids align: the disparity, modulo the block, at
/// which a patch sees the right view's seams where the left's are (full
/// resolution px, 0..7), or -1 when the steps do not show a grid in both
/// views (contrast under bdis::BlockArtefactCheck's threshold).
int alignedGridDisparity(const PhaseSteps& left_columns, const PhaseSteps& right_columns);

}  // namespace detail
}  // namespace bdis
