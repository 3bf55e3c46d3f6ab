// The image border cue (image_border_cue.hpp) on hand-made maps: a surface
// that rises towards one edge, an upright one, holes and images too small
// for the cue.
#include <gtest/gtest.h>

#include <algorithm>

#include "bdis_stereo/matcher.hpp"
#include "confidence.hpp"
#include "image_border_cue.hpp"

namespace {

using bdis::kNoDisparity;
using bdis::detail::ImageBorderCue;
using bdis::detail::kImageBorderKeptAtEdge;

constexpr int kPatch = 8;       // level px
constexpr float kHalving = 1.f;  // level px of shortfall that halves

float factor(float shortfall) { return 1.f / (1.f + (shortfall / kHalving) * (shortfall / kHalving)); }

/// The share kept for the one-sided start, `from_edge` px from the nearest edge.
float start(int from_edge) {
  return std::min(1.f, kImageBorderKeptAtEdge + (1.f - kImageBorderKeptAtEdge) * static_cast<float>(from_edge) /
                                                    static_cast<float>(2 * kPatch));
}

TEST(ImageBorderCue, LowersTheEstimatesCarriedToAnEdgeTheSurfaceRisesTowards) {
  // d = 30 + 0.25 (95 - y): 0.25 px per px towards the top edge, flat across.
  cv::Mat1f d(96, 128), c(96, 128, 0.6f);
  for (int y = 0; y < d.rows; ++y) d.row(y).setTo(30.f + 0.25f * static_cast<float>(95 - y));
  ImageBorderCue cue;
  cue.apply(d, kPatch, kHalving, c);
  // The slope a patch side in is the surface's: 0.25 px per px, carried
  // kPatch - y px out to row y.
  for (int y = 0; y < kPatch; ++y) {
    EXPECT_NEAR(c(y, 64), 0.6f * start(y) * factor(0.25f * static_cast<float>(kPatch - y)), 1e-5f) << y;
    // The side bands see no slope across, only their own edge's start.
    EXPECT_NEAR(c(y, 3), 0.6f * start(std::min(y, 3)) * factor(0.25f * static_cast<float>(kPatch - y)), 1e-5f)
        << y;
  }
  EXPECT_NEAR(c(0, 64), 0.6f / 5.f * 0.25f, 1e-5f);  // 2 px short at the edge: a fifth, of a quarter
  // At the bottom edge the surface falls away from the edge at the same
  // slope: the cue does not know which way the shortfall goes, only how large.
  EXPECT_NEAR(c(95, 64), c(0, 64), 1e-5f);
  // From a patch side to two in, only the start lowers it.
  EXPECT_NEAR(c(12, 64), 0.6f * start(12), 1e-6f);
  // Two patch sides and more from every edge nothing changes.
  for (int y = 2 * kPatch; y < d.rows - 2 * kPatch; ++y) {
    for (int x = 2 * kPatch; x < d.cols - 2 * kPatch; ++x) ASSERT_EQ(c(y, x), 0.6f) << x << "," << y;
  }
}

TEST(ImageBorderCue, AnUprightSurfaceLosesOnlyTheStartsShareAtTheEdges) {
  cv::Mat1f d(64, 80, 12.f), c(64, 80, 0.9f);
  ImageBorderCue cue;
  cue.apply(d, kPatch, kHalving, c);
  for (int y = 0; y < d.rows; ++y) {
    for (int x = 0; x < d.cols; ++x) {
      const int from_edge = std::min(std::min(y, d.rows - 1 - y), std::min(x, d.cols - 1 - x));
      ASSERT_NEAR(c(y, x), 0.9f * start(from_edge), 1e-6f) << x << "," << y;
    }
  }
  EXPECT_NEAR(c(0, 40), 0.9f * 0.25f, 1e-6f);  // a quarter at the edge
  EXPECT_EQ(c(32, 16), 0.9f);                   // all of it two patch sides in
  EXPECT_LT(c(32, 15), 0.9f);
}

TEST(ImageBorderCue, SlopeAlongTheRightEdgeAndHolesLeftAsTheyAre) {
  // d = 10 + 0.5 x: rising towards the right edge, by 0.5 px per px.
  cv::Mat1f d(64, 80), c(64, 80, 1.f);
  for (int x = 0; x < d.cols; ++x) d.col(x).setTo(10.f + 0.5f * static_cast<float>(x));
  d(cv::Rect(76, 20, 4, 4)).setTo(kNoDisparity);
  c(cv::Rect(76, 20, 4, 4)).setTo(0.f);
  ImageBorderCue cue;
  cue.apply(d, kPatch, kHalving, c);
  EXPECT_NEAR(c(40, 79), start(0) * factor(0.5f * 8.f), 1e-5f);  // carried a patch side out to the edge
  EXPECT_NEAR(c(40, 72), start(7) * factor(0.5f), 1e-5f);        // carried 1 px
  EXPECT_NEAR(c(40, 71), start(8), 1e-6f);                       // carried none
  EXPECT_EQ(c(40, 63), 1.f);
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
  EXPECT_NEAR(c(0, 40), start(0), 1e-6f);  // the start's share only
  EXPECT_LT(c(63, 40), 0.5f * start(0));   // the bottom edge has both boxes
}

TEST(ImageBorderCue, ImagesUnderTwoPatchSidesAreLeftAsTheyAre) {
  cv::Mat1f d(16, 40), c(16, 40, 1.f);
  for (int y = 0; y < d.rows; ++y) d.row(y).setTo(20.f + 2.f * static_cast<float>(y));
  ImageBorderCue cue;
  cue.apply(d, kPatch, kHalving, c);
  EXPECT_EQ(cv::countNonZero(c != 1.f), 0);
}

}  // namespace
