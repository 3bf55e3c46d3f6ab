// The neighbourhood cue (neighbourhood_cue.hpp) on hand-made maps: an even
// confidence stays as it is, a confident estimate among doubtful ones comes
// down and a doubtful one among confident ones up, holes count for nothing,
// and random maps match a slow box mean.
#include <cmath>

#include <gtest/gtest.h>

#include "bdis_stereo/matcher.hpp"
#include "neighbourhood_cue.hpp"

namespace {

using bdis::kNoDisparity;
using bdis::detail::NeighbourhoodCue;

constexpr int kPatch = 8;  // level px: a box of 5 x 5 blocks of 2 x 2 px

/// The first and last pixel of the box around pixel i: two blocks to each
/// side of its block, clipped to n pixels.
int boxBegin(int i) { return std::max(0, 2 * (i / 2) - 4); }
int boxEnd(int i, int n) { return std::min(n - 1, 2 * (i / 2) + 5); }

/// The cue's value at (x, y) the slow way: the mean confidence of the
/// estimates in its box, pooled 3 : 1.
float slowPooled(const cv::Mat1f& d, const cv::Mat1f& c, int x, int y) {
  double sum = 0.0;
  int count = 0;
  for (int yy = boxBegin(y); yy <= boxEnd(y, d.rows); ++yy) {
    for (int xx = boxBegin(x); xx <= boxEnd(x, d.cols); ++xx) {
      if (d(yy, xx) < 0.f) continue;
      sum += c(yy, xx);
      ++count;
    }
  }
  const double mean = sum / count;
  return static_cast<float>(std::pow(c(y, x), 0.75) * std::pow(mean, 0.25));
}

TEST(NeighbourhoodCue, AnEvenConfidenceStaysAsItIs) {
  cv::Mat1f d(40, 48, 25.f), c(40, 48, 0.3f);
  NeighbourhoodCue cue;
  cue.apply(d, kPatch, c);
  for (float v : c) ASSERT_NEAR(v, 0.3f, 1e-6f);
}

TEST(NeighbourhoodCue, ALoneConfidentEstimateComesDownAndALoneDoubtfulOneUp) {
  cv::Mat1f d(40, 48, 25.f), c(40, 48, 0.01f);
  c(20, 24) = 0.8f;
  cv::Mat1f doubtful(40, 48, 0.8f);
  doubtful(20, 24) = 0.01f;
  NeighbourhoodCue cue;
  cue.apply(d, kPatch, c);
  cue.apply(d, kPatch, doubtful);
  // The box of (24, 20): columns 20 .. 29, rows 16 .. 25.
  const float mean_low = (0.8f + 99.f * 0.01f) / 100.f, mean_high = (0.01f + 99.f * 0.8f) / 100.f;
  EXPECT_NEAR(c(20, 24), std::pow(0.8f, 0.75f) * std::pow(mean_low, 0.25f), 1e-5f);
  EXPECT_LT(c(20, 24), 0.35f);  // from 0.8
  EXPECT_NEAR(doubtful(20, 24), std::pow(0.01f, 0.75f) * std::pow(mean_high, 0.25f), 1e-5f);
  EXPECT_GT(doubtful(20, 24), 0.02f);  // from 0.01
  // Its neighbours within the box move the other way, by less.
  EXPECT_GT(c(20, 20), 0.01f);
  EXPECT_NEAR(c(20, 19), 0.01f, 1e-6f);  // outside the box
}

TEST(NeighbourhoodCue, HolesCountForNothingAndKeepTheirConfidence) {
  cv::Mat1f d(30, 30, 25.f), c(30, 30, 0.5f);
  d(cv::Rect(10, 10, 10, 10)).setTo(kNoDisparity);
  c(cv::Rect(10, 10, 10, 10)).setTo(0.f);
  NeighbourhoodCue cue;
  cue.apply(d, kPatch, c);
  EXPECT_EQ(cv::countNonZero(c(cv::Rect(10, 10, 10, 10))), 0);
  // The estimates around the hole see only estimates of 0.5.
  for (float v : c(cv::Rect(0, 0, 30, 10))) ASSERT_NEAR(v, 0.5f, 1e-6f);
}

TEST(NeighbourhoodCue, AFaintEstimateAfterBrightOnesStaysFinite) {
  // The box sums slide: what bright confidences add and then take away can
  // leave a sum a rounding step below 0 where only faint ones remain.
  cv::RNG rng(3);
  cv::Mat1f d(96, 96, 30.f), c(96, 96, 0.f);
  for (int y = 0; y < 48; ++y) {
    for (int x = 0; x < 96; ++x) c(y, x) = rng.uniform(0.f, 1.f);
  }
  for (int y = 48; y < 96; ++y) {
    for (int x = 0; x < 96; ++x) c(y, x) = x % 2 ? 0.f : rng.uniform(0.f, 1e-7f);
  }
  NeighbourhoodCue cue;
  cue.apply(d, kPatch, c);
  for (int y = 0; y < 96; ++y) {
    for (int x = 0; x < 96; ++x) ASSERT_TRUE(std::isfinite(c(y, x)) && c(y, x) >= 0.f) << x << "," << y;
  }
}

TEST(NeighbourhoodCue, RandomMapsWithHolesMatchTheSlowBoxMean) {
  cv::RNG rng(7);
  NeighbourhoodCue cue;  // one object: buffers reused across sizes
  for (const cv::Size size : {cv::Size(37, 23), cv::Size(64, 48), cv::Size(5, 3)}) {
    cv::Mat1f d(size), c(size);
    for (int y = 0; y < size.height; ++y) {
      for (int x = 0; x < size.width; ++x) {
        const bool hole = rng.uniform(0.f, 1.f) < 0.3f;
        d(y, x) = hole ? kNoDisparity : rng.uniform(0.f, 60.f);
        // confidences over five orders of magnitude, some exactly 0
        c(y, x) = hole || rng.uniform(0.f, 1.f) < 0.1f ? 0.f : std::pow(10.f, rng.uniform(-5.f, 0.f));
      }
    }
    const cv::Mat1f before = c.clone();
    cue.apply(d, kPatch, c);
    for (int y = 0; y < size.height; ++y) {
      for (int x = 0; x < size.width; ++x) {
        ASSERT_TRUE(std::isfinite(c(y, x))) << x << "," << y;
        if (d(y, x) < 0.f) {
          ASSERT_EQ(c(y, x), before(y, x));
          continue;
        }
        const float want = slowPooled(d, before, x, y);
        ASSERT_NEAR(c(y, x), want, 1e-4f * want + 1e-7f) << size << " at " << x << "," << y;
      }
    }
  }
}

}  // namespace
