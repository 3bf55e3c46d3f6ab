// The consensus cue (consensus_cue.hpp) on hand-made maps: planes, where a
// pixel lies at the mean of a box centred on it, and a blob of wrong
// estimates a few px off the surface around it.
#include <cmath>

#include <gtest/gtest.h>

#include "bdis_stereo/matcher.hpp"
#include "consensus_cue.hpp"

namespace {

using bdis::kNoDisparity;
using bdis::detail::ConsensusCue;

constexpr int kPatch = 8;         // level px: the box is 17 blocks of 2 x 2 px, 34 px, each way 16-17 px
constexpr float kHalving = 0.5f;  // level px of distance from the box mean that halves

float factor(float deviation) { return 1.f / (1.f + (deviation / kHalving) * (deviation / kHalving)); }

/// The box mean the cue takes for (x, y), computed the slow way: the
/// estimates of the 2 x 2 blocks within kPatch blocks of the pixel's block.
float boxMean(const cv::Mat1f& d, int x, int y) {
  double sum = 0.0;
  int count = 0;
  for (int yy = 2 * (y / 2 - kPatch); yy < 2 * (y / 2 + kPatch + 1); ++yy) {
    for (int xx = 2 * (x / 2 - kPatch); xx < 2 * (x / 2 + kPatch + 1); ++xx) {
      if (yy < 0 || xx < 0 || yy >= d.rows || xx >= d.cols || d(yy, xx) < 0.f) continue;
      sum += d(yy, xx);
      ++count;
    }
  }
  return static_cast<float>(sum / count);
}

TEST(ConsensusCue, SlantedPlaneKeepsItsConfidenceAwayFromTheBorder) {
  // d = 20 + 0.3 x + 0.1 y: a slant of 0.3 px per px, three times the slant
  // cue's halving across a patch. Inside, a box centred (to half a pixel) on
  // the pixel has the pixel's disparity as its mean.
  cv::Mat1f d(96, 128), c(96, 128, 1.f);
  for (int y = 0; y < d.rows; ++y) {
    for (int x = 0; x < d.cols; ++x) d(y, x) = 20.f + 0.3f * x + 0.1f * y;
  }
  ConsensusCue cue;
  cue.apply(d, kPatch, kHalving, c);
  for (int y = 20; y < 76; ++y) {
    for (int x = 20; x < 108; ++x) {
      // the block's box is off-centre by half a pixel for even x and y: 0.15 + 0.05 px
      ASSERT_GT(c(y, x), factor(0.21f)) << x << "," << y;
    }
  }
  // At the border the box is clipped and its mean lies inside: an upright
  // plane still agrees with it, a slanted one less.
  EXPECT_LT(c(0, 0), 0.5f);
}

TEST(ConsensusCue, ABlobOffTheSurfaceIsDiscountedAndItsSurroundingsMuchLess) {
  cv::Mat1f d(96, 128, 30.f), c(96, 128, 0.8f);
  d(cv::Rect(56, 40, 12, 12)).setTo(33.f);  // 144 estimates 3 px too far
  ConsensusCue cue;
  cue.apply(d, kPatch, kHalving, c);
  // The blob is 144 of the box's 34 x 34 estimates: the mean is 30.37, the
  // blob's centre 2.63 px from it.
  const float mean = 30.f + 3.f * 144.f / (34.f * 34.f);
  EXPECT_NEAR(c(46, 62), 0.8f * factor(33.f - mean), 1e-4f);
  EXPECT_LT(c(46, 62), 0.8f * 0.05f);
  // The surface beside the blob: 0.37 px from the mean, the confidence about 0.64 of it.
  EXPECT_NEAR(c(46, 50), 0.8f * factor(mean - 30.f), 1e-4f);
  EXPECT_GT(c(46, 50), 0.8f * 0.6f);
  // Out of the blob's reach the surface keeps its confidence.
  EXPECT_EQ(c(46, 10), 0.8f);
}

TEST(ConsensusCue, MatchesTheBoxMeanOfTheEstimatesAroundHoles) {
  cv::Mat1f d(61, 77), c(61, 77, 1.f);  // odd sizes: the last blocks are partly outside
  cv::RNG rng(5);
  for (int y = 0; y < d.rows; ++y) {
    for (int x = 0; x < d.cols; ++x) {
      d(y, x) = rng.uniform(0.f, 1.f) < 0.3f ? kNoDisparity : 10.f + rng.uniform(-2.f, 2.f);
    }
  }
  const cv::Mat1f before = d.clone();
  ConsensusCue cue;
  cue.apply(d, kPatch, kHalving, c);
  for (int y = 0; y < d.rows; ++y) {
    for (int x = 0; x < d.cols; ++x) {
      if (d(y, x) < 0.f) {
        ASSERT_EQ(c(y, x), 1.f) << "a pixel without an estimate keeps what it has";
        continue;
      }
      ASSERT_NEAR(c(y, x), factor(d(y, x) - boxMean(d, x, y)), 1e-4f) << x << "," << y;
    }
  }
  EXPECT_EQ(cv::countNonZero(d != before), 0) << "the disparity is not changed";
}

TEST(ConsensusCue, TinyMapsAndReusedBuffers) {
  ConsensusCue cue;
  for (const auto& [w, h] : {std::pair<int, int>{1, 1}, {2, 1}, {3, 40}, {40, 3}, {64, 48}, {5, 5}}) {
    cv::Mat1f d(h, w, 7.f), c(h, w, 1.f);
    cue.apply(d, kPatch, kHalving, c);
    EXPECT_EQ(cv::countNonZero(c != 1.f), 0) << w << "x" << h;
  }
  cv::Mat1f d(5, 5, kNoDisparity), c(5, 5, 0.f);
  d(2, 2) = 3.f;
  c(2, 2) = 1.f;
  cue.apply(d, kPatch, kHalving, c);  // the box is the whole map: the lone estimate is its own mean
  EXPECT_EQ(c(2, 2), 1.f);
}

}  // namespace
