// The matcher's defaults with the confidence left as the cues' product, for
// the tests that ask the cues about named regions: their thresholds are set on
// the product's scale. The published confidence, a probability of being
// within 2 px, is tested by test_confidence_calibration, on the colon
// sequences and on the generated scenes.
#pragma once

#include "bdis_stereo/matcher.hpp"

namespace bdis_test {

inline bdis::MatcherParams cuesProductParams() {
  bdis::MatcherParams params;
  params.calibrated_confidence = false;
  return params;
}

}  // namespace bdis_test
