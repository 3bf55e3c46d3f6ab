// The BDIS stereo matcher (Song et al., MICCAI 2022): coarse-to-fine dense
// inverse search whose patches are weighted by a Bayesian posterior and a
// spatial Gaussian. ROS-free; OpenCV core/imgproc only.
#pragma once

#include <memory>

#include <opencv2/core.hpp>

#include "bdis_stereo/params.hpp"

namespace bdis {

/// Marker for "no estimate" in MatchResult::disparity. Every real estimate is
/// >= 0 (d = x_left - x_right), so `d >= 0` tests for an estimate.
constexpr float kNoDisparity = -1.0f;

/// Smallest accepted input side, px.
constexpr int kMinImageSide = 32;

/// Per-pixel outputs at the full input resolution.
struct MatchResult {
  cv::Mat disparity;   ///< CV_32FC1, d >= 0 px, kNoDisparity where there is no estimate
  /// CV_32FC1 in [0, 1], 0 where there is no estimate: the probability that
  /// the estimate is within 2 px of the true disparity (calibrated on
  /// generated scenes: docs/method.md, "Calibration"). It maps a product of
  /// cues: the covering patches' mean posterior above chance, lowered where
  /// the estimate is in doubt for reasons the posteriors cannot see (the
  /// patches or the two views disagree, the surface is too slanted for a
  /// patch, the neighbourhood has few estimates or the estimate stands apart
  /// from them: "Confidence"); with MatcherParams::calibrated_confidence
  /// false, that product itself. A higher confidence has fewer outliers:
  /// threshold it to trade density for fewer wrong depths.
  cv::Mat confidence;
  cv::Mat variance;    ///< CV_32FC1 px^2 when compute_variance, NaN where no estimate; else empty
};

/// Which full-resolution maps compute() fills besides the disparity. A map
/// left out is released (empty) and costs nothing to upsample, and without the
/// confidence or the variance (whose outlier term reads the confidence) the
/// confidence's cues are not computed either (they change no disparity): a
/// node computes only what is subscribed.
struct MatchOutputs {
  /// Filled when false too while MatcherParams::min_confidence > 0 or
  /// two_scales is on: it then decides which estimates are published.
  bool confidence = true;
  bool variance = true;  ///< only with MatcherParams::compute_variance
};

/// Construct once, call compute() for every frame. Buffers are sized on the
/// first frame of a given size and reused: frames of an unchanged size do not
/// allocate (pass the same MatchResult back in to reuse its buffers too).
/// Not thread-safe: use one Matcher per thread.
class Matcher {
 public:
  /// Throws std::invalid_argument when params are invalid.
  explicit Matcher(const MatcherParams& params = MatcherParams{});
  ~Matcher();
  Matcher(Matcher&&) noexcept;
  Matcher& operator=(Matcher&&) noexcept;
  Matcher(const Matcher&) = delete;
  Matcher& operator=(const Matcher&) = delete;

  /// Validates and applies new parameters from the next compute().
  void setParams(const MatcherParams& params);
  const MatcherParams& params() const;

  /// Left and right: rectified, equal size, CV_8UC1 (mono) or CV_8UC3 (BGR),
  /// each side at least kMinImageSide. Pure black (0) pixels are treated as
  /// outside the rectified view. Throws std::invalid_argument on anything else.
  void compute(const cv::Mat& left, const cv::Mat& right, MatchResult& result,
               const MatchOutputs& outputs = MatchOutputs{});

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace bdis
