// The edge distance cue (edge_distance_cue.hpp) on hand-made maps: a depth
// step, a smooth slant and holes (no jumps), and random maps against a
// brute-force reference of the same definition.
#include <algorithm>
#include <cmath>
#include <cstdlib>

#include <gtest/gtest.h>

#include "bdis_stereo/matcher.hpp"
#include "edge_distance_cue.hpp"

namespace {

using bdis::kNoDisparity;
using bdis::detail::EdgeDistanceCue;

constexpr float kJump = 2.f;      // level px between neighbours
constexpr float kHalving = 16.f;  // level px from the nearest jump

/// The factor of a pixel whose 2 x 2 block is `blocks` blocks (city-block)
/// from the nearest block at a jump.
float factor(int blocks) {
  const float distance = 2.f * static_cast<float>(blocks) + 0.5f;
  return distance / (distance + kHalving);
}

TEST(EdgeDistanceCue, FallsTowardsADepthStep) {
  // A step of 4 px between columns 39 and 40: blocks 19 and 20 hold it.
  cv::Mat1f d(64, 96, 10.f), c(64, 96, 0.8f);
  d(cv::Rect(40, 0, 56, 64)).setTo(14.f);
  EdgeDistanceCue cue;
  cue.apply(d, kJump, kHalving, c);
  for (int y : {0, 31, 63}) {
    for (int x = 0; x < d.cols; ++x) {
      const int blocks = std::min(std::abs(x / 2 - 19), std::abs(x / 2 - 20));
      ASSERT_NEAR(c(y, x), 0.8f * factor(blocks), 1e-6f) << x << "," << y;
    }
  }
  // At the step the confidence falls to 3 % of what it was; 20 px from it, to a half.
  EXPECT_LT(c(10, 39), 0.8f * 0.031f);
  EXPECT_NEAR(c(10, 60), 0.8f * factor(10), 1e-6f);
  EXPECT_GT(c(10, 60), 0.8f * 0.55f);
}

TEST(EdgeDistanceCue, SlantsAndHolesAreNoJumps) {
  // 0.5 px per px along x, 1.5 along y: below the jump both ways. A hole
  // column separates surfaces 20 px apart, and a hole block sits inside.
  cv::Mat1f d(50, 70), c(50, 70, 1.f);
  for (int y = 0; y < d.rows; ++y) {
    for (int x = 0; x < d.cols; ++x) d(y, x) = 5.f + 0.5f * x + 1.5f * y + (x > 35 ? 20.f : 0.f);
  }
  d.col(35).setTo(kNoDisparity);
  d(cv::Rect(10, 10, 6, 6)).setTo(kNoDisparity);
  EdgeDistanceCue cue;
  cue.apply(d, kJump, kHalving, c);
  double lowest = 1.0;
  for (int y = 0; y < d.rows; ++y) {
    for (int x = 0; x < d.cols; ++x) lowest = std::min(lowest, static_cast<double>(c(y, x)));
  }
  EXPECT_GT(lowest, 1.0 - 1e-4);
}

TEST(EdgeDistanceCue, MatchesABruteForceDistanceOnRandomMaps) {
  cv::RNG rng(11);
  for (const cv::Size size : {cv::Size(33, 21), cv::Size(40, 30), cv::Size(1, 9), cv::Size(17, 1)}) {
    cv::Mat1f d(size), c(size);
    for (int y = 0; y < d.rows; ++y) {
      for (int x = 0; x < d.cols; ++x) {
        const float u = rng.uniform(0.f, 1.f);
        d(y, x) = u < 0.2f ? kNoDisparity : u < 0.25f ? 30.f : 10.f + rng.uniform(-1.f, 1.f);
        c(y, x) = rng.uniform(0.f, 1.f);
      }
    }
    const cv::Mat1f before = c.clone();
    EdgeDistanceCue cue;
    cue.apply(d, kJump, kHalving, c);
    // The blocks with a pixel that jumps to a 4-neighbour, then the nearest one by brute force.
    auto jumps = [&](int y, int x, int yy, int xx) {
      if (yy < 0 || xx < 0 || yy >= d.rows || xx >= d.cols) return false;
      return d(y, x) >= 0.f && d(yy, xx) >= 0.f && std::fabs(d(y, x) - d(yy, xx)) > kJump;
    };
    const int bw = (d.cols + 1) / 2, bh = (d.rows + 1) / 2;
    cv::Mat1b marked(bh, bw, uchar(0));
    for (int y = 0; y < d.rows; ++y) {
      for (int x = 0; x < d.cols; ++x) {
        if (jumps(y, x, y, x - 1) || jumps(y, x, y, x + 1) || jumps(y, x, y - 1, x) || jumps(y, x, y + 1, x)) {
          marked(y / 2, x / 2) = 1;
        }
      }
    }
    for (int y = 0; y < d.rows; ++y) {
      for (int x = 0; x < d.cols; ++x) {
        int nearest = 1 << 20;
        for (int by = 0; by < bh; ++by) {
          for (int bx = 0; bx < bw; ++bx) {
            if (marked(by, bx)) nearest = std::min(nearest, std::abs(by - y / 2) + std::abs(bx - x / 2));
          }
        }
        const float expected = nearest == 1 << 20 ? before(y, x) : before(y, x) * factor(nearest);
        ASSERT_NEAR(c(y, x), expected, 1e-5f) << size << " at " << x << "," << y;
      }
    }
  }
}

TEST(EdgeDistanceCue, KeepsItsBuffersAcrossSizes) {
  // A larger frame after a smaller one and back: the same result as a fresh cue.
  cv::Mat1f small(20, 30, 5.f), large(40, 50, 5.f);
  small(cv::Rect(10, 0, 20, 20)).setTo(9.f);
  large(cv::Rect(0, 20, 50, 20)).setTo(1.f);
  EdgeDistanceCue reused, fresh;
  cv::Mat1f c1(small.size(), 1.f), c2(large.size(), 1.f), c3(small.size(), 1.f), c4(small.size(), 1.f);
  reused.apply(small, kJump, kHalving, c1);
  reused.apply(large, kJump, kHalving, c2);
  reused.apply(small, kJump, kHalving, c3);
  fresh.apply(small, kJump, kHalving, c4);
  EXPECT_EQ(cv::norm(c3, c4, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(c1, c4, cv::NORM_INF), 0.0);
  EXPECT_LT(c2(20, 25), 0.05f);
}

}  // namespace
