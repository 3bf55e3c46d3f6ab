// The confidence as a probability (docs/method.md, "Calibration"): the
// cues' product spans many decades, and its value says little by itself.
// Mapped through a table fitted on generated scenes, it reads as the share
// of estimates within 2 px of the true disparity among those given that
// confidence, so that a threshold of 0.9 means about one wrong depth in ten
// at the threshold. The map is increasing, so the order of the estimates,
// and with it every ranking figure, is the product's.
#pragma once

#include <opencv2/core.hpp>

namespace bdis {
namespace detail {

/// The probability that an estimate whose cues multiply to `raw` is within
/// 2 px; 0 for raw <= 0 (no estimate). Increasing in `raw`; constant below
/// 2^-40 and from 1 up.
float calibratedConfidence(float raw);

/// calibratedConfidence() of every pixel of `confidence`, in place.
void calibrateConfidence(cv::Mat1f& confidence);

}  // namespace detail
}  // namespace bdis
