// The confidence's calibration stage (confidence_calibration.hpp): the map
// from the cues' product to a probability of being within 2 px. Its values
// come from a fit (checked against ground truth in test_core's
// PresetCalibration and test_synth); here, the properties every use
// of it relies on.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include <opencv2/core.hpp>

#include "confidence_calibration.hpp"

namespace {

using bdis::detail::calibratedConfidence;

// The finest levels a table was fitted for.
const int kLevels[] = {1, 2, 3};

TEST(ConfidenceCalibration, NoEstimateStaysZero) {
  for (int level : kLevels) {
    EXPECT_EQ(calibratedConfidence(0.f, level), 0.f);
    EXPECT_EQ(calibratedConfidence(-1.f, level), 0.f);
    EXPECT_EQ(calibratedConfidence(std::numeric_limits<float>::quiet_NaN(), level), 0.f);
  }
}

TEST(ConfidenceCalibration, AProbabilityThatNeverFallsAsTheProductRises) {
  for (int level : kLevels) {
    SCOPED_TRACE("finest level " + std::to_string(level));
    // A denormal, then raw values from the smallest normal float to 2, about
    // 90 per octave: in (0, 1), and never lower than the previous.
    float previous = calibratedConfidence(std::numeric_limits<float>::denorm_min(), level);
    EXPECT_GT(previous, 0.f);
    int steps = 0;
    for (float raw = std::numeric_limits<float>::min(); raw < 2.f; raw *= 1.0078125f, ++steps) {
      const float p = calibratedConfidence(raw, level);
      ASSERT_GT(p, 0.f) << raw;
      ASSERT_LT(p, 1.f) << raw;
      ASSERT_GE(p, previous) << raw;
      previous = p;
    }
    EXPECT_GT(steps, 1000);
    // Across the table's span it rises from octave to octave: the order of
    // the estimates is the product's.
    for (int k = -40; k < 0; ++k) {
      EXPECT_GT(calibratedConfidence(std::ldexp(1.f, k + 1), level), calibratedConfidence(std::ldexp(1.f, k), level))
          << k;
    }
    // And it spans the range a threshold is chosen in.
    EXPECT_LT(calibratedConfidence(1e-9f, level), 0.6f);
    EXPECT_GT(calibratedConfidence(0.5f, level), 0.99f);
  }
}

TEST(ConfidenceCalibration, TheMostConfidentEstimatesKeepTheirOrder) {
  // Near 1 floats are about 6e-8 apart: a table that rose by a fixed 1e-6
  // per octave there gave the colon's products above 2^-3 (7 % of the
  // estimates) about 40 values to share, so a node taking the N most
  // confident met ties. 64 raw values per octave stay apart in the top ones.
  for (int level : kLevels) {
    SCOPED_TRACE("finest level " + std::to_string(level));
    float previous = 0.f;
    for (int k = -8; k < 0; ++k) {
      for (int i = 0; i < 64; ++i) {
        const float p = calibratedConfidence(std::ldexp(1.f + static_cast<float>(i) / 64.f, k), level);
        ASSERT_GT(p, previous) << k << " " << i;
        previous = p;
      }
    }
  }
}

TEST(ConfidenceCalibration, LevelsWithoutATableTakeTheNearestOnes) {
  for (const float raw : {1e-9f, 1e-6f, 1e-4f, 1e-2f, 0.3f}) {
    EXPECT_EQ(calibratedConfidence(raw, 0), calibratedConfidence(raw, 1)) << raw;
    EXPECT_EQ(calibratedConfidence(raw, 5), calibratedConfidence(raw, 3)) << raw;
  }
}

TEST(ConfidenceCalibration, ContinuousAtTheKnots) {
  // Linear in the mantissa between powers of two, so the value just below a
  // power of two meets the value at it.
  for (int level : kLevels) {
    for (int k = -40; k <= 0; ++k) {
      const float at = std::ldexp(1.f, k);
      const float below = std::nextafter(at, 0.f);
      EXPECT_NEAR(calibratedConfidence(below, level), calibratedConfidence(at, level), 1e-5f) << level << " " << k;
    }
  }
}

TEST(ConfidenceCalibration, TheStageMapsEveryPixelInPlace) {
  cv::Mat1f confidence(3, 5);
  const float raw[] = {0.f, 1e-12f, 1e-7f, 1e-5f, 1e-3f, 0.01f, 0.1f, 0.3f, 0.9f, 0.f, 2e-4f, 5e-6f, 1e-9f, 0.f, 0.05f};
  for (int i = 0; i < 15; ++i) confidence(i / 5, i % 5) = raw[i];
  bdis::detail::calibrateConfidence(confidence, 2);
  for (int i = 0; i < 15; ++i) EXPECT_EQ(confidence(i / 5, i % 5), calibratedConfidence(raw[i], 2)) << raw[i];
}

}  // namespace
