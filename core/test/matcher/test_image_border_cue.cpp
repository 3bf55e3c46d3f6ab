// The image border cue (image_border_cue.hpp) on hand-made maps: a surface
// that rises towards one edge, an upright one, holes and images too small
// for the cue.
#include <gtest/gtest.h>

#include "bdis_stereo/matcher.hpp"
#include "image_border_cue.hpp"

namespace {

using bdis::kNoDisparity;
using bdis::detail::ImageBorderCue;

constexpr int kPatch = 8;       // level px
constexpr float kHalving = 1.f;  // level px of shortfall that halves

float factor(float shortfall) { return 1.f / (1.f + (shortfall / kHalving) * (shortfall / kHalving)); }

TEST(ImageBorderCue, LowersTheEstimatesCarriedToAnEdgeTheSurfaceRisesTowards) {
  // d = 30 + 0.25 (95 - y): 0.25 px per px towards the top edge, flat across.
  cv::Mat1f d(96, 128), c(96, 128, 0.6f);
  for (int y = 0; y < d.rows; ++y) d.row(y).setTo(30.f + 0.25f * static_cast<float>(95 - y));
  ImageBorderCue cue;
  cue.apply(d, kPatch, kHalving, c);
  // The slope a patch side in is the surface's: 0.25 px per px, carried
  // kPatch - y px out to row y.
  for (int y = 0; y < kPatch; ++y) {
    EXPECT_NEAR(c(y, 64), 0.6f * factor(0.25f * static_cast<float>(kPatch - y)), 1e-5f) << y;
    EXPECT_NEAR(c(y, 3), c(y, 64), 1e-5f) << y;  // the side bands see no slope across
  }
  EXPECT_NEAR(c(0, 64), 0.6f / 5.f, 1e-5f);  // 2 px short at the edge: a fifth
  // At the bottom edge the surface falls away from the edge at the same
  // slope: the cue does not know which way the shortfall goes, only how large.
  EXPECT_NEAR(c(95, 64), c(0, 64), 1e-5f);
  // A patch side and more from every edge nothing changes.
  for (int y = kPatch; y < d.rows - kPatch; ++y) {
    for (int x = kPatch; x < d.cols - kPatch; ++x) ASSERT_EQ(c(y, x), 0.6f) << x << "," << y;
  }
}

TEST(ImageBorderCue, AnUprightSurfaceKeepsItsConfidenceAtTheEdges) {
  cv::Mat1f d(64, 80, 12.f), c(64, 80, 0.9f);
  ImageBorderCue cue;
  cue.apply(d, kPatch, kHalving, c);
  EXPECT_EQ(cv::countNonZero(c != 0.9f), 0);
}

TEST(ImageBorderCue, SlopeAlongTheRightEdgeAndHolesLeftAsTheyAre) {
  // d = 10 + 0.5 x: rising towards the right edge, by 0.5 px per px.
  cv::Mat1f d(64, 80), c(64, 80, 1.f);
  for (int x = 0; x < d.cols; ++x) d.col(x).setTo(10.f + 0.5f * static_cast<float>(x));
  d(cv::Rect(76, 20, 4, 4)).setTo(kNoDisparity);
  c(cv::Rect(76, 20, 4, 4)).setTo(0.f);
  ImageBorderCue cue;
  cue.apply(d, kPatch, kHalving, c);
  EXPECT_NEAR(c(40, 79), factor(0.5f * 8.f), 1e-5f);  // carried a patch side out to the edge
  EXPECT_NEAR(c(40, 72), factor(0.5f), 1e-5f);        // carried 1 px
  EXPECT_EQ(c(40, 71), 1.f);
  EXPECT_EQ(cv::countNonZero(c(cv::Rect(76, 20, 4, 4))), 0);  // no estimate: still 0
  // The left edge sees the same slope, carried as far.
  EXPECT_NEAR(c(40, 0), c(40, 79), 1e-5f);
}

TEST(ImageBorderCue, OneBoxWithoutEstimatesGivesNoSlope) {
  // The rows a patch side and a half in from the top are empty: no slope to take.
  cv::Mat1f d(64, 80), c(64, 80, 1.f);
  for (int y = 0; y < d.rows; ++y) d.row(y).setTo(20.f + 0.5f * static_cast<float>(63 - y));
  d.rowRange(8, 17).setTo(kNoDisparity);
  ImageBorderCue cue;
  cue.apply(d, kPatch, kHalving, c);
  EXPECT_EQ(c(0, 40), 1.f);
  EXPECT_LT(c(63, 40), 0.5f);  // the bottom edge has both boxes
}

TEST(ImageBorderCue, ImagesUnderTwoPatchSidesAreLeftAsTheyAre) {
  cv::Mat1f d(16, 40), c(16, 40, 1.f);
  for (int y = 0; y < d.rows; ++y) d.row(y).setTo(20.f + 2.f * static_cast<float>(y));
  ImageBorderCue cue;
  cue.apply(d, kPatch, kHalving, c);
  EXPECT_EQ(cv::countNonZero(c != 1.f), 0);
}

}  // namespace
