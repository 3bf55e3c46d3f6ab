// The left-right check (left_right_check.hpp) on hand-made rows.
#include <gtest/gtest.h>

#include <cmath>

#include "bdis_stereo/matcher.hpp"
#include "confidence.hpp"
#include "left_right_check.hpp"

namespace {

using bdis::kNoDisparity;
using bdis::detail::kLeftRightVarianceShare;
using bdis::detail::leftRightCheck;

/// One row of 20 px: left estimates at columns 10-12 with disparity 4, so
/// their matches are right columns 6-8, which the mirrored row holds at
/// columns 19 - 6 .. 19 - 8.
struct Row {
  cv::Mat1f left = cv::Mat1f(1, 20, kNoDisparity), mirrored = cv::Mat1f(1, 20, kNoDisparity);
  cv::Mat1f confidence = cv::Mat1f(1, 20, 0.f), variance = cv::Mat1f(1, 20, 0.f);
  Row() {
    for (int x = 10; x <= 12; ++x) {
      left(0, x) = 4.f;
      confidence(0, x) = 0.8f;
      variance(0, x) = 0.1f;
    }
  }
  float& back(int right_x) { return mirrored(0, 19 - right_x); }
};

TEST(LeftRightCheck, AgreementKeepsDifferenceLowersBeyondToleranceDrops) {
  Row r;
  r.back(6) = 4.f;    // column 10: confirmed
  r.back(7) = 4.5f;   // column 11: 0.5 px off
  r.back(8) = 7.f;    // column 12: 3 px off, beyond a tolerance of 2
  leftRightCheck(r.mirrored, /*tolerance=*/2.f, /*halving=*/0.5f, r.left, r.confidence, &r.variance);
  EXPECT_EQ(r.left(0, 10), 4.f);
  EXPECT_FLOAT_EQ(r.confidence(0, 10), 0.8f);
  EXPECT_FLOAT_EQ(r.variance(0, 10), 0.1f);
  // Half the confidence at the halving difference; the variance grows by a share of its square.
  EXPECT_EQ(r.left(0, 11), 4.f);
  EXPECT_FLOAT_EQ(r.confidence(0, 11), 0.4f);
  EXPECT_FLOAT_EQ(r.variance(0, 11), 0.1f + kLeftRightVarianceShare * 0.25f);
  EXPECT_EQ(r.left(0, 12), kNoDisparity);
  EXPECT_EQ(r.confidence(0, 12), 0.f);
}

TEST(LeftRightCheck, NoEstimateToConfirmOrAMatchOutsideTheImageDrops) {
  Row r;
  r.back(6) = 4.f;
  // Column 11's match (right column 7) has no estimate.
  r.left(0, 2) = 4.f;  // match at right column -2: outside the image
  r.confidence(0, 2) = 0.9f;
  leftRightCheck(r.mirrored, 2.f, 0.5f, r.left, r.confidence, nullptr);
  EXPECT_EQ(r.left(0, 10), 4.f);
  EXPECT_EQ(r.left(0, 11), kNoDisparity);
  EXPECT_EQ(r.left(0, 2), kNoDisparity);
  EXPECT_EQ(r.confidence(0, 2), 0.f);
}

}  // namespace
