// The blurred step cue (blurred_step_cue.hpp) on hand-made disparity maps,
// with the slopes and jump distances of the slant and edge distance cues: a
// step blurred into a ramp between flat sides, a uniform slant, a sharp
// jump, surfaces on both sides of a hole; and random maps against a
// brute-force reference of the same definition.
#include <algorithm>
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "bdis_stereo/matcher.hpp"
#include "blurred_step_cue.hpp"
#include "edge_distance_cue.hpp"
#include "slant_cue.hpp"

namespace {

using bdis::kNoDisparity;
using bdis::detail::BlurredStepCue;
using bdis::detail::EdgeDistanceCue;
using bdis::detail::SlantCue;

constexpr int kPatch = 8;         // level px: rb = 2 blocks
constexpr float kRatio = 2.f;     // the slope ratio
constexpr float kHalving = 1.f;   // level px of excess slope across a patch (2 px at level 1)
constexpr float kJump = 1.f;      // level px between neighbours: a jump for the edge cue
constexpr float kOff = 1e6f;      // a halving no slant cue term reaches here

/// The slant and edge distance cues run on `d`, for their block maps.
struct BlockMaps {
  SlantCue slant;
  EdgeDistanceCue edge;
  explicit BlockMaps(const cv::Mat1f& d, int patch = kPatch) {
    cv::Mat1f unused(d.size(), 1.f);
    slant.apply(d, cv::Mat1f(d.size(), 0.f), patch, kOff, kOff, kOff, kOff, unused);
    edge.apply(d, kJump, 2.f * static_cast<float>(patch), unused);
  }
};

/// The blurred step cue on `d` from `maps`, on a confidence of 1; returns that confidence.
cv::Mat1f applyCue(const cv::Mat1f& d, const BlockMaps& maps, BlurredStepCue& cue, int patch = kPatch) {
  cv::Mat1f c(d.size(), 1.f);
  cue.apply(d, maps.slant.blockSlopesSquared(), maps.edge.blockDistances(), patch, kRatio, kHalving, c);
  return c;
}

cv::Mat1f applyCue(const cv::Mat1f& d, BlurredStepCue& cue) { return applyCue(d, BlockMaps(d), cue); }

/// A map constant along y whose columns follow `profile(x)`.
template <class Profile>
cv::Mat1f columns(int w, int h, Profile profile) {
  cv::Mat1f d(h, w);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) d(y, x) = profile(x);
  }
  return d;
}

/// The least confidence over the columns [x0, x1) of row y.
float lowestIn(const cv::Mat1f& c, int y, int x0, int x1) {
  float lowest = 1.f;
  for (int x = x0; x < x1; ++x) lowest = std::min(lowest, c(y, x));
  return lowest;
}

/// The highest confidence over the columns [x0, x1) of row y.
float highestIn(const cv::Mat1f& c, int y, int x0, int x1) {
  float highest = 0.f;
  for (int x = x0; x < x1; ++x) highest = std::max(highest, c(y, x));
  return highest;
}

TEST(BlurredStepCue, LowersARampBetweenFlatSides) {
  // A 5 px step blurred over 12 px (columns 40-51), flat on both sides: no
  // neighbours jump by more than 1 px, so the edge cue sees nothing.
  const cv::Mat1f d = columns(96, 48, [](int x) {
    return 10.f + 5.f * std::clamp(static_cast<float>(x - 40) / 12.f, 0.f, 1.f);
  });
  BlurredStepCue cue;
  const cv::Mat1f c = applyCue(d, cue);
  // On the ramp, most where its ends meet the flat sides: the slope across
  // a patch there is about 3 px, against the flat sides' none.
  const float on_ramp = lowestIn(c, 24, 40, 52);
  EXPECT_GT(on_ramp, 0.05f);
  EXPECT_LT(on_ramp, 0.2f);
  // Its middle, 6 px from the flat sides' blocks, less: 0.41.
  EXPECT_LT(highestIn(c, 24, 40, 52), 0.45f);
  // Far out on the flat sides: untouched.
  EXPECT_EQ(lowestIn(c, 24, 0, 20), 1.f);
  EXPECT_EQ(lowestIn(c, 24, 76, 96), 1.f);
}

TEST(BlurredStepCue, KeepsAUniformSlant) {
  // Steeper than the ramp's slope (0.5 px per px), everywhere alike: the
  // flattest slope nearby is as steep, so there is no excess.
  const cv::Mat1f d = columns(96, 48, [](int x) { return 10.f + 0.5f * static_cast<float>(x); });
  BlurredStepCue cue;
  const cv::Mat1f c = applyCue(d, cue);
  // One-sided slopes at the map's edge halve the box there: only inside it.
  EXPECT_EQ(lowestIn(c, 24, 12, 84), 1.f);
}

TEST(BlurredStepCue, LeavesASharpJumpToTheEdgeCue) {
  // A 5 px jump at column 48: the box means make it a ramp too, but the
  // blocks beside it are at a jump, where the edge cue already lowers them.
  const cv::Mat1f d = columns(96, 48, [](int x) { return x < 48 ? 10.f : 15.f; });
  BlurredStepCue cue;
  const cv::Mat1f c = applyCue(d, cue);
  EXPECT_GT(c(24, 47), 0.9f);
  EXPECT_GT(c(24, 48), 0.9f);
  // A patch side out from it the gate opens, and the ramp the boxes read is
  // lowered less than a blurred step's.
  EXPECT_GT(lowestIn(c, 24, 0, 96), 0.3f);
}

TEST(BlurredStepCue, KeepsSurfacesAcrossAHole) {
  // An instrument 15 px nearer than the tissue, a 6 px hole between them
  // (the left-right check's): the box means across the hole mix the two
  // surfaces, but slopes read near a hole do not count.
  cv::Mat1f d = columns(96, 48, [](int x) { return x < 45 ? 10.f : 25.f; });
  d.colRange(45, 51).setTo(kNoDisparity);
  BlurredStepCue cue;
  const cv::Mat1f c = applyCue(d, cue);
  EXPECT_EQ(lowestIn(c, 24, 0, 96), 1.f);
}

TEST(BlurredStepCue, FlatMapKeepsItsConfidence) {
  const cv::Mat1f d(40, 50, 12.f);
  BlurredStepCue cue;
  EXPECT_EQ(cv::countNonZero(applyCue(d, cue) != 1.f), 0);
}

/// The cue's definition pixel by pixel, from the same block maps, for patches
/// of `patch` px (rb = patch / 4 rounded half up, at least 1).
cv::Mat1f bruteForce(const cv::Mat1f& d, const cv::Mat1f& slopes_sq, const cv::Mat1f& edge_blocks, int patch) {
  const int bw = slopes_sq.cols, bh = slopes_sq.rows, rb = std::max(1, (patch / 2 + 1) / 2);
  const float p = static_cast<float>(patch);
  auto hole = [&](int bx, int by) {
    for (int y = 2 * by; y < std::min(2 * by + 2, d.rows); ++y) {
      for (int x = 2 * bx; x < std::min(2 * bx + 2, d.cols); ++x) {
        if (d(y, x) < 0.f) return true;
      }
    }
    return false;
  };
  auto counted = [&](int bx, int by) {
    for (int y = std::max(0, by - rb); y <= std::min(bh - 1, by + rb); ++y) {
      for (int x = std::max(0, bx - rb); x <= std::min(bw - 1, bx + rb); ++x) {
        if (hole(x, y)) return false;
      }
    }
    return true;
  };
  cv::Mat1f c(d.size(), 1.f);
  for (int by = 0; by < bh; ++by) {
    for (int bx = 0; bx < bw; ++bx) {
      float steepest = 0.f, flattest = std::numeric_limits<float>::infinity();
      for (int y = std::max(0, by - 2 * rb); y <= std::min(bh - 1, by + 2 * rb); ++y) {
        for (int x = std::max(0, bx - 2 * rb); x <= std::min(bw - 1, bx + 2 * rb); ++x) {
          if (!counted(x, y)) continue;
          const float s = std::sqrt(slopes_sq(y, x)) * p;
          flattest = std::min(flattest, s);
          if (std::abs(x - bx) <= rb && std::abs(y - by) <= rb) steepest = std::max(steepest, s);
        }
      }
      const float excess = std::max(0.f, steepest - kRatio * flattest);
      const float gate = std::min(1.f, (2.f * edge_blocks(by, bx) + 0.5f) / (2.f * p));
      const float e = excess * gate / kHalving;
      for (int y = 2 * by; y < std::min(2 * by + 2, d.rows); ++y) {
        for (int x = 2 * bx; x < std::min(2 * bx + 2, d.cols); ++x) {
          if (d(y, x) >= 0.f) c(y, x) = 1.f / (1.f + e * e);
        }
      }
    }
  }
  return c;
}

TEST(BlurredStepCue, MatchesABruteForceReferenceOnRandomMaps) {
  cv::RNG rng(5);
  BlurredStepCue cue;  // one object for all: buffers reused across sizes
  // Patches of 8 px take the kernels of the box sides known when compiling
  // (5 and 9 blocks); 4 and 12 px, sides 3 / 5 and 7 / 13, the general ones.
  for (const int patch : {8, 4, 12}) {
    for (const cv::Size size : {cv::Size(61, 37), cv::Size(40, 30), cv::Size(9, 33), cv::Size(3, 3)}) {
      // Smooth patches of slope with steps, and a few holes: enough that the
      // hole rule leaves some slopes out, few enough that it counts others.
      cv::Mat1f d(size);
      for (int y = 0; y < d.rows; ++y) {
        for (int x = 0; x < d.cols; ++x) {
          const float u = rng.uniform(0.f, 1.f);
          d(y, x) =
              u < 0.004f ? kNoDisparity : 10.f + 0.3f * static_cast<float>((x / 7) % 3) * x + (y > 20 ? 3.f : 0.f);
        }
      }
      const BlockMaps maps(d, patch);
      const cv::Mat1f c = applyCue(d, maps, cue, patch);
      const cv::Mat1f want = bruteForce(d, maps.slant.blockSlopesSquared(), maps.edge.blockDistances(), patch);
      float worst = 0.f;
      int lowered = 0;
      for (int y = 0; y < d.rows; ++y) {
        for (int x = 0; x < d.cols; ++x) {
          worst = std::max(worst, std::abs(c(y, x) - want(y, x)));
          lowered += want(y, x) < 0.99f;
        }
      }
      EXPECT_LT(worst, 1e-5f) << size << ", patch " << patch;
      if (size.area() > 1000) {
        EXPECT_GT(lowered, 0) << size << ", patch " << patch;  // the maps do exercise it
      }
    }
  }
}

}  // namespace
