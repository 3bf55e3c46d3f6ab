// The slant cue of the confidence (docs/method.md, "Confidence"): a patch
// matches one disparity over its whole footprint, so where the surface is
// strongly slanted (tissue close to the scope seen at a grazing angle, its
// texture foreshortened differently in the two views) no single disparity
// fits the patch and its optimum is less trustworthy than its posterior
// says. The slope is that of the surface around the pixel: the derivative of
// the disparity averaged over a patch-sized box, not of the pixel's
// neighbours, whose small jitter says nothing about the slant.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

namespace bdis {
namespace detail {

class SlantCue {
 public:
  /// Multiplies the confidence of each estimate of `disparity` (level px;
  /// kNoDisparity where none) by agreement() of the disparity change across
  /// a patch, |grad D| * `patch_px`, with `halving` (level px). grad D is
  /// the central difference, `patch_px` / 2 to each side, of the mean of the
  /// estimates in a box of side `patch_px` + 1 around each pixel (one-sided
  /// where one side's box holds no estimate, 0 along an axis where neither
  /// does). Buffers are kept for the next frame of the same size; the box
  /// sums are separable, in row loops that vectorise.
  void apply(const cv::Mat1f& disparity, int patch_px, float halving, cv::Mat1f& confidence);

 private:
  std::vector<float> padded_value_, padded_count_;  ///< a row, 0 where no estimate, r zeros each side
  cv::Mat1f row_sum_, row_count_;                   ///< the rows' horizontal box sums
  std::vector<float> column_sum_, column_count_;    ///< one row of box sums
  /// Box mean of the estimates, kNoDisparity where the box has none; r
  /// columns of kNoDisparity each side, and one all-kNoDisparity row last
  /// (stands in for the rows above the first and below the last).
  cv::Mat1f mean_;
};

}  // namespace detail
}  // namespace bdis
