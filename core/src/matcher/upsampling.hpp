// From the finest searched level to the input resolution (docs/method.md,
// "Upsampling"): bilinear among the neighbouring level pixels that have an
// estimate, disparities scaled by 2^s, only where the input pixel is valid.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "bdis_stereo/matcher.hpp"
#include "fusion.hpp"  // LevelMaps

namespace bdis {
namespace detail {

class Upsampler {
 public:
  /// out.disparity and, `with_confidence`, out.confidence (CV_32FC1, the
  /// size of `full_valid`; else out.confidence is released) from the level-s
  /// maps. A pixel gets an estimate where `full_valid` is set and the level
  /// pixels around it that have one carry more than a quarter of the
  /// bilinear weight.
  void upsample(const LevelMaps& level, int s, const cv::Mat1b& full_valid, bool with_confidence, MatchResult& out);
  /// out.variance from level.variance, after upsample(): the bilinear mean
  /// of the neighbours with an estimate, scaled by 4^s times `calibration`;
  /// NaN where out.disparity has no estimate.
  void upsampleVariance(const LevelMaps& level, int s, MatchResult& out, float calibration = 1.f);

 private:
  /// The level columns and weight of each output column (the same on every row).
  void columnTaps(int out_width, int level_width, float inv_scale);

  std::vector<int> x0_, x1_;
  std::vector<float> ax_;
  // The two level rows blended vertically (level width), then interpolated
  // to the output columns (output width).
  std::vector<float> weight_, disparity_, confidence_, variance_;
  std::vector<float> row_weight_, row_disparity_, row_confidence_;
};

}  // namespace detail
}  // namespace bdis
