// The slant cue (slant_cue.hpp) on hand-made disparity maps of known slope
// and gradient maps of known texture: uniform, striped, and one edge.
#include <gtest/gtest.h>

#include <cmath>

#include "bdis_stereo/matcher.hpp"
#include "slant_cue.hpp"

namespace {

using bdis::kNoDisparity;
using bdis::detail::SlantCue;

constexpr int kPatch = 8;        // level px; the box: 5 x 5 blocks of 2 x 2 px, 4-5 px to each side
constexpr float kHalving = 1.f;  // level px of disparity across a patch
constexpr float kMisfitHalving = 4.f;  // grey levels
constexpr float kBendHalving = 1.f;    // level px of bend
constexpr float kBendOff = 1e6f;       // a halving no bend here reaches: the slant and misfit alone
constexpr float kLoneEdgeOff = 1e6f;   // nor a lone edge

/// The cue on an untextured image (gradient 0): the slant alone.
void applySlant(SlantCue& cue, const cv::Mat1f& disparity, cv::Mat1f& confidence) {
  cue.apply(disparity, cv::Mat1f(disparity.size(), 0.f), kPatch, kHalving, kMisfitHalving, kBendOff, kLoneEdgeOff, confidence);
}

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
  SlantCue cue;
  applySlant(cue, d, c);
  EXPECT_EQ(cv::countNonZero(c != 1.f), 0);
}

TEST(SlantCue, InteriorOfAPlaneGetsTheFactorOfItsSlope) {
  SlantCue cue;  // one object for all: buffers reused across sizes and slopes
  for (const auto& [gx, gy] : {std::pair<float, float>{0.25f, 0.f}, {0.f, -0.25f}, {0.1f, 0.2f}, {0.05f, 0.f}}) {
    cv::Mat1f d, c;
    plane(64, 48, gx, gy, d, c);
    applySlant(cue, d, c);
    const float want = expectedFactor(std::hypot(gx, gy));
    // Pixels whose boxes and neighbours' boxes lie inside the map: 2 box radii from the border.
    for (int y = 8; y < 40; ++y) {
      for (int x = 8; x < 56; ++x) {
        ASSERT_NEAR(c(y, x), want, 1e-4f) << "gx " << gx << " gy " << gy << " at " << x << "," << y;
      }
    }
  }
}

TEST(SlantCue, APlaneHasNoBend) {
  cv::Mat1f d, c;
  plane(64, 48, 0.1f, 0.2f, d, c);
  SlantCue cue;
  cue.apply(d, cv::Mat1f(d.size(), 0.f), kPatch, kHalving, kMisfitHalving, kBendHalving, kLoneEdgeOff, c);
  const float want = expectedFactor(std::hypot(0.1f, 0.2f));
  for (int y = 8; y < 40; ++y) {
    for (int x = 8; x < 56; ++x) ASSERT_NEAR(c(y, x), want, 1e-4f) << x << "," << y;
  }
}

TEST(SlantCue, ABentSurfaceGetsTheFactorOfItsBend) {
  // d = 30 + a (x - 32.5)^2 (a trough along y) and its ridge: the box means
  // (of 2 x 2 blocks, 10 px wide) are the curve at the box's centre plus a
  // constant, so their Laplacian 4 px to each side is 2 a 4^2 = 32 a
  // everywhere, and the block of columns 32 and 33, centred at 32.5, has
  // slope 0: the bend's factor alone.
  SlantCue cue;
  for (float a : {1.f / 64.f, 1.f / 32.f, -1.f / 32.f}) {
    cv::Mat1f d(48, 64), c(48, 64, 1.f);
    for (int x = 0; x < 64; ++x) d.col(x).setTo(30.f + a * (static_cast<float>(x) - 32.5f) * (static_cast<float>(x) - 32.5f));
    cue.apply(d, cv::Mat1f(d.size(), 0.f), kPatch, kHalving, kMisfitHalving, kBendHalving, kLoneEdgeOff, c);
    const float bend = 32.f * a / kBendHalving;
    for (int y = 8; y < 40; ++y) {
      for (int x : {32, 33}) ASSERT_NEAR(c(y, x), 1.f / (1.f + bend * bend), 1e-4f) << "a " << a << " at " << x << "," << y;
    }
  }
}

TEST(SlantCue, StrongerSlopeLowersTheConfidenceMore) {
  SlantCue cue;
  float previous = 1.f;
  for (float g : {0.02f, 0.06f, 0.12f, 0.25f, 0.5f}) {
    cv::Mat1f d, c;
    plane(40, 40, g, 0.f, d, c);
    applySlant(cue, d, c);
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
  SlantCue cue;
  applySlant(cue, d, c);
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
  SlantCue cue;
  applySlant(cue, d, c);
  EXPECT_LT(c(20, 31), 0.05f);
  EXPECT_LT(c(20, 32), 0.05f);
  EXPECT_EQ(c(20, 10), 1.f);  // more than two box radii away
  EXPECT_EQ(c(20, 54), 1.f);
}

TEST(SlantCue, EmptyMapAndMapsSmallerThanABox) {
  SlantCue cue;
  cv::Mat1f d(5, 3, kNoDisparity), c(5, 3, 0.f);
  cue.apply(d, cv::Mat1f(5, 3, 50.f), kPatch, kHalving, kMisfitHalving, kBendOff, kLoneEdgeOff, c);
  EXPECT_EQ(cv::countNonZero(c), 0);
  cv::Mat1f d2, c2;
  plane(3, 5, 0.5f, 0.f, d2, c2);
  applySlant(cue, d2, c2);
  for (float v : c2) {
    EXPECT_TRUE(std::isfinite(v));
    EXPECT_GT(v, 0.f);
    EXPECT_LE(v, 1.f);
  }
}

/// The misfit factor of a slope of magnitude s on texture of gradient RMS g.
float expectedMisfitFactor(float s, float g) {
  const float misfit = s * static_cast<float>(kPatch) * g;  // grey levels at the patch's rim
  return 1.f / (1.f + (misfit / kMisfitHalving) * (misfit / kMisfitHalving));
}

TEST(SlantCue, TextureOnAFrontoParallelSurfaceKeepsItsConfidence) {
  cv::Mat1f d, c;
  plane(64, 48, 0.f, 0.f, d, c);
  SlantCue().apply(d, cv::Mat1f(48, 64, 30.f), kPatch, kHalving, kMisfitHalving, kBendOff, kLoneEdgeOff, c);
  EXPECT_EQ(cv::countNonZero(c != 1.f), 0);
}

TEST(SlantCue, TexturedSlantGetsTheFactorOfItsMisfit) {
  SlantCue cue;
  for (const auto& [slope, g] : {std::pair<float, float>{0.05f, 2.f}, {0.05f, 10.f}, {0.1f, 4.f}, {0.02f, 20.f}}) {
    cv::Mat1f d, c;
    plane(64, 48, 0.f, slope, d, c);
    cv::Mat1f gradient(48, 64, g);
    cue.apply(d, gradient, kPatch, kHalving, kMisfitHalving, kBendOff, kLoneEdgeOff, c);
    const float want = expectedFactor(slope) * expectedMisfitFactor(slope, g);
    for (int y = 8; y < 40; ++y) {
      for (int x = 8; x < 56; ++x) {
        ASSERT_NEAR(c(y, x), want, 1e-4f) << "slope " << slope << " gradient " << g << " at " << x << "," << y;
      }
    }
  }
  // 0.05 px per px over an 8 px patch on a gradient of 10 grey levels per px
  // misfits by 4 grey levels at the rim: the misfit alone halves the confidence.
  EXPECT_NEAR(expectedMisfitFactor(0.05f, 10.f), 0.5f, 1e-6f);
}

TEST(SlantCue, BoxesCutByTheSidesAverageTheTextureOverTheirOwnPixels) {
  // A plane slanted along y, uniform texture: along every column, also in
  // the boxes the left and right sides cut (and an odd width's last block of
  // one column), the slope read is the plane's and the texture's RMS is g, so
  // every pixel of the rows away from the top and bottom gets the same factor.
  const float slope = 0.05f, g = 6.f;
  SlantCue cue;
  for (const int w : {37, 38}) {
    cv::Mat1f d, c;
    plane(w, 30, 0.f, slope, d, c);
    cue.apply(d, cv::Mat1f(30, w, g), kPatch, kHalving, kMisfitHalving, kBendOff, kLoneEdgeOff, c);
    const float want = expectedFactor(slope) * expectedMisfitFactor(slope, g);
    for (int y = 10; y < 20; ++y) {
      for (int x = 0; x < w; ++x) ASSERT_NEAR(c(y, x), want, 1e-4f) << "width " << w << " at " << x << "," << y;
    }
  }
}

TEST(SlantCue, TheMisfitTakesTheGradientsRmsNotItsMean) {
  // Stripes whose gradient alternates +g and -g (mean 0) misfit as much as a
  // ramp of gradient g: a shifted patch is off by g per px of shift either way.
  const float slope = 0.08f, g = 8.f;
  cv::Mat1f d, ramp_confidence, stripe_confidence;
  plane(64, 48, slope, 0.f, d, ramp_confidence);
  stripe_confidence = ramp_confidence.clone();
  cv::Mat1f stripes(48, 64);
  for (int y = 0; y < 48; ++y) {
    for (int x = 0; x < 64; ++x) stripes(y, x) = (x / 2) % 2 == 0 ? g : -g;
  }
  SlantCue cue;
  cue.apply(d, cv::Mat1f(48, 64, g), kPatch, kHalving, kMisfitHalving, kBendOff, kLoneEdgeOff, ramp_confidence);
  cue.apply(d, stripes, kPatch, kHalving, kMisfitHalving, kBendOff, kLoneEdgeOff, stripe_confidence);
  EXPECT_LT(ramp_confidence(24, 32), 0.5f * expectedFactor(slope));
  EXPECT_NEAR(stripe_confidence(24, 32), ramp_confidence(24, 32), 1e-4f);
}

TEST(SlantCue, StrongerTextureOnTheSameSlantLowersTheConfidenceMore) {
  SlantCue cue;
  float previous = 1.f;
  for (float g : {0.f, 1.f, 3.f, 8.f, 20.f}) {
    cv::Mat1f d, c;
    plane(40, 40, 0.06f, 0.f, d, c);
    cue.apply(d, cv::Mat1f(40, 40, g), kPatch, kHalving, kMisfitHalving, kBendOff, kLoneEdgeOff, c);
    if (g > 0.f) {
      EXPECT_LT(c(20, 20), previous) << "gradient " << g;
    }
    previous = c(20, 20);
  }
}

/// A fronto-parallel plane on a texture of gradient `noise` everywhere plus
/// one vertical edge: `edge` grey levels per px in columns 31 and 32.
void loneEdge(float noise, float edge, cv::Mat1f& d, cv::Mat1f& c, cv::Mat1f& gradient) {
  plane(64, 48, 0.f, 0.f, d, c);
  gradient.create(48, 64);
  for (int y = 0; y < 48; ++y) {
    for (int x = 0; x < 64; ++x) gradient(y, x) = ((x + y) % 2 == 0 ? noise : -noise) + (x == 31 || x == 32 ? edge : 0.f);
  }
}

TEST(SlantCue, ALoneEdgeGetsTheFactorOfItsPeakedness) {
  // Beside the edge the box (10 columns) holds it in 2 of its columns:
  // mean |g| = 0.2 e, mean g^2 = 0.2 e^2, so the peakedness is 1 / 0.2 = 5,
  // pi / 2 over a Gaussian's by 3.43. Four blocks from it and further, the
  // box sees no edge and keeps the plane's confidence (1).
  const float halving = 2.f;
  cv::Mat1f d, c, gradient;
  loneEdge(0.f, 20.f, d, c, gradient);
  SlantCue().apply(d, gradient, kPatch, kHalving, kMisfitHalving, kBendOff, halving, c);
  const float excess = 5.f - 1.5707963f;
  const float want = 1.f / (1.f + (excess / halving) * (excess / halving));
  for (int y = 8; y < 40; ++y) {
    for (int x = 28; x < 36; ++x) ASSERT_NEAR(c(y, x), want, 1e-4f) << x << "," << y;
    for (int x : {0, 20, 42, 63}) ASSERT_EQ(c(y, x), 1.f) << x << "," << y;
  }
}

TEST(SlantCue, TextureAroundAnEdgeTakesTheLoneEdgeFactorAway) {
  // The same edge on ever stronger texture: the edge is less and less of
  // what a patch sees, so the factor beside it rises towards 1. Uniform
  // texture alone (the alternating +-g) is less peaked than a Gaussian's.
  // With texture n beside it the box's mean |g| is 0.8 n + 4 and its mean
  // g^2 n^2 + 80: from n = 6 on, no more peaked than a Gaussian's.
  float previous = 0.f;
  for (float noise : {0.f, 1.f, 2.f, 4.f, 6.f}) {
    cv::Mat1f d, c, gradient;
    loneEdge(noise, 20.f, d, c, gradient);
    SlantCue().apply(d, gradient, kPatch, kHalving, kMisfitHalving, kBendOff, 1.f, c);
    if (noise < 6.f) {
      EXPECT_GT(c(24, 32), previous) << "texture " << noise;
      EXPECT_LT(c(24, 32), 1.f) << "texture " << noise;
    } else {
      EXPECT_EQ(c(24, 32), 1.f);
    }
    previous = c(24, 32);
  }
  cv::Mat1f d, c, gradient;
  loneEdge(4.f, 0.f, d, c, gradient);
  SlantCue().apply(d, gradient, kPatch, kHalving, kMisfitHalving, kBendOff, 1.f, c);
  EXPECT_EQ(cv::countNonZero(c != 1.f), 0);
}

TEST(SlantCue, AFlatBoxHasNoLoneEdge) {
  // Gradients far below a grey level (the 8-bit image's step) are no edge,
  // however they are distributed.
  cv::Mat1f d, c, gradient;
  loneEdge(0.f, 0.04f, d, c, gradient);
  SlantCue().apply(d, gradient, kPatch, kHalving, kMisfitHalving, kBendOff, 1.f, c);
  EXPECT_EQ(cv::countNonZero(c != 1.f), 0);
}

}  // namespace
