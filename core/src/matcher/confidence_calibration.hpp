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

/// The probability that an estimate whose cues multiply to `raw`, matched
/// with `finest_level` as the finest level, is within 2 px of the input
/// resolution; 0 for raw <= 0 (no estimate). Increasing in `raw`; constant
/// below 2^-40 and from 1 up. Fitted for finest levels 1 to 3; level 0 takes
/// level 1's table, levels above 3 level 3's.
float calibratedConfidence(float raw, int finest_level);

/// calibratedConfidence() of every pixel of `confidence`, in place.
void calibrateConfidence(cv::Mat1f& confidence, int finest_level);

}  // namespace detail
}  // namespace bdis
