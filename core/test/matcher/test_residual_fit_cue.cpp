// The residual fit cues (residual_fit_cue.hpp) on rendered planes: the
// estimates given by hand, right or flattened, at the finest level (level 0
// of a two-level pyramid here), the fit on level 1.
#include <gtest/gtest.h>

#include <cstdio>

#include <opencv2/core.hpp>

#include "bdis_stereo/matcher.hpp"
#include "pyramid.hpp"
#include "residual_fit_cue.hpp"
#include "test_images.hpp"

namespace {

using bdis::kNoDisparity;
using bdis::detail::ResidualFitCue;
using bdis::detail::StereoPyramid;

constexpr int kW = 256, kH = 192;
constexpr int kPatch = 8;
constexpr float kHalving = 0.5f;       // finest-level px of disparity change across a patch
constexpr float kErrorHalving = 0.5f;  // finest-level px of a patch's standard error
constexpr double kD0 = 12.0;      // disparity at x = 0

/// A textured plane with disparity kD0 + slope x, the right view's grey
/// levels offset by `offset`: right column xr shows the scene point whose
/// left column x satisfies x - d(x) = xr.
/// `amplitude` sets the texture's contrast (about 2.5 standard deviations),
/// `noise` the standard deviation of Gaussian noise added to both views.
StereoPyramid renderPlane(double slope, double offset, bool textured = true, double amplitude = 60.0,
                          double noise = 0.0) {
  const bdis_test::Texture texture(7, 128.0, amplitude, 6.0, 30.0);
  cv::RNG rng(11);
  cv::Mat left(kH, kW, CV_8UC1), right(kH, kW, CV_8UC1);
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) {
      const double xl = (x + kD0) / (1.0 - slope);
      left.at<uchar>(y, x) = bdis_test::toByte((textured ? texture(x, y) : 128.0) + rng.gaussian(noise));
      right.at<uchar>(y, x) = bdis_test::toByte((textured ? texture(xl, y) : 128.0) + offset + rng.gaussian(noise));
    }
  }
  StereoPyramid pyramid;
  pyramid.build(left, right, 2, 0);
  return pyramid;
}

/// Estimates of the plane kD0 + slope x that miss `missing` of its slope:
/// right at column kAgree, off by `missing` px per px away from it.
constexpr int kAgree = 140;
cv::Mat1f planeEstimates(double slope, double missing = 0.0) {
  cv::Mat1f d(kH, kW);
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) d(y, x) = static_cast<float>(kD0 + slope * x - missing * (x - kAgree));
  }
  return d;
}

/// The confidence factors of the cue (it starts from 1) over the interior,
/// away from the borders, where the right view holds every match.
struct Factors {
  float min = 1.f, max = 0.f;
  double mean = 0.0;
};
Factors interiorFactors(const cv::Mat1f& confidence, int x_begin = 64, int x_end = kW - 40) {
  Factors f;
  int n = 0;
  for (int y = 40; y < kH - 40; ++y) {
    for (int x = x_begin; x < x_end; ++x) {
      const float c = confidence(y, x);
      f.min = std::min(f.min, c);
      f.max = std::max(f.max, c);
      f.mean += c;
      ++n;
    }
  }
  f.mean /= n;
  return f;
}

Factors runCue(const StereoPyramid& pyramid, const cv::Mat1f& estimates, int x_begin = 64, int x_end = kW - 40) {
  cv::Mat1f confidence(estimates.size(), 1.f);
  ResidualFitCue cue;
  cue.apply(estimates, pyramid.level(1), kPatch, kHalving, kErrorHalving, confidence);
  const Factors f = interiorFactors(confidence, x_begin, x_end);
  std::printf("[measured] factors min %.3f mean %.3f max %.3f\n", f.min, f.mean, f.max);
  return f;
}

TEST(ResidualFitCue, RightEstimatesOfAnUprightOrSlantedPlaneKeepTheirConfidence) {
  for (const double slope : {0.0, 0.15, -0.1}) {
    const Factors f = runCue(renderPlane(slope, 0.0), planeEstimates(slope));
    EXPECT_GT(f.min, 0.85f) << "slope " << slope;
    EXPECT_GT(f.mean, 0.95) << "slope " << slope;
  }
}

TEST(ResidualFitCue, AnOffsetBetweenTheViewsIsNotASlant) {
  const Factors f = runCue(renderPlane(0.1, 12.0), planeEstimates(0.1));
  EXPECT_GT(f.min, 0.9f);
  EXPECT_GT(f.mean, 0.95);
}

TEST(ResidualFitCue, FlattenedEstimatesOfASlantedPlaneLoseConfidence) {
  // The fronto-parallel bias: estimates flatter than the surface, right
  // where they cross it and off by a growing shift away from there (within
  // 1-2 px over the columns scored, where the residual is still a shift of
  // the texture). A missed slope m changes the disparity by 8 m across a
  // patch: at m = 0.05 and 0.1 the slant factor is 1 / (1 + (0.4 / 0.5)^2)
  // = 0.61 and 1 / (1 + (0.8 / 0.5)^2) = 0.28; what the fit leaves of the
  // misfit lowers the precision factor a little more.
  const StereoPyramid plane = renderPlane(0.15, 0.0);
  const Factors right = runCue(plane, planeEstimates(0.15), kAgree - 16, kAgree + 16);
  const Factors some = runCue(plane, planeEstimates(0.15, 0.05), kAgree - 16, kAgree + 16);
  const Factors more = runCue(plane, planeEstimates(0.15, 0.1), kAgree - 16, kAgree + 16);
  EXPECT_GT(right.min, 0.9f);
  EXPECT_GT(some.mean, 0.4);
  EXPECT_LT(some.mean, 0.61);
  EXPECT_GT(more.mean, 0.12);
  EXPECT_LT(more.mean, 0.28);
  EXPECT_LT(more.max, 0.4f);
  // Estimates steeper than the surface are as wrong.
  const Factors steeper = runCue(plane, planeEstimates(0.15, -0.1), kAgree - 16, kAgree + 16);
  EXPECT_NEAR(steeper.mean, more.mean, 0.05);
}

TEST(ResidualFitCue, WeakTextureUnderNoiseIsAGuess) {
  // Right estimates everywhere; what changes is how well the texture pins
  // them against the noise. Strong texture (grey levels 128 +- 60) under a
  // noise of 3 grey levels in each view: a patch's standard error is small.
  // Texture of +- 4 under the same noise: it is several times the 0.5 px
  // halving, the estimate a guess the posterior's assumed noise would not
  // call one. Without the noise the weak texture is pinned again.
  const Factors strong = runCue(renderPlane(0.1, 0.0, true, 60.0, 3.0), planeEstimates(0.1));
  const Factors weak = runCue(renderPlane(0.1, 0.0, true, 4.0, 3.0), planeEstimates(0.1));
  const Factors weak_clean = runCue(renderPlane(0.1, 0.0, true, 4.0, 0.0), planeEstimates(0.1));
  EXPECT_GT(strong.mean, 0.9);
  EXPECT_LT(weak.mean, 0.3);
  EXPECT_GT(weak_clean.mean, 2 * weak.mean);
}

TEST(ResidualFitCue, NoTextureNoSayAndNoEstimateUntouched) {
  const StereoPyramid flat_scene = renderPlane(0.0, 0.0, /*textured=*/false);
  cv::Mat1f estimates = planeEstimates(0.2);  // wrong, but nothing in the images can tell
  estimates(cv::Rect(100, 50, 30, 30)).setTo(kNoDisparity);
  const cv::Mat1f before = estimates.clone();
  cv::Mat1f confidence(estimates.size(), 0.7f);
  confidence(cv::Rect(100, 50, 30, 30)).setTo(0.f);
  ResidualFitCue cue;
  cue.apply(estimates, flat_scene.level(1), kPatch, kHalving, kErrorHalving, confidence);
  EXPECT_EQ(cv::countNonZero(confidence(cv::Rect(0, 0, kW, kH)) != 0.7f), 30 * 30);
  EXPECT_EQ(cv::countNonZero(estimates != before), 0) << "the disparity is not changed";

  // On texture, a pixel without an estimate keeps what it has too, and the
  // flattened estimates around the hole still lose theirs.
  const StereoPyramid textured = renderPlane(0.15, 0.0);
  cv::Mat1f half = planeEstimates(0.15, 0.1);
  half(cv::Rect(100, 50, 30, 30)).setTo(kNoDisparity);
  cv::Mat1f c2(half.size(), 1.f);
  c2(cv::Rect(100, 50, 30, 30)).setTo(0.f);
  cue.apply(half, textured.level(1), kPatch, kHalving, kErrorHalving, c2);
  EXPECT_EQ(cv::countNonZero(c2(cv::Rect(100, 50, 30, 30))), 0);
  EXPECT_LT(c2(65, kAgree), 0.5f);
}

TEST(ResidualFitCue, OddSizesSmallLevelsAndReusedBuffers) {
  ResidualFitCue cue;
  for (const auto& [w, h] : {std::pair<int, int>{33, 17}, {64, 48}, {97, 61}, {40, 3}, {4, 40}}) {
    const bdis_test::Texture texture(3);
    cv::Mat left(h, w, CV_8UC1), right(h, w, CV_8UC1);
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        left.at<uchar>(y, x) = bdis_test::toByte(texture(x, y));
        right.at<uchar>(y, x) = bdis_test::toByte(texture(x + 4.0, y));
      }
    }
    StereoPyramid pyramid;
    pyramid.build(left, right, 2, 0);
    cv::Mat1f d(h, w, 4.f), c(h, w, 1.f);
    cue.apply(d, pyramid.level(1), kPatch, kHalving, kErrorHalving, c);
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        ASSERT_TRUE(c(y, x) > 0.f && c(y, x) <= 1.f) << w << "x" << h << " at " << x << "," << y;
      }
    }
  }
}

}  // namespace
