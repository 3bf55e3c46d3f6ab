// The choice between two scales (scale_choice.hpp) on hand-made results.
#include <gtest/gtest.h>

#include <cmath>

#include "bdis_stereo/matcher.hpp"
#include "scale_choice.hpp"

namespace {

using bdis::kNoDisparity;
using bdis::MatchResult;
using bdis::detail::ScaleChoice;

int keepMoreConfident(const MatchResult& coarser, MatchResult& result, int reach_px = 2) {
  ScaleChoice choice;
  return choice.keepMoreConfident(coarser, 2.f, reach_px, result);
}

MatchResult result(float disparity, float confidence, float variance, int w = 4, int h = 3) {
  MatchResult r;
  r.disparity = cv::Mat(h, w, CV_32FC1, cv::Scalar(disparity));
  r.confidence = cv::Mat(h, w, CV_32FC1, cv::Scalar(confidence));
  r.variance = cv::Mat(h, w, CV_32FC1, cv::Scalar(variance));
  return r;
}

TEST(ScaleChoice, TheMoreConfidentEstimateIsKeptWithItsVariance) {
  MatchResult finer = result(20.f, 0.6f, 0.5f);
  MatchResult coarser = result(24.f, 0.9f, 2.f);
  coarser.confidence.at<float>(1, 2) = 0.5f;  // less confident there
  coarser.confidence.at<float>(2, 3) = 0.6f;  // as confident: the finer stays
  EXPECT_EQ(keepMoreConfident(coarser, finer), 10);
  EXPECT_EQ(finer.disparity.at<float>(0, 0), 24.f);
  EXPECT_EQ(finer.confidence.at<float>(0, 0), 0.9f);
  EXPECT_EQ(finer.variance.at<float>(0, 0), 2.f);
  EXPECT_EQ(finer.disparity.at<float>(1, 2), 20.f);
  EXPECT_EQ(finer.variance.at<float>(1, 2), 0.5f);
  EXPECT_EQ(finer.disparity.at<float>(2, 3), 20.f);
}

TEST(ScaleChoice, HolesOfEitherScaleAreNotFilled) {
  // A pixel without a finer estimate stays without one, however confident
  // the coarser; a coarser hole leaves the finer estimate.
  MatchResult finer = result(20.f, 0.6f, 0.5f);
  finer.disparity.at<float>(0, 1) = kNoDisparity;
  finer.confidence.at<float>(0, 1) = 0.f;
  finer.variance.at<float>(0, 1) = std::nanf("");
  MatchResult coarser = result(24.f, 0.95f, 2.f);
  coarser.disparity.at<float>(2, 0) = kNoDisparity;
  coarser.confidence.at<float>(2, 0) = 0.f;
  EXPECT_EQ(keepMoreConfident(coarser, finer), 10);
  EXPECT_EQ(finer.disparity.at<float>(0, 1), kNoDisparity);
  EXPECT_EQ(finer.confidence.at<float>(0, 1), 0.f);
  EXPECT_TRUE(std::isnan(finer.variance.at<float>(0, 1)));
  EXPECT_EQ(finer.disparity.at<float>(2, 0), 20.f);
}

TEST(ScaleChoice, WithoutAVarianceOnlyDisparityAndConfidenceChange) {
  MatchResult finer = result(20.f, 0.6f, 0.5f);
  finer.variance.release();
  const MatchResult coarser = result(24.f, 0.9f, 2.f);
  EXPECT_EQ(keepMoreConfident(coarser, finer), 12);
  EXPECT_TRUE(finer.variance.empty());
  EXPECT_EQ(finer.disparity.at<float>(1, 1), 24.f);
}

TEST(ScaleChoice, NearADepthEdgeTheFinerEstimateStays) {
  // A jump of more than 2 px between the finer estimates of columns 9 and 10:
  // within the reach (3 px) of either side the coarser patches straddle the
  // edge, so the finer estimates stay; beyond it the coarser are taken.
  MatchResult finer = result(20.f, 0.6f, 0.5f, 24, 9);
  finer.disparity.colRange(10, 24).setTo(30.f);
  MatchResult coarser = result(25.f, 0.9f, 2.f, 24, 9);
  ScaleChoice choice;
  EXPECT_EQ(choice.keepMoreConfident(coarser, 2.f, 3, finer), 9 * (24 - 8));
  for (int x = 0; x < 24; ++x) {
    const bool near_edge = x >= 6 && x <= 13;
    EXPECT_EQ(finer.disparity.at<float>(4, x), near_edge ? (x < 10 ? 20.f : 30.f) : 25.f) << "x " << x;
  }
  // A step of 2 px is no edge: everything is taken.
  MatchResult gentle = result(20.f, 0.6f, 0.5f, 24, 9);
  gentle.disparity.colRange(10, 24).setTo(22.f);
  EXPECT_EQ(choice.keepMoreConfident(coarser, 2.f, 3, gentle), 9 * 24);
}

}  // namespace
