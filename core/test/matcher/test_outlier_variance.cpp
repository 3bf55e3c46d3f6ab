// The variance's outlier term (outlier_variance.hpp) on hand-made maps.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "bdis_stereo/matcher.hpp"
#include "outlier_variance.hpp"

namespace {

using bdis::kNoDisparity;
using bdis::detail::addOutlierVariance;
using bdis::detail::outlierProbability;

TEST(OutlierVariance, ProbabilityIsOneHalfAtTheHalfConfidenceAndFallsWithIt) {
  EXPECT_FLOAT_EQ(outlierProbability(1e-5f, 1e-5f), 0.5f);
  EXPECT_FLOAT_EQ(outlierProbability(1e-3f, 1e-5f), 1.f / 11.f);  // sqrt(100) = 10
  EXPECT_FLOAT_EQ(outlierProbability(0.f, 1e-5f), 1.f);
  EXPECT_FLOAT_EQ(outlierProbability(-1.f, 1e-5f), 1.f);  // no confidence is no evidence
  float previous = 1.f;
  for (float c = 1e-9f; c <= 1.f; c *= 10.f) {
    const float q = outlierProbability(c, 1e-5f);
    EXPECT_LT(q, previous) << c;
    previous = q;
  }
}

TEST(OutlierVariance, AddsTheOutliersVarianceTimesItsProbabilityWhereThereIsAnEstimate) {
  const float kNaN = std::numeric_limits<float>::quiet_NaN();
  cv::Mat1f disparity(2, 3, 10.f), confidence(2, 3, 0.f), variance(2, 3, 0.25f);
  confidence(0, 0) = 1e-5f;  // q = 1/2
  confidence(0, 1) = 1e-3f;  // q = 1/11
  confidence(0, 2) = 1e-9f;  // q = 1 / (1 + 0.01)
  disparity(1, 0) = kNoDisparity;
  variance(1, 0) = kNaN;
  disparity(1, 1) = kNoDisparity;  // no estimate: left as it is
  confidence(1, 2) = 1.f;          // q = 1 / (1 + sqrt(1e5))
  addOutlierVariance(disparity, confidence, 8.f, 1e-5f, variance);
  EXPECT_FLOAT_EQ(variance(0, 0), 0.25f + 8.f * 0.5f);
  EXPECT_FLOAT_EQ(variance(0, 1), 0.25f + 8.f / 11.f);
  EXPECT_NEAR(variance(0, 2), 0.25f + 8.f / 1.01f, 1e-5f);
  EXPECT_TRUE(std::isnan(variance(1, 0)));
  EXPECT_FLOAT_EQ(variance(1, 1), 0.25f);
  EXPECT_NEAR(variance(1, 2), 0.25f + 8.f / (1.f + std::sqrt(1e5f)), 1e-6f);
}

TEST(OutlierVariance, RejectsMapsOfDifferentSizes) {
  cv::Mat1f disparity(2, 3, 1.f), confidence(2, 3, 1.f), variance(3, 2, 0.f);
  EXPECT_THROW(addOutlierVariance(disparity, confidence, 8.f, 1e-5f, variance), cv::Exception);
}

}  // namespace
