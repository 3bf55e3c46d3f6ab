// The variance's outlier term (docs/method.md, "Variance"): an estimate is
// either right, with the small error its patches' window fit, spread and
// left-right difference describe, or an outlier, whose error those miss
// (a near miss on slanted tissue, a fattened edge, a dark guess). The
// confidence's cues rank which is which; so the variance adds the outlier's
// squared error times the probability their product (the confidence before
// its calibration) gives it,
// and a downstream node weighting depths by 1 / variance down-weights the
// likely outliers, not only the loosely pinned inliers.
#pragma once

#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>

namespace bdis {
namespace detail {

/// Probability that an estimate of confidence `c` is an outlier:
/// 1 / (1 + sqrt(c / c_half)), 1/2 at `c_half`, falling slowly over the
/// decades the confidence spans.
inline float outlierProbability(float confidence, float c_half) {
  return 1.f / (1.f + std::sqrt(std::max(confidence, 0.f) * (1.f / c_half)));
}

/// Adds `outlier_variance` (px^2 at the variance's scale) times
/// outlierProbability() of each estimate's confidence to its variance;
/// pixels without an estimate (disparity < 0) are left as they are.
void addOutlierVariance(const cv::Mat1f& disparity, const cv::Mat1f& confidence, float outlier_variance,
                        float c_half, cv::Mat1f& variance);

}  // namespace detail
}  // namespace bdis
