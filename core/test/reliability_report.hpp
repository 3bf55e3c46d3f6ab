// One line of the confidence's calibration for a test's log: what a failing
// bound is read against, printed the same way by every test that checks it.
#pragma once

#include <cstdio>

#include "bdis_stereo/error_analysis.hpp"

namespace bdis_test {

/// Prints `label`'s expected calibration error, bad2 predicted and found,
/// each bin's share and mean confidence / share within 2 px, and the most a
/// bin from `from_confidence` up claims over what it has, which it returns.
inline double reportReliability(const char* label, const bdis::Reliability& r, float from_confidence = 0.f) {
  std::printf("  %s: expected calibration error %.3f, bad2 predicted %.1f%% / found %.1f%%; bins:", label,
              r.expected_error, 100 * (1 - r.mean_confidence), 100 * (1 - r.within2));
  for (const bdis::ReliabilityBin& b : r.bins) std::printf(" %.1f%% %.3f/%.3f", 100 * b.share, b.mean_confidence, b.within2);
  const double over_claim = r.mostClaimedOver(from_confidence);
  std::printf("; most claimed over from %.1f up %.3f\n", from_confidence, over_claim);
  return over_claim;
}

}  // namespace bdis_test
