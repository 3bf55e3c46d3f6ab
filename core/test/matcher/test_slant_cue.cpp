// The slant cue (slant_cue.hpp) on hand-made disparity maps of known slope.
#include <gtest/gtest.h>

#include <cmath>

#include "bdis_stereo/matcher.hpp"
#include "slant_cue.hpp"

namespace {

using bdis::kNoDisparity;
using bdis::detail::SlantCue;

constexpr int kPatch = 8;        // level px; the box reaches 4 px to each side
constexpr float kHalving = 1.f;  // level px of disparity across a patch

/// d = 30 + gx * x + gy * y everywhere, confidence 1.
void plane(int w, int h, float gx, float gy, cv::Mat1f& disparity, cv::Mat1f& confidence) {
  disparity.create(h, w);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) disparity(y, x) = 30.f + gx * static_cast<float>(x) + gy * static_cast<float>(y);
  }
  confidence = cv::Mat1f(h, w, 1.f);
}

/// The factor the cue gives a slope of magnitude g.
float expectedFactor(float g) {
  const float change = g * static_cast<float>(kPatch);  // disparity across a patch
  return 1.f / (1.f + (change / kHalving) * (change / kHalving));
}

/// The slope magnitude a factor c stands for (the inverse of expectedFactor).
float slopeOf(float c) { return kHalving / static_cast<float>(kPatch) * std::sqrt(1.f / c - 1.f); }

TEST(SlantCue, FrontoParallelSurfaceKeepsItsConfidence) {
  cv::Mat1f d, c;
  plane(64, 48, 0.f, 0.f, d, c);
  SlantCue().apply(d, kPatch, kHalving, c);
  EXPECT_EQ(cv::countNonZero(c != 1.f), 0);
}

TEST(SlantCue, InteriorOfAPlaneGetsTheFactorOfItsSlope) {
  SlantCue cue;  // one object for all: buffers reused across sizes and slopes
  for (const auto& [gx, gy] : {std::pair<float, float>{0.25f, 0.f}, {0.f, -0.25f}, {0.1f, 0.2f}, {0.05f, 0.f}}) {
    cv::Mat1f d, c;
    plane(64, 48, gx, gy, d, c);
    cue.apply(d, kPatch, kHalving, c);
    const float want = expectedFactor(std::hypot(gx, gy));
    // Pixels whose boxes and neighbours' boxes lie inside the map: 2 box radii from the border.
    for (int y = 8; y < 40; ++y) {
      for (int x = 8; x < 56; ++x) {
        ASSERT_NEAR(c(y, x), want, 1e-4f) << "gx " << gx << " gy " << gy << " at " << x << "," << y;
      }
    }
  }
}

TEST(SlantCue, StrongerSlopeLowersTheConfidenceMore) {
  SlantCue cue;
  float previous = 1.f;
  for (float g : {0.02f, 0.06f, 0.12f, 0.25f, 0.5f}) {
    cv::Mat1f d, c;
    plane(40, 40, g, 0.f, d, c);
    cue.apply(d, kPatch, kHalving, c);
    EXPECT_LT(c(20, 20), previous) << "slope " << g;
    previous = c(20, 20);
  }
  EXPECT_NEAR(expectedFactor(0.125f), 0.5f, 1e-6f);  // 1 px across the patch halves it
}

TEST(SlantCue, BordersAndHolesSeeThePlanesSlopeFromOneSide) {
  cv::Mat1f d, c;
  const float g = 0.2f;
  plane(64, 48, g, 0.f, d, c);
  d(cv::Rect(24, 10, 12, 20)).setTo(kNoDisparity);  // a hole
  c(cv::Rect(24, 10, 12, 20)).setTo(0.f);
  cv::Mat1f before = c.clone();
  SlantCue().apply(d, kPatch, kHalving, c);
  for (int y = 0; y < 48; ++y) {
    for (int x = 0; x < 64; ++x) {
      if (d(y, x) < 0.f) {
        ASSERT_EQ(c(y, x), before(y, x)) << "no estimate at " << x << "," << y;
        continue;
      }
      // A box cut by the border or the hole averages a shifted stretch of
      // the plane: the slope read there is at least half of it, and at most
      // a little more (next to the hole's corners a cut box's centre moves
      // along the other axis too: up to 1.15 times the slope here).
      const float slope = slopeOf(c(y, x));
      ASSERT_GE(slope, 0.5f * g - 1e-3f) << x << "," << y;
      ASSERT_LE(slope, 1.2f * g) << x << "," << y;
    }
  }
}

TEST(SlantCue, DepthStepLowersTheConfidenceAlongItOnly) {
  cv::Mat1f d(40, 64, 20.f), c(40, 64, 1.f);
  d(cv::Rect(32, 0, 32, 40)).setTo(40.f);  // a step of 20 px at x = 32
  SlantCue().apply(d, kPatch, kHalving, c);
  EXPECT_LT(c(20, 31), 0.05f);
  EXPECT_LT(c(20, 32), 0.05f);
  EXPECT_EQ(c(20, 10), 1.f);  // more than two box radii away
  EXPECT_EQ(c(20, 54), 1.f);
}

TEST(SlantCue, EmptyMapAndMapsSmallerThanABox) {
  SlantCue cue;
  cv::Mat1f d(5, 3, kNoDisparity), c(5, 3, 0.f);
  cue.apply(d, kPatch, kHalving, c);
  EXPECT_EQ(cv::countNonZero(c), 0);
  cv::Mat1f d2, c2;
  plane(3, 5, 0.5f, 0.f, d2, c2);
  cue.apply(d2, kPatch, kHalving, c2);
  for (float v : c2) {
    EXPECT_TRUE(std::isfinite(v));
    EXPECT_GT(v, 0.f);
    EXPECT_LE(v, 1.f);
  }
}

}  // namespace
