// Variational refinement of the finest level's disparity (docs/method.md,
// "Variational refinement"): DIS's last stage (Kroeger et al. 2016; OpenCV's
// VariationalRefinement), along x only, as a rectified pair needs. A patch
// matches one disparity over its footprint, so on tissue slanted towards
// the scope its estimates are flattened and off by more than the patch can
// tell. Per pixel, a data term (brightness and gradient constancy against
// the right image warped by the current disparity) and a smoothness term
// over the 4-neighbours, both robust (Charbonnier), the latter weaker across
// an edge of the left image (mostly a depth edge), pull each estimate to
// the disparity its own pixel and the surface around it agree on. The BDIS
// paper dropped the stage as worth under 0.5 %; on the colon sequences it
// removes 1.4-2.6 points of bad2, more in a dark periphery (docs/method.md).
#pragma once

#include <opencv2/core.hpp>

#include "pyramid.hpp"

namespace bdis {
namespace detail {

class VariationalRefinement {
 public:
  /// `iterations` fixed-point steps (0 = off), each re-weighting the robust
  /// terms and then solving the linearised system with a few SOR sweeps;
  /// `smoothness` the weight of the smoothness term (alpha).
  void configure(int iterations, float smoothness);

  /// Refines the estimates of `disparity` (level px; kNoDisparity where
  /// none) in place. `level` is the searched level the disparity belongs to
  /// (its left and right images and validity), `coarser` the dense
  /// disparity of the level above, which stands in for the holes: they take
  /// part in the smoothness term and stay holes. Buffers are kept for the
  /// next frame of the same size.
  void apply(const PyramidLevel& level, const cv::Mat1f& coarser, cv::Mat1f& disparity);

 private:
  /// The warp of level row `y` by the start and the coefficients its data
  /// term reads, into data_rows_.
  void prepareDataTermRow(const PyramidLevel& level, int y);
  /// One fixed-point step, row by row: each row's data term, smoothness
  /// links and system from the current increment, then the SOR sweeps; on
  /// the last step (`refined` not null) the refined estimates into it.
  void fixedPointStep(const PyramidLevel& level, cv::Mat1f* refined);

  int iterations_ = 0;
  float smoothness_ = 20.f;
  /// The estimates, the holes from the coarser level; one column each
  /// side repeats the end, row y at start(y).
  cv::Mat1f start_;
  float* start(int y) { return start_[y] + 1; }
  /// The solution, start_ + increment is the refined disparity; a border
  /// of one 0 all round, row y of the level at t(y).
  cv::Mat1f increment_;
  float* t(int y) { return increment_[y + 1] + 1; }
  /// One row's data term: the right image warped by the start minus the
  /// left (kDifference), the x derivatives of their average (kIx, kIxx) and
  /// of the difference (kIxz), and the normalisations, 0 where the pixel or
  /// its match is invalid. Recomputed each step: the start does not change,
  /// and a row in cache is cheaper than six level-sized planes read back.
  enum DataRow { kDifference, kIx, kIxx, kIxz, kNorm, kNormX, kDataRows };
  cv::Mat1f data_rows_;
  /// The rows the SOR wavefront still reads, level row y in slot
  /// y % kRingRows: the system (the diagonal inverted, then the right-hand
  /// side) and the smoothness links. weight_right_ slot of y, column x + 1
  /// links (x, y) to (x + 1, y), columns 0 and w are 0; weight_down_ slot of
  /// y + 1 links (x, y) to (x, y + 1), 0 above the first row and below the
  /// last.
  static constexpr int kRingRows = 8;
  cv::Mat1f system_rows_;
  cv::Mat1f weight_right_, weight_down_;
  static constexpr int kScratchRows = 6;
  cv::Mat1f scratch_;      ///< rows for one level row: the coarser level upsampled; the warp's
  cv::Mat1i match_index_;  ///< the warp's right pixel per level pixel, one row
};

}  // namespace detail
}  // namespace bdis
