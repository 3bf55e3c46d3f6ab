// The choice between two scales (scale_choice.hpp) on hand-made results.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <opencv2/core.hpp>

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

/// What the choice should do, pixel by pixel: take the coarser estimate
/// where both estimate, it is more confident and no pixel in the box of
/// `reach` around takes part in a jump of more than `jump` with a 4-neighbour.
MatchResult chosenByDefinition(const MatchResult& coarser, const MatchResult& finer, float jump, int reach) {
  const cv::Mat1f d = finer.disparity;
  auto in_jump = [&](int y, int x) {
    const int dx[] = {1, -1, 0, 0}, dy[] = {0, 0, 1, -1};
    for (int k = 0; k < 4; ++k) {
      const int u = x + dx[k], v = y + dy[k];
      if (u < 0 || v < 0 || u >= d.cols || v >= d.rows) continue;
      if (d(y, x) >= 0.f && d(v, u) >= 0.f && std::fabs(d(y, x) - d(v, u)) > jump) return true;
    }
    return false;
  };
  MatchResult out;
  out.disparity = finer.disparity.clone();
  out.confidence = finer.confidence.clone();
  out.variance = finer.variance.clone();
  for (int y = 0; y < d.rows; ++y) {
    for (int x = 0; x < d.cols; ++x) {
      bool near = false;
      for (int v = std::max(0, y - reach); v <= std::min(d.rows - 1, y + reach) && !near; ++v) {
        for (int u = std::max(0, x - reach); u <= std::min(d.cols - 1, x + reach) && !near; ++u) near = in_jump(v, u);
      }
      const bool take = d(y, x) >= 0.f && coarser.disparity.at<float>(y, x) >= 0.f &&
                        coarser.confidence.at<float>(y, x) > finer.confidence.at<float>(y, x) && !near;
      if (!take) continue;
      out.disparity.at<float>(y, x) = coarser.disparity.at<float>(y, x);
      out.confidence.at<float>(y, x) = coarser.confidence.at<float>(y, x);
      out.variance.at<float>(y, x) = coarser.variance.at<float>(y, x);
    }
  }
  return out;
}

TEST(ScaleChoice, MatchesTheDefinitionOnRandomMapsWithHolesAndEdgesEverywhere) {
  cv::RNG rng(7);
  for (const int reach : {1, 2, 3, 5, 8, 16}) {
    for (const cv::Size size : {cv::Size(1, 1), cv::Size(3, 40), cv::Size(37, 2), cv::Size(61, 29)}) {
      MatchResult finer, coarser;
      for (MatchResult* r : {&finer, &coarser}) {
        r->disparity.create(size, CV_32FC1);
        r->confidence.create(size, CV_32FC1);
        r->variance.create(size, CV_32FC1);
        rng.fill(r->confidence, cv::RNG::UNIFORM, 0.f, 1.f);
        rng.fill(r->variance, cv::RNG::UNIFORM, 0.f, 4.f);
      }
      // Mostly smooth steps with a few jumps and holes, so that some boxes
      // hold no jump at every reach.
      for (int y = 0; y < size.height; ++y) {
        for (int x = 0; x < size.width; ++x) {
          const double u = rng.uniform(0., 1.);
          finer.disparity.at<float>(y, x) = u < 0.05 ? kNoDisparity : (u < 0.07 ? 40.f : 20.f + 0.01f * static_cast<float>(x));
          coarser.disparity.at<float>(y, x) = rng.uniform(0., 1.) < 0.1 ? kNoDisparity : 21.f;
        }
      }
      const MatchResult expected = chosenByDefinition(coarser, finer, 2.f, reach);
      ScaleChoice choice;
      const int taken = choice.keepMoreConfident(coarser, 2.f, reach, finer);
      EXPECT_EQ(cv::norm(finer.disparity, expected.disparity, cv::NORM_INF), 0.) << "reach " << reach << " " << size;
      EXPECT_EQ(cv::norm(finer.confidence, expected.confidence, cv::NORM_INF), 0.) << "reach " << reach;
      EXPECT_EQ(cv::norm(finer.variance, expected.variance, cv::NORM_INF), 0.) << "reach " << reach;
      EXPECT_EQ(taken, cv::countNonZero(expected.disparity == 21.f)) << "reach " << reach << " " << size;
    }
  }
}

}  // namespace
