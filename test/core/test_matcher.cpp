// Behaviour of bdis::Matcher on synthetic pairs with known disparity, its
// input validation and its output contract. Synthetic scenes come from
// test_images.hpp (analytic sinusoid texture, exact sub-pixel shifts).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "../../src/core/patch_kernels.hpp"
#include "bdis_stereo/matcher.hpp"
#include "test_images.hpp"

namespace {

using bdis::kNoDisparity;
using bdis::Matcher;
using bdis::MatcherParams;
using bdis::MatchResult;
using namespace bdis_test;

constexpr int kW = 320;
constexpr int kH = 240;

/// Full-resolution side of one patch at the finest searched level.
int patchAtFullRes(const MatcherParams& p) { return p.patch_size << p.finest_level; }

/// Margin that keeps every evaluated pixel two patches (at full resolution)
/// away from the image border, where fewer patches cover a pixel.
int accuracyMargin(const MatcherParams& p) { return 2 * patchAtFullRes(p); }

/// Least-squares line d = intercept + slope * t through the estimates in roi,
/// t the column (along_columns) or the row; NaNs without estimates.
std::pair<double, double> fitDisparityLine(const cv::Mat& disparity, const cv::Rect& roi,
                                           bool along_columns) {
  double n = 0, sum_t = 0, sum_d = 0, sum_tt = 0, sum_td = 0;
  for (int y = roi.y; y < roi.br().y; ++y) {
    for (int x = roi.x; x < roi.br().x; ++x) {
      const float d = disparity.at<float>(y, x);
      if (d < 0.f) continue;
      const double t = along_columns ? x : y;
      n += 1, sum_t += t, sum_d += d, sum_tt += t * t, sum_td += t * d;
    }
  }
  if (n == 0) return {std::nan(""), std::nan("")};
  const double slope = (n * sum_td - sum_t * sum_d) / (n * sum_tt - sum_t * sum_t);
  return {slope, (sum_d - slope * sum_t) / n};
}

MatchResult run(const MatcherParams& params, const cv::Mat& left, const cv::Mat& right) {
  Matcher m(params);
  MatchResult r;
  m.compute(left, right, r);
  return r;
}

void printStats(const char* what, const ErrorStats& s) {
  std::printf("[measured] %s: density %.4f, median |err| %.4f px, p95 %.4f px, max %.4f px, "
              "bias %+.4f px\n",
              what, s.density(), s.median, s.p95, s.max, s.mean_signed);
}

// Output contract of one result: sizes, types, value ranges, and that
// "no estimate" is consistent across the three outputs.
void expectValidResult(const MatchResult& r, cv::Size size, bool with_variance) {
  ASSERT_EQ(r.disparity.size(), size);
  ASSERT_EQ(r.disparity.type(), CV_32FC1);
  ASSERT_EQ(r.confidence.size(), size);
  ASSERT_EQ(r.confidence.type(), CV_32FC1);
  if (with_variance) {
    ASSERT_EQ(r.variance.size(), size);
    ASSERT_EQ(r.variance.type(), CV_32FC1);
  } else {
    ASSERT_TRUE(r.variance.empty()) << "variance must be empty when compute_variance is off";
  }
  int bad_disparity = 0, bad_confidence = 0, bad_variance = 0;
  for (int y = 0; y < size.height; ++y) {
    for (int x = 0; x < size.width; ++x) {
      const float d = r.disparity.at<float>(y, x);
      const float c = r.confidence.at<float>(y, x);
      const bool has = d >= 0.f;
      if (!has && d != kNoDisparity) ++bad_disparity;  // also catches NaN and inf
      if (has && !std::isfinite(d)) ++bad_disparity;
      if (!(c >= 0.f && c <= 1.f) || (!has && c != 0.f)) ++bad_confidence;
      if (with_variance) {
        const float v = r.variance.at<float>(y, x);
        if (has ? !(v >= 0.f && std::isfinite(v)) : !std::isnan(v)) ++bad_variance;
      }
    }
  }
  EXPECT_EQ(bad_disparity, 0) << "disparity must be >= 0 (finite) or exactly kNoDisparity";
  EXPECT_EQ(bad_confidence, 0) << "confidence must be in [0, 1] and 0 without an estimate";
  EXPECT_EQ(bad_variance, 0) << "variance must be finite >= 0 with an estimate, NaN without";
}

double density(const cv::Mat& disparity) {
  return static_cast<double>(cv::countNonZero(disparity >= 0.f)) / disparity.total();
}

// ---------------------------------------------------------------------------
// 1. Constant sub-pixel disparity.
//
// Measured with the default ("balanced") preset on this texture: median
// |error| 0.019-0.040 px and p95 0.043-0.064 px over d in {1.5, 3.25, 7.3,
// 12.6} and texture seeds 1-3. The error is a bias, not noise: its sign and
// size follow the fractional part of d / 2, it vanishes for even d (see
// EvenIntegerDisparityIsExactAtHalfResolution) and peaks at quarter pixels of
// the half-resolution level. That is the pixel-locking of bilinear
// interpolation at the finest searched level (finest_level = 1, half
// resolution), doubled by the upsampling to full resolution; a smoother
// texture (shortest wavelength 12 px instead of 6) halves it. Searching at
// full resolution (finest_level = 0) removes most of it: median < 0.01 px,
// p95 < 0.03 px.
// ---------------------------------------------------------------------------

TEST(MatcherAccuracy, ConstantSubpixelDisparityDefaultPresetMedianWithin005) {
  const MatcherParams params;  // default = balanced
  for (unsigned seed : {1u, 2u}) {
    for (double d : {3.25, 7.3, 12.6}) {
      const std::string what =
          "default preset, texture seed " + std::to_string(seed) + ", d = " + std::to_string(d);
      SCOPED_TRACE(what);
      const StereoPair pair = texturedPair(kW, kH, {d, 0.0}, seed);
      const MatchResult r = run(params, pair.left, pair.right);
      const cv::Rect roi =
          interior(kW, kH, accuracyMargin(params), static_cast<int>(std::ceil(d)));
      const ErrorStats s = errorStats(r.disparity, pair.gt, roi);
      printStats(what.c_str(), s);
      EXPECT_GE(s.density(), 0.99);
      EXPECT_LT(s.median, 0.05);
      // p95 bound above 0.05: the half-resolution pixel-locking bias, see above.
      EXPECT_LT(s.p95, 0.08);
    }
  }
}

TEST(MatcherAccuracy, ConstantSubpixelDisparityFullResolutionP95Within005) {
  // finest_level = 0 searches at full resolution; documents that the 0.05 px
  // bound on the 95th percentile needs it (the default's bias is explained
  // above).
  MatcherParams params;
  params.finest_level = 0;
  for (double d : {3.25, 7.3, 12.6}) {
    SCOPED_TRACE("d = " + std::to_string(d));
    const StereoPair pair = texturedPair(kW, kH, {d, 0.0});
    const MatchResult r = run(params, pair.left, pair.right);
    const cv::Rect roi =
        interior(kW, kH, 2 * accuracyMargin(MatcherParams{}), static_cast<int>(std::ceil(d)));
    const ErrorStats s = errorStats(r.disparity, pair.gt, roi);
    printStats(("finest_level 0, d = " + std::to_string(d)).c_str(), s);
    EXPECT_GE(s.density(), 0.99);
    EXPECT_LT(s.median, 0.02);
    EXPECT_LT(s.p95, 0.05);
  }
}

TEST(MatcherAccuracy, EvenIntegerDisparityIsExactAtHalfResolution) {
  // With the default finest_level = 1, an even disparity is a whole-pixel
  // shift at the finest level: no interpolation error, so the estimate is
  // exact up to float rounding. Confirms the diagnosis of the sub-pixel bias.
  const MatcherParams params;
  for (double d : {0.0, 6.0, 8.0}) {
    SCOPED_TRACE("d = " + std::to_string(d));
    const StereoPair pair = texturedPair(kW, kH, {d, 0.0});
    const MatchResult r = run(params, pair.left, pair.right);
    const ErrorStats s = errorStats(r.disparity, pair.gt,
                                    interior(kW, kH, accuracyMargin(params), static_cast<int>(d)));
    printStats(("default preset, d = " + std::to_string(d)).c_str(), s);
    EXPECT_GE(s.density(), 0.99);
    EXPECT_LT(s.median, 0.005);
  }
}

// ---------------------------------------------------------------------------
// 2. Slanted plane, d = a + b * x.
//
// Each patch assumes one disparity, so on a slant the right patch is
// foreshortened by (1 - b) and the patch estimate is a least-squares average
// over the patch (at the default level-1 patch of 16 full-resolution px, d
// varies by 0.32 px across it for b = 0.02). Measured (default preset):
// b = +0.02 median 0.025-0.027 px, p95 0.069-0.077 px; b = -0.02 median
// 0.019-0.021, p95 0.044-0.059; no bias (|mean signed error| < 0.005 px); the
// ranges span the library versions seen while these tests were written. The
// bounds leave about 2x margin: median < 0.06 px, p95 < 0.15 px; the fitted
// slope must match to 2 % (measured: to 0.05 %).
// ---------------------------------------------------------------------------

TEST(MatcherAccuracy, SlantedPlaneRecovered) {
  const MatcherParams params;
  const LinearDisparity planes[] = {{5.0, 0.02}, {12.0, -0.02}};
  for (const LinearDisparity& plane : planes) {
    SCOPED_TRACE("d = " + std::to_string(plane.a) + " + " + std::to_string(plane.b) + " x");
    const StereoPair pair = texturedPair(kW, kH, plane);
    const MatchResult r = run(params, pair.left, pair.right);
    const int max_d = static_cast<int>(std::ceil(std::max(plane.at(0), plane.at(kW))));
    const cv::Rect roi = interior(kW, kH, accuracyMargin(params), max_d);
    const ErrorStats s = errorStats(r.disparity, pair.gt, roi);
    printStats("slanted plane", s);
    EXPECT_GE(s.density(), 0.99);
    EXPECT_LT(s.median, 0.06);
    EXPECT_LT(s.p95, 0.15);
    EXPECT_LT(std::fabs(s.mean_signed), 0.02);

    // Least-squares line through the estimates: the slope is the plane's.
    const auto [slope, intercept] = fitDisparityLine(r.disparity, roi, /*along_columns=*/true);
    std::printf("[measured] slanted plane fit: slope %.5f (true %.5f), intercept %.4f (true %.4f)\n",
                slope, plane.b, intercept, plane.a);
    EXPECT_NEAR(slope, plane.b, 0.02 * std::fabs(plane.b));
    EXPECT_NEAR(intercept, plane.a, 0.05);
  }
}

// The same along the image rows, d = a + c * y: every patch row carries its
// own disparity, so a fused row taken from the wrong place, or a row that
// misses some of its patches' weight, shows as an error in that row (the
// fusion accumulates in a band of rows that slides down each level). Measured
// (default preset, c = +-0.1): median 0.041-0.044 px, p95 0.109-0.116 px,
// worst row median 0.080 px, slope to 0.03 %. Carrying the band's rows over
// one row off gives a worst row of 0.23 px and p95 0.19 px; dropping them, 0.38.
TEST(MatcherAccuracy, PlaneSlantedAlongTheRowsRecoveredInEveryRow) {
  const MatcherParams params;
  const Texture tex(3);
  for (const double c : {0.1, -0.1}) {
    const double a = c > 0 ? 2.0 : 26.0;
    SCOPED_TRACE("d = " + std::to_string(a) + " + " + std::to_string(c) + " y");
    const StereoPair pair = renderPair(kW, kH, tex, {a, 0.0, c});
    const MatchResult r = run(params, pair.left, pair.right);
    const int max_d = static_cast<int>(std::ceil(std::max(a, a + c * kH)));
    const cv::Rect roi = interior(kW, kH, accuracyMargin(params), max_d);
    const ErrorStats s = errorStats(r.disparity, pair.gt, roi);
    printStats("plane slanted along the rows", s);
    EXPECT_GE(s.density(), 0.99);
    EXPECT_LT(s.median, 0.06);
    EXPECT_LT(s.p95, 0.16);

    double worst_row_median = 0.0;
    for (int y = roi.y; y < roi.br().y; ++y) {
      const ErrorStats row = errorStats(r.disparity, pair.gt, cv::Rect(roi.x, y, roi.width, 1));
      EXPECT_GE(row.density(), 0.95) << "row " << y;
      worst_row_median = std::max(worst_row_median, row.median);
    }
    const double slope = fitDisparityLine(r.disparity, roi, /*along_columns=*/false).first;
    std::printf("[measured] rows slant: worst row median %.4f px, slope %.5f (true %.5f)\n",
                worst_row_median, slope, c);
    EXPECT_LT(worst_row_median, 0.12);
    EXPECT_NEAR(slope, c, 0.02 * std::fabs(c));
  }
}

// ---------------------------------------------------------------------------
// 3. Brightness offset between the cameras.
// With mean normalisation the offset cancels from every cost, so the result
// is the same as without it. Measured: identical to 1e-5 px (p95).
// Control: without mean normalisation the same offset costs about 0.5 px
// median error (measured 0.50-0.53), so the scene does exercise the offset.
// ---------------------------------------------------------------------------

TEST(MatcherRobustness, BrightnessOffsetCancelsWithMeanNormalization) {
  const MatcherParams params;
  ASSERT_TRUE(params.mean_normalization);
  const double d = 7.3;
  const StereoPair plain = texturedPair(kW, kH, {d, 0.0});
  const MatchResult r0 = run(params, plain.left, plain.right);
  const cv::Rect roi = interior(kW, kH, accuracyMargin(params), static_cast<int>(std::ceil(d)));
  for (double offset : {20.0, -20.0}) {
    SCOPED_TRACE("offset = " + std::to_string(offset));
    const StereoPair shifted = texturedPair(kW, kH, {d, 0.0}, 1, offset);
    // The texture stays inside (34, 230): no saturation at 0 or 255 hides the offset.
    double lo, hi;
    cv::minMaxLoc(shifted.right, &lo, &hi);
    ASSERT_GT(lo, 0);
    ASSERT_LT(hi, 255);
    const MatchResult r1 = run(params, shifted.left, shifted.right);
    std::vector<float> diffs;
    for (int y = roi.y; y < roi.br().y; ++y) {
      for (int x = roi.x; x < roi.br().x; ++x) {
        const float a = r0.disparity.at<float>(y, x), b = r1.disparity.at<float>(y, x);
        if (a >= 0.f && b >= 0.f) diffs.push_back(std::fabs(a - b));
      }
    }
    const ErrorStats s = errorStats(r1.disparity, shifted.gt, roi);
    std::printf("[measured] offset %+.0f: median |d_offset - d_plain| %.5f px, p95 %.5f px\n",
                offset, quantile(diffs, 0.5), quantile(diffs, 0.95));
    printStats("with offset", s);
    EXPECT_GE(s.density(), 0.99);
    EXPECT_NEAR(density(r1.disparity(roi)), density(r0.disparity(roi)), 0.01);
    EXPECT_LT(quantile(diffs, 0.5), 0.01);
    EXPECT_LT(quantile(diffs, 0.95), 0.05);
    EXPECT_LT(s.median, 0.05);
  }
}

TEST(MatcherRobustness, BrightnessOffsetHurtsWithoutMeanNormalization) {
  // Control for the test above.
  MatcherParams params;
  params.mean_normalization = false;
  const double d = 7.3;
  const StereoPair shifted = texturedPair(kW, kH, {d, 0.0}, 1, 20.0);
  const MatchResult r = run(params, shifted.left, shifted.right);
  const ErrorStats s = errorStats(
      r.disparity, shifted.gt, interior(kW, kH, accuracyMargin(params), static_cast<int>(std::ceil(d))));
  printStats("offset +20 without mean normalisation", s);
  EXPECT_GT(s.median, 0.2);
}

// ---------------------------------------------------------------------------
// 4. A flat, textureless region inside a textured image.
//
// Its patches have an (almost) flat cost: every window sample is about as
// likely as the optimum, so the patch posterior is about 1/(2n+1), chance
// level. The matcher's confidence is the covering patches' mean posterior
// above chance, (p - 1/(2n+1)) / (1 - 1/(2n+1)): 0 for a flat cost, 1 for a
// single peak. kLowConfidence = 0.1 means "within 10 % of chance", i.e. a
// posterior below 0.28 for the default n = 2: no information. (The first
// library version reported the raw posterior p as confidence; flat patches
// then came out at 0.2, and the same "no information" bound was p < 0.25.)
// Sensor noise makes local minima that pass the local-minimum test, so some
// flat pixels may keep an estimate, wrong by several px; the requirement is
// that they are never confident. Measured in the flat interior (default
// preset, current library): density 0.008, max confidence 0.047, max
// confidence of a >= 1 px error 0.039; with the raw-posterior version:
// density 0.47-0.90, median error 2-5 px, max confidence 0.215.
// The "flat interior" excludes a band one full-resolution patch wide along
// the region's border, because a patch there also sees texture and may be
// legitimately confident; see the DISABLED_ test below for that band.
// ---------------------------------------------------------------------------

constexpr double kLowConfidence = 0.1;

struct FlatScene {
  StereoPair pair;
  cv::Rect flat;
};

FlatScene flatRegionScene(double d) {
  FlatScene s;
  s.flat = cv::Rect(100, 60, 120, 120);
  const Texture tex(1);
  const cv::Rect flat = s.flat;
  auto scene = [&](double x, double y) {
    return flat.contains(cv::Point(static_cast<int>(std::floor(x)), static_cast<int>(std::floor(y))))
               ? 120.0
               : tex(x, y);
  };
  s.pair = renderPair(kW, kH, scene, {d, 0.0});
  // Independent sensor noise (sigma 0.5 grey levels) on the flat part of each image.
  cv::RNG rng(7);
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) {
      if (flat.contains(cv::Point(x, y))) s.pair.left.at<uchar>(y, x) = toByte(120 + rng.gaussian(0.5));
      if (flat.contains(cv::Point(static_cast<int>(std::floor(x + d)), y))) {
        s.pair.right.at<uchar>(y, x) = toByte(120 + rng.gaussian(0.5));
      }
    }
  }
  return s;
}

struct FlatRegionCounts {
  int pixels = 0, estimated = 0, wrong = 0, confident_wrong = 0;
  double max_conf_wrong = 0, max_conf = 0;
  std::vector<float> errors, confidences;
};

FlatRegionCounts countInRegion(const MatchResult& r, const cv::Mat& gt, const cv::Rect& roi,
                               double low_confidence) {
  FlatRegionCounts c;
  for (int y = roi.y; y < roi.br().y; ++y) {
    for (int x = roi.x; x < roi.br().x; ++x) {
      ++c.pixels;
      const float d = r.disparity.at<float>(y, x), conf = r.confidence.at<float>(y, x);
      if (d < 0.f) continue;
      ++c.estimated;
      const float e = std::fabs(d - gt.at<float>(y, x));
      c.errors.push_back(e);
      c.confidences.push_back(conf);
      c.max_conf = std::max<double>(c.max_conf, conf);
      if (e >= 1.f) {
        ++c.wrong;
        c.max_conf_wrong = std::max<double>(c.max_conf_wrong, conf);
        if (conf >= low_confidence) ++c.confident_wrong;
      }
    }
  }
  return c;
}

void printFlat(const char* what, const FlatRegionCounts& c) {
  std::printf("[measured] %s: %d px, density %.4f, >= 1 px wrong %d, median error %.3f px, "
              "median confidence %.3f, max confidence %.3f, max confidence of a wrong one %.3f\n",
              what, c.pixels, double(c.estimated) / c.pixels, c.wrong, quantile(c.errors, 0.5),
              quantile(c.confidences, 0.5), c.max_conf, c.max_conf_wrong);
}

TEST(MatcherRobustness, FlatRegionHasNoConfidentWrongEstimate) {
  const MatcherParams params;
  const double d = 7.3;
  const FlatScene scene = flatRegionScene(d);
  const MatchResult r = run(params, scene.pair.left, scene.pair.right);
  const double low = kLowConfidence;
  const int band = patchAtFullRes(params);
  const cv::Rect inner(scene.flat.x + band, scene.flat.y + band, scene.flat.width - 2 * band,
                       scene.flat.height - 2 * band);
  const FlatRegionCounts c = countInRegion(r, scene.pair.gt, inner, low);
  printFlat("flat interior", c);
  // Every pixel: no estimate, or error < 1 px, or confidence < low.
  EXPECT_EQ(c.confident_wrong, 0) << "max confidence of a >= 1 px error: " << c.max_conf_wrong;
  // And the flat interior is never confident at all.
  EXPECT_LT(c.max_conf, low);

  // The textured surroundings (one patch away from the flat region) stay
  // accurate and confident.
  cv::Mat textured(kH, kW, CV_8U, cv::Scalar(0));
  textured(interior(kW, kH, accuracyMargin(params), 8)).setTo(1);
  textured(cv::Rect(scene.flat.x - band, scene.flat.y - band, scene.flat.width + 2 * band,
                    scene.flat.height + 2 * band))
      .setTo(0);
  auto surroundings = [&](const MatchResult& res, const char* what) {
    std::vector<float> errs, confs;
    for (int y = 0; y < kH; ++y) {
      for (int x = 0; x < kW; ++x) {
        if (!textured.at<uchar>(y, x)) continue;
        const float dd = res.disparity.at<float>(y, x);
        confs.push_back(res.confidence.at<float>(y, x));
        if (dd >= 0.f) errs.push_back(std::fabs(dd - scene.pair.gt.at<float>(y, x)));
      }
    }
    std::printf("[measured] textured surroundings%s: density %.4f, median error %.4f px, "
                "median confidence %.3f\n",
                what, double(errs.size()) / confs.size(), quantile(errs, 0.5), quantile(confs, 0.5));
    EXPECT_GE(double(errs.size()) / confs.size(), 0.99);
    EXPECT_LT(quantile(errs, 0.5), 0.05);
    EXPECT_GT(quantile(confs, 0.5), 2 * low);
  };
  surroundings(r, "");

  // So a confidence floor at that level removes the flat interior entirely
  // and keeps the texture.
  MatcherParams floored = params;
  floored.confidence_floor = static_cast<float>(low);
  const MatchResult rf = run(floored, scene.pair.left, scene.pair.right);
  const FlatRegionCounts cf = countInRegion(rf, scene.pair.gt, inner, low);
  printFlat("flat interior, confidence_floor = kLowConfidence", cf);
  EXPECT_EQ(cf.estimated, 0);
  surroundings(rf, ", confidence_floor = kLowConfidence");
}

// KNOWN LIMITATION (method, not a crash): in the band one patch wide inside
// the flat region's border, the fused disparity mixes the textured patches
// that reach into the band with flat patches whose disparity is wherever the
// noise put it, and the confidence (the mean evidence of the covering patches)
// is raised by the textured ones. Measured with the default preset, pixels
// with confidence >= kLowConfidence off by >= 2 px (the bad2 outliers): 164,
// 63, 25, 48 of the 6656 band pixels for d = 3.4, 7.3, 12.6, 20.2 (at most
// 2.5 %), errors up to 4.8 px, all within 12 px (less than one patch) of the border; the
// interior is clean (test above). Measured alternatives that clean the band
// all cost accuracy on the real sequences (diffuse median error 0.526 px ->
// 0.56-0.58, past the journal release's 0.54): fusion weights times
// (evidence + lambda), lambda 0.03-0.3; a Cauchy re-weighting of the patches
// against the first fused value; confidence times a patch-spread penalty
// (which also loses density: 0.584 -> 0.495 on specular); a gradient-energy
// texture test (specular density 0.584 -> 0.411). So this test bounds the
// band's confident outliers instead of forbidding them.
TEST(MatcherRobustness, FlatRegionBorderBandConfidentOutliersStayRare) {
  const MatcherParams params;
  const int band = patchAtFullRes(params);
  for (double d : {3.4, 7.3, 12.6, 20.2}) {
    const FlatScene scene = flatRegionScene(d);
    const MatchResult r = run(params, scene.pair.left, scene.pair.right);
    const cv::Rect& flat = scene.flat;
    int band_pixels = 0, confident_outliers = 0, deepest = 0;
    double max_error = 0;
    for (int y = flat.y; y < flat.br().y; ++y) {
      for (int x = flat.x; x < flat.br().x; ++x) {
        const int depth = std::min({x - flat.x, flat.br().x - 1 - x, y - flat.y, flat.br().y - 1 - y});
        if (depth < band) ++band_pixels;
        const float e = r.disparity.at<float>(y, x);
        if (e < 0.f || r.confidence.at<float>(y, x) < kLowConfidence) continue;
        const double err = std::fabs(e - scene.pair.gt.at<float>(y, x));
        if (err < 2.0) continue;
        ++confident_outliers;
        deepest = std::max(deepest, depth);
        max_error = std::max(max_error, err);
      }
    }
    const double share = double(confident_outliers) / band_pixels;
    std::printf("[measured] d = %.1f: band %d px, confident >= 2 px errors %d (%.2f %%), max %.2f px, "
                "deepest %d px from the border\n",
                d, band_pixels, confident_outliers, 100 * share, max_error, deepest);
    EXPECT_LT(deepest, band) << "a confident outlier deeper than one patch into the flat region";
    EXPECT_LT(share, 0.035);
    EXPECT_LT(max_error, 5.0);
  }
}

// ---------------------------------------------------------------------------
// 5. Black borders: outside the rectified view.
// Measured (default): no estimate on the black left columns; of the left
// pixels whose match falls in the right image's black strip or border,
// 81-94 % keep an estimate, all within 0.18 px of the truth.
// ---------------------------------------------------------------------------

TEST(MatcherRobustness, BlackBordersGiveNoEstimateAndNoWrongMatch) {
  MatcherParams params;
  params.compute_variance = true;
  const double d = 7.3;
  StereoPair pair = texturedPair(kW, kH, {d, 0.0});
  const int border = 40;
  const cv::Range strip(150, 170);  // black in the right image only
  pair.left.colRange(0, border).setTo(0);
  pair.right.colRange(0, border).setTo(0);
  pair.right.colRange(strip.start, strip.end).setTo(0);
  const MatchResult r = run(params, pair.left, pair.right);
  expectValidResult(r, pair.left.size(), true);

  // No estimate on black left pixels.
  const cv::Rect black_left(0, 0, border, kH);
  EXPECT_EQ(cv::countNonZero(r.disparity(black_left) != kNoDisparity), 0);
  EXPECT_EQ(cv::countNonZero(r.confidence(black_left) != 0.f), 0);

  // Left pixels whose match (with its bilinear neighbours) touches a black
  // right column: no estimate or correct.
  const int margin = accuracyMargin(params);
  int affected = 0, estimated = 0, wrong = 0;
  double max_err = 0;
  for (int y = margin; y < kH - margin; ++y) {
    for (int x = border; x < kW - margin; ++x) {
      const double xr = x - pair.gt.at<float>(y, x);
      const bool into_black =
          xr - 1 < border || (xr + 1 >= strip.start && xr - 1 < strip.end);
      if (!into_black) continue;
      ++affected;
      const float e = r.disparity.at<float>(y, x);
      if (e < 0.f) continue;
      ++estimated;
      const double err = std::fabs(e - pair.gt.at<float>(y, x));
      max_err = std::max(max_err, err);
      if (err >= 0.5) ++wrong;
    }
  }
  std::printf("[measured] matches into black: %d px, density %.4f, max error %.4f px\n", affected,
              double(estimated) / affected, max_err);
  ASSERT_GT(affected, 0);
  EXPECT_EQ(wrong, 0) << "max error " << max_err;

  // Elsewhere the black areas do not hurt.
  const ErrorStats s = errorStats(r.disparity, pair.gt, cv::Rect(border + margin, margin,
                                                                   strip.start - border - margin,
                                                                   kH - 2 * margin));
  printStats("between the black areas", s);
  EXPECT_GE(s.density(), 0.99);
  EXPECT_LT(s.median, 0.05);
}

// Small black holes inside the left view (dead pixels, a masked instrument
// tip): the patches that hold a few of them take the masked sums, which
// leave the hole out, and the valid pixels around each hole keep a correct
// estimate. Taking such a patch for all-valid would compare the black pixels
// with the right image's texture. Measured with the default preset: 100 %
// of the ring around the holes estimated, median error 0.02 px, max 0.07 px.
TEST(MatcherRobustness, HolesInsideTheLeftViewAreLeftOutOfThePatchSums) {
  const MatcherParams params;
  const double d = 7.3;
  StereoPair pair = texturedPair(kW, kH, {d, 0.0});
  cv::Mat1b hole_mask(kH, kW, uchar{0});
  const int spacing = 24, side = 3;
  for (int y = spacing; y + side < kH - spacing; y += spacing) {
    for (int x = spacing + (y / spacing % 2) * (spacing / 2); x + side < kW - spacing; x += spacing) {
      hole_mask(cv::Rect(x, y, side, side)).setTo(1);
    }
  }
  pair.left.setTo(0, hole_mask);
  const MatchResult r = run(params, pair.left, pair.right);
  expectValidResult(r, pair.left.size(), false);
  EXPECT_EQ(cv::countNonZero((r.disparity != kNoDisparity) & hole_mask), 0)
      << "black left pixels have no estimate";

  // The valid pixels within 4 px of a hole: their covering patches hold it.
  cv::Mat1b near_hole;
  cv::dilate(hole_mask, near_hole, cv::Mat::ones(9, 9, CV_8U));
  near_hole.setTo(0, hole_mask);
  const int margin = accuracyMargin(params);
  cv::Mat1b inside(kH, kW, uchar{0});
  inside(interior(kW, kH, margin)).setTo(1);
  near_hole &= inside;
  std::vector<double> errors;
  int ring = 0;
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) {
      if (!near_hole(y, x)) continue;
      ++ring;
      const float e = r.disparity.at<float>(y, x);
      if (e >= 0.f) errors.push_back(std::fabs(e - pair.gt.at<float>(y, x)));
    }
  }
  ASSERT_GT(ring, 0);
  ASSERT_FALSE(errors.empty());
  std::sort(errors.begin(), errors.end());
  const double ring_density = static_cast<double>(errors.size()) / ring;
  std::printf("[measured] around the holes: %d px, density %.4f, median |err| %.4f px, max %.4f px\n",
              ring, ring_density, errors[errors.size() / 2], errors.back());
  EXPECT_GE(ring_density, 0.95);
  EXPECT_LT(errors[errors.size() / 2], 0.05);
  EXPECT_LT(errors.back(), 0.25);
}

// ---------------------------------------------------------------------------
// 6. A flat cost is rejected.
// ---------------------------------------------------------------------------

TEST(MatcherRobustness, ConstantPairHasNoEstimate) {
  MatcherParams params;
  params.compute_variance = true;
  Matcher m(params);
  for (int value : {1, 120, 255}) {
    SCOPED_TRACE("grey " + std::to_string(value));
    const cv::Mat img(kH, kW, CV_8UC1, cv::Scalar(value));
    MatchResult r;
    m.compute(img, img.clone(), r);
    expectValidResult(r, img.size(), true);
    EXPECT_EQ(cv::countNonZero(r.disparity != kNoDisparity), 0);
    EXPECT_EQ(cv::countNonZero(r.confidence != 0.f), 0);

    cv::Mat bgr;
    cv::merge(std::vector<cv::Mat>{img, img, img}, bgr);
    m.compute(bgr, bgr.clone(), r);
    EXPECT_EQ(cv::countNonZero(r.disparity != kNoDisparity), 0);
  }
}

// A clipped specular highlight: a disc saturated at 255 in both views, on the
// surface (so at the surface's disparity in each). Inside it there is nothing
// to match, so there must be no estimate; near its edge, patches that reach the
// texture may keep one, but only a right one; around it the texture matches.
TEST(MatcherRobustness, SaturatedHighlightGetsNoEstimateInside) {
  const MatcherParams params;
  const double d = 7.3;
  StereoPair pair = texturedPair(kW, kH, {d, 0.0});
  const cv::Point centre(kW / 2, kH / 2);
  const int radius = 60;
  cv::circle(pair.left, centre, radius, cv::Scalar(255), cv::FILLED);
  cv::circle(pair.right, cv::Point(centre.x - static_cast<int>(std::lround(d)), centre.y), radius,
             cv::Scalar(255), cv::FILLED);
  const MatchResult r = run(params, pair.left, pair.right);
  expectValidResult(r, pair.left.size(), false);
  cv::Mat err;
  cv::absdiff(r.disparity, pair.gt, err);
  const cv::Mat estimated = r.disparity >= 0.f;

  // Deep inside: farther from the edge than a patch's corner reaches.
  const int reach = static_cast<int>(std::ceil(std::sqrt(2.0) * patchAtFullRes(params)));
  cv::Mat deep = cv::Mat::zeros(kH, kW, CV_8UC1), disc = deep.clone();
  cv::circle(deep, centre, radius - reach, cv::Scalar(255), cv::FILLED);
  cv::circle(disc, centre, radius, cv::Scalar(255), cv::FILLED);
  const int deep_estimated = cv::countNonZero(estimated & deep);
  const int disc_estimated = cv::countNonZero(estimated & disc);
  const int disc_wrong = cv::countNonZero(estimated & disc & (err >= 1.f));
  // Outside: the interior minus the disc grown by one patch.
  cv::Mat outside = cv::Mat::zeros(kH, kW, CV_8UC1);
  outside(interior(kW, kH, accuracyMargin(params), 8)).setTo(255);
  cv::circle(outside, centre, radius + patchAtFullRes(params), cv::Scalar(0), cv::FILLED);
  const int outside_px = cv::countNonZero(outside);
  const int outside_good = cv::countNonZero(estimated & (err < 0.5f) & outside);
  std::printf("[measured] saturated disc: %d of %d pixels deep inside estimated, %d of %d in the "
              "disc (%d off by >= 1 px); outside %.4f within 0.5 px\n",
              deep_estimated, cv::countNonZero(deep), disc_estimated, cv::countNonZero(disc),
              disc_wrong, static_cast<double>(outside_good) / outside_px);
  EXPECT_GT(cv::countNonZero(deep), 3000);
  EXPECT_EQ(deep_estimated, 0) << "a disparity inside a saturated area is a guess";
  EXPECT_EQ(disc_wrong, 0);
  EXPECT_GT(static_cast<double>(outside_good) / outside_px, 0.9);
}

// All-black and saturated frames (lens cap, light off, glare) give no estimate
// and leave nothing behind: the next good frame is what a fresh matcher gives.
TEST(MatcherRobustness, DegenerateFramesThenGoodFrame) {
  MatcherParams params;
  params.compute_variance = true;
  const StereoPair good = texturedPair(kW, kH, {5.6, 0.0});
  const MatchResult fresh = run(params, good.left, good.right);
  ASSERT_GT(density(fresh.disparity), 0.9);

  Matcher m(params);
  MatchResult r;
  const cv::Mat black = cv::Mat::zeros(kH, kW, CV_8UC1);
  const cv::Mat saturated(kH, kW, CV_8UC1, cv::Scalar(255));
  cv::Mat half_saturated = good.left.clone();
  half_saturated(cv::Rect(0, 0, kW / 2, kH)).setTo(255);
  const std::vector<std::pair<const char*, std::pair<cv::Mat, cv::Mat>>> frames = {
      {"black", {black, black}},
      {"saturated", {saturated, saturated}},
      {"black left, good right", {black, good.right}},
      {"saturated left, good right", {saturated, good.right}},
      {"half-saturated left", {half_saturated, good.right}},
  };
  for (const auto& f : frames) {
    SCOPED_TRACE(f.first);
    ASSERT_NO_THROW(m.compute(f.second.first, f.second.second, r));
    expectValidResult(r, good.left.size(), true);
    if (std::string(f.first) == "half-saturated left") continue;  // the textured half matches
    EXPECT_EQ(cv::countNonZero(r.disparity >= 0.f), 0);
  }
  m.compute(good.left, good.right, r);
  EXPECT_TRUE(identical(r.disparity, fresh.disparity));
  EXPECT_TRUE(identical(r.confidence, fresh.confidence));
  EXPECT_TRUE(identical(r.variance, fresh.variance));
}

TEST(MatcherRobustness, NearlyFlatPairIsNeverConfident) {
  // Constant 120 plus independent sigma-0.5 noise per camera: noise creates
  // local minima that pass the local-minimum test, but their posterior stays
  // near chance, so confidence stays below kLowConfidence (see section 4).
  // Measured: density 0.001, max confidence 0.018 now (raw-posterior version:
  // density 0.18-0.87, posterior 0.21, i.e. within 2 % of chance). The band
  // one patch wide along the image border is excluded: there a window sample
  // outside the image gets zero likelihood, which lifts the others (raw
  // posterior 0.250 in the first version).
  const MatcherParams params;
  cv::Mat left(kH, kW, CV_8UC1), right(kH, kW, CV_8UC1);
  cv::RNG rng(3);
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) {
      left.at<uchar>(y, x) = toByte(120 + rng.gaussian(0.5));
      right.at<uchar>(y, x) = toByte(120 + rng.gaussian(0.5));
    }
  }
  const MatchResult r = run(params, left, right);
  const cv::Rect roi = interior(kW, kH, patchAtFullRes(params));
  double max_conf;
  cv::minMaxLoc(r.confidence(roi), nullptr, &max_conf);
  std::printf("[measured] noisy flat pair: density %.4f, max confidence %.4f\n",
              density(r.disparity(roi)), max_conf);
  EXPECT_LT(max_conf, kLowConfidence);
}

// ---------------------------------------------------------------------------
// 7. Odd and tiny sizes.
// ---------------------------------------------------------------------------

TEST(MatcherOutputs, OddAndTinySizesKeepTheOutputContract) {
  const cv::Size sizes[] = {{32, 32}, {33, 47}, {47, 33}, {100, 35}, {641, 479}, {161, 121}};
  MatcherParams params;
  Matcher plain(params);
  params.compute_variance = true;
  Matcher with_variance(params);
  for (const cv::Size& size : sizes) {
    const double d = size.width >= 160 ? 7.3 : 3.3;
    const StereoPair pair = texturedPair(size.width, size.height, {d, 0.0});
    for (bool variance : {false, true}) {
      SCOPED_TRACE(std::to_string(size.width) + "x" + std::to_string(size.height) +
                   (variance ? " with variance" : ""));
      MatchResult r;
      (variance ? with_variance : plain).compute(pair.left, pair.right, r);
      expectValidResult(r, size, variance);
      // Textured input: most pixels get an estimate, even at 32x32.
      EXPECT_GT(density(r.disparity), 0.5);
      if (size.width >= 160) {
        const ErrorStats s = errorStats(
            r.disparity, pair.gt, interior(size.width, size.height, accuracyMargin(params), 8));
        EXPECT_LT(s.median, 0.05);
      }
    }
  }
}

// An odd last input row has no pixel at level 1, but it belongs to the
// output mask: black there means no estimate, real pixels mean estimates
// (mono and BGR inputs take different paths through the pyramid).
TEST(MatcherOutputs, OddLastRowFollowsTheLeftValidity) {
  const StereoPair pair = texturedPair(161, 121, {7.3, 0.0});
  Matcher matcher;
  for (bool colour : {false, true}) {
    for (bool black_last_row : {false, true}) {
      SCOPED_TRACE(std::string(colour ? "BGR" : "mono") + (black_last_row ? ", black last row" : ""));
      cv::Mat left = pair.left.clone(), right = pair.right.clone();
      if (black_last_row) left.row(left.rows - 1).setTo(0);
      if (colour) {
        cv::cvtColor(left, left, cv::COLOR_GRAY2BGR);
        cv::cvtColor(right, right, cv::COLOR_GRAY2BGR);
      }
      MatchResult r;
      matcher.compute(left, right, r);
      const cv::Mat last = r.disparity.row(r.disparity.rows - 1);
      if (black_last_row) {
        EXPECT_EQ(cv::countNonZero(last >= 0.f), 0);
      } else {
        EXPECT_GT(cv::countNonZero(last >= 0.f), last.cols / 2);
      }
    }
  }
}

TEST(MatcherOutputs, ExtremeParametersKeepTheOutputContract) {
  const StereoPair pair = texturedPair(160, 120, {5.6, 0.0});
  std::vector<MatcherParams> all;
  for (const std::string& name : MatcherParams::presetNames()) all.push_back(MatcherParams::preset(name));
  auto with = [](auto f) {
    MatcherParams p;
    f(p);
    return p;
  };
  all.push_back(with([](MatcherParams& p) { p.patch_size = 4; }));
  all.push_back(with([](MatcherParams& p) { p.patch_size = 32; }));
  all.push_back(with([](MatcherParams& p) { p.overlap = 0.95f; }));
  all.push_back(with([](MatcherParams& p) { p.overlap = 0.f; }));
  all.push_back(with([](MatcherParams& p) { p.window_half_width = 10, p.window_step = 4.f; }));
  all.push_back(with([](MatcherParams& p) { p.window_half_width = 1, p.window_step = 0.05f; }));
  all.push_back(with([](MatcherParams& p) { p.coarsest_level = 10, p.finest_level = 10; }));
  all.push_back(with([](MatcherParams& p) { p.coarsest_level = 0, p.finest_level = 0; }));
  all.push_back(with([](MatcherParams& p) { p.sigma_r = 0.1f, p.contrast_share = 100.f; }));
  all.push_back(with([](MatcherParams& p) { p.min_valid_share = 1.f, p.iterations = 1; }));
  all.push_back(with([](MatcherParams& p) { p.confidence_floor = 0.f, p.iterations = 200; }));
  all.push_back(with([](MatcherParams& p) { p.sigma_s = 100.f; }));
  for (size_t i = 0; i < all.size(); ++i) {
    SCOPED_TRACE("parameter set " + std::to_string(i) + ":\n" + bdis::toYaml(all[i]));
    for (bool variance : {false, true}) {
      all[i].compute_variance = variance;
      const MatchResult r = run(all[i], pair.left, pair.right);
      expectValidResult(r, pair.left.size(), variance);
    }
  }
  // The confidence floor: every estimate reaches it, and a higher floor never
  // adds estimates.
  double previous_density = 1.0;
  for (float floor : {0.f, 0.3f, 0.6f, 0.9f, 1.f}) {
    SCOPED_TRACE("confidence_floor = " + std::to_string(floor));
    MatcherParams p;
    p.confidence_floor = floor;
    const MatchResult r = run(p, pair.left, pair.right);
    const cv::Mat estimated = r.disparity >= 0.f;
    double min_conf = 1.0;
    if (cv::countNonZero(estimated) > 0) cv::minMaxLoc(r.confidence, &min_conf, nullptr, nullptr, nullptr, estimated);
    EXPECT_GE(min_conf, floor);
    EXPECT_LE(density(r.disparity), previous_density);
    previous_density = density(r.disparity);
  }
}

// Regression test for a bug found while writing these tests (fuseLevel in
// src/core/matcher.cpp): the pixel variance was vnum / vden with vden the sum
// of the squared weights w^2 = (posterior * spatial)^2 in float. With a small
// sigma_s the spatial weight of off-centre pixels is ~1e-25, w^2 underflowed
// to 0 while w itself (in fused_den) did not, so the pixel kept a disparity
// but its variance was 0/0 = NaN: 49718 such pixels on 320x240 at
// sigma_s = 0.2 and 14720 at 0.3, both inside the accepted range [0.1, 100].
// Fixed; DISABLED_ until then.
TEST(MatcherOutputs, SmallSigmaSKeepsVarianceFiniteWhereEstimated) {
  const StereoPair pair = texturedPair(160, 120, {5.6, 0.0});
  for (float sigma_s : {0.1f, 0.2f, 0.3f, 0.5f}) {
    SCOPED_TRACE("sigma_s = " + std::to_string(sigma_s));
    MatcherParams params;
    params.sigma_s = sigma_s;
    params.compute_variance = true;
    const MatchResult r = run(params, pair.left, pair.right);
    expectValidResult(r, pair.left.size(), true);
  }
}

// Every output row is written, whichever level is the finest (upsampling by
// 1, 2, 4 or 8) and for heights that leave a partial fusion band and an odd
// last row. A result pre-filled with values the matcher never writes would
// show a missed row, and a fresh result must agree with it bit for bit.
TEST(MatcherOutputs, EveryOutputRowIsWrittenAtEachFinestLevel) {
  const cv::Size sizes[] = {{96, 481}, {161, 263}, {200, 64}};
  for (int finest = 0; finest <= 3; ++finest) {
    for (const cv::Size& size : sizes) {
      for (bool variance : {false, true}) {
        SCOPED_TRACE("finest_level " + std::to_string(finest) + ", " + std::to_string(size.width) +
                     "x" + std::to_string(size.height) + (variance ? " with variance" : ""));
        MatcherParams params;
        params.finest_level = finest;
        params.coarsest_level = std::max(params.coarsest_level, finest);
        params.compute_variance = variance;
        const StereoPair pair = texturedPair(size.width, size.height, {5.6, 0.0});
        MatchResult prefilled;
        prefilled.disparity = cv::Mat(size, CV_32FC1, cv::Scalar(-7.f));
        prefilled.confidence = cv::Mat(size, CV_32FC1, cv::Scalar(7.f));
        prefilled.variance = cv::Mat(size, CV_32FC1, cv::Scalar(-7.f));
        Matcher matcher(params);
        matcher.compute(pair.left, pair.right, prefilled);
        expectValidResult(prefilled, size, variance);
        EXPECT_EQ(cv::countNonZero(prefilled.disparity == -7.f), 0);
        EXPECT_GT(density(prefilled.disparity), 0.3);
        const MatchResult fresh = run(params, pair.left, pair.right);
        EXPECT_TRUE(identical(prefilled.disparity, fresh.disparity));
        EXPECT_TRUE(identical(prefilled.confidence, fresh.confidence));
        EXPECT_TRUE(identical(prefilled.variance, fresh.variance));
      }
    }
  }
}

// ---------------------------------------------------------------------------
// 7b. The left-right check.
// A textured foreground strip at disparity 20 in front of a textured
// background at disparity 4. The right camera does not see the background
// just left of the strip's left edge (16 px wide in the left image): no
// estimate there can be right, and the check is what removes them, while it
// keeps the estimates where both views see the surface.
// ---------------------------------------------------------------------------

namespace {

constexpr int kOccW = 320, kOccH = 160;
constexpr int kStripX0 = 140, kStripX1 = 230;  // left-image columns of the strip
constexpr double kBackground = 4.0, kForeground = 20.0;

StereoPair occludingStripPair() {
  const Texture background(3), foreground(4);
  std::vector<double> xs(kOccW), xs_bg(kOccW), xs_fg(kOccW);
  for (int x = 0; x < kOccW; ++x) {
    xs[static_cast<size_t>(x)] = x;
    xs_bg[static_cast<size_t>(x)] = x + kBackground;
    xs_fg[static_cast<size_t>(x)] = x + kForeground;
  }
  const cv::Mat bg_left = background.render(xs, kOccH), fg_left = foreground.render(xs, kOccH);
  const cv::Mat bg_right = background.render(xs_bg, kOccH), fg_right = foreground.render(xs_fg, kOccH);
  StereoPair p;
  p.left = bg_left.clone();
  p.right = bg_right.clone();
  p.gt = cv::Mat(kOccH, kOccW, CV_32FC1, cv::Scalar(static_cast<float>(kBackground)));
  fg_left.colRange(kStripX0, kStripX1).copyTo(p.left.colRange(kStripX0, kStripX1));
  p.gt.colRange(kStripX0, kStripX1).setTo(static_cast<float>(kForeground));
  // Right column xr shows the strip where xr + 20 falls on it.
  const int r0 = kStripX0 - static_cast<int>(kForeground), r1 = kStripX1 - static_cast<int>(kForeground);
  fg_right.colRange(r0, r1).copyTo(p.right.colRange(r0, r1));
  return p;
}

}  // namespace

TEST(MatcherLeftRightCheck, DropsEstimatesWhereTheRightViewIsOccludedAndKeepsTheRest) {
  const StereoPair pair = occludingStripPair();
  const int margin = 24;  // rows and columns near the image edge left out
  const int occluded_x0 = kStripX0 - static_cast<int>(kForeground - kBackground);
  const cv::Rect occluded(occluded_x0, margin, kStripX0 - occluded_x0, kOccH - 2 * margin);
  // Both views see these: background and strip, a patch away from the edges.
  const cv::Rect seen_background(margin, margin, occluded_x0 - 16 - margin, kOccH - 2 * margin);
  const cv::Rect seen_strip(kStripX0 + 16, margin, kStripX1 - kStripX0 - 32, kOccH - 2 * margin);
  for (const char* preset : {"fast", "balanced", "accurate"}) {
    SCOPED_TRACE(preset);
    MatcherParams checked = MatcherParams::preset(preset);
    ASSERT_GT(checked.lr_check_tolerance, 0.f);
    MatcherParams unchecked = checked;
    unchecked.lr_check_tolerance = 0.f;
    const MatchResult with = run(checked, pair.left, pair.right);
    const MatchResult without = run(unchecked, pair.left, pair.right);
    expectValidResult(with, pair.left.size(), checked.compute_variance);
    const double occluded_with = density(with.disparity(occluded));
    const double occluded_without = density(without.disparity(occluded));
    const ErrorStats background_with = errorStats(with.disparity, pair.gt, seen_background);
    const ErrorStats strip_with = errorStats(with.disparity, pair.gt, seen_strip);
    const double background_without = density(without.disparity(seen_background));
    const double strip_without = density(without.disparity(seen_strip));
    std::printf("[measured] %s: occluded band density %.3f checked / %.3f unchecked; seen "
                "background %.3f / %.3f, strip %.3f / %.3f; median |err| %.3f / %.3f px\n",
                preset, occluded_with, occluded_without, background_with.density(),
                background_without, strip_with.density(), strip_without, background_with.median,
                strip_with.median);
    // Most of the occluded band loses its estimates; where both views see
    // the surface, the check keeps almost everything.
    EXPECT_LT(occluded_with, 0.5 * occluded_without);
    EXPECT_GT(background_with.density(), 0.95 * background_without);
    EXPECT_GT(strip_with.density(), 0.95 * strip_without);
    EXPECT_LT(background_with.median, 0.1);
    EXPECT_LT(strip_with.median, 0.1);
  }
}

// ---------------------------------------------------------------------------
// 8. Invalid input.
// ---------------------------------------------------------------------------

TEST(MatcherInputs, InvalidImagesThrowInvalidArgumentSayingWhy) {
  Matcher m;
  MatchResult r;
  const cv::Mat good(64, 64, CV_8UC1, cv::Scalar(100));
  auto message = [&](const cv::Mat& left, const cv::Mat& right) {
    return invalidArgumentMessage([&] { m.compute(left, right, r); });
  };
  struct Case {
    const char* what;
    cv::Mat left, right;
    std::vector<std::string> expected;  // substrings of the message
  };
  const int sz3[] = {40, 40, 3};
  const std::vector<Case> cases = {
      {"empty left", cv::Mat(), good, {"left", "empty"}},
      {"empty right", good, cv::Mat(), {"right", "empty"}},
      {"mismatched sizes", good, cv::Mat(64, 65, CV_8UC1, cv::Scalar(100)), {"equal sizes"}},
      {"mismatched types", good, cv::Mat(64, 64, CV_8UC3, cv::Scalar::all(100)), {"same type"}},
      {"16-bit", cv::Mat(64, 64, CV_16UC1, cv::Scalar(100)), good, {"left", "16UC1", "8-bit"}},
      {"16-bit right", good, cv::Mat(64, 64, CV_16UC1, cv::Scalar(100)), {"right", "16UC1"}},
      {"float", cv::Mat(64, 64, CV_32FC1, cv::Scalar(100)), good, {"32FC1", "8-bit"}},
      {"4-channel", cv::Mat(64, 64, CV_8UC4, cv::Scalar::all(100)),
       cv::Mat(64, 64, CV_8UC4, cv::Scalar::all(100)), {"8UC4", "CV_8UC3"}},
      {"2-channel", cv::Mat(64, 64, CV_8UC2, cv::Scalar::all(100)),
       cv::Mat(64, 64, CV_8UC2, cv::Scalar::all(100)), {"8UC2"}},
      {"1xN", cv::Mat(1, 100, CV_8UC1, cv::Scalar(100)), cv::Mat(1, 100, CV_8UC1, cv::Scalar(100)),
       {"100x1", "at least 32"}},
      {"Nx1", cv::Mat(100, 1, CV_8UC1, cv::Scalar(100)), cv::Mat(100, 1, CV_8UC1, cv::Scalar(100)),
       {"1x100", "at least 32"}},
      {"31 wide", cv::Mat(64, 31, CV_8UC1, cv::Scalar(100)), cv::Mat(64, 31, CV_8UC1, cv::Scalar(100)),
       {"31x64", "at least 32"}},
      {"31 high", cv::Mat(31, 64, CV_8UC1, cv::Scalar(100)), cv::Mat(31, 64, CV_8UC1, cv::Scalar(100)),
       {"64x31", "at least 32"}},
      {"small right only", good, cv::Mat(20, 20, CV_8UC1, cv::Scalar(100)), {"right", "at least 32"}},
      {"3-D", cv::Mat(3, sz3, CV_8UC1, cv::Scalar(100)), cv::Mat(3, sz3, CV_8UC1, cv::Scalar(100)),
       {"2-D"}},
  };
  for (const Case& c : cases) {
    const std::string msg = message(c.left, c.right);
    for (const std::string& s : c.expected) {
      EXPECT_TRUE(contains(msg, s)) << c.what << ": message '" << msg << "' lacks '" << s << "'";
    }
  }
  // The matcher is still usable after rejecting input.
  EXPECT_NO_THROW(m.compute(good, good, r));
  EXPECT_EQ(r.disparity.size(), good.size());
}

TEST(MatcherInputs, RoiInputsGiveTheSameResultAsClones) {
  MatcherParams params;
  params.compute_variance = true;
  const StereoPair big = texturedPair(401, 307, {7.3, 0.0});
  const cv::Rect roi(37, 21, 251, 203);  // odd offset and size: non-contiguous rows
  const cv::Mat left_roi = big.left(roi), right_roi = big.right(roi);
  ASSERT_FALSE(left_roi.isContinuous());
  const MatchResult from_roi = run(params, left_roi, right_roi);
  const MatchResult from_clone = run(params, left_roi.clone(), right_roi.clone());
  EXPECT_TRUE(identical(from_roi.disparity, from_clone.disparity));
  EXPECT_TRUE(identical(from_roi.confidence, from_clone.confidence));
  EXPECT_TRUE(identical(from_roi.variance, from_clone.variance));
  EXPECT_GT(density(from_roi.disparity), 0.9);

  // BGR ROI too.
  cv::Mat bgr_l, bgr_r;
  cv::merge(std::vector<cv::Mat>{big.left, big.left, big.left}, bgr_l);
  cv::merge(std::vector<cv::Mat>{big.right, big.right, big.right}, bgr_r);
  const MatchResult from_bgr_roi = run(params, bgr_l(roi), bgr_r(roi));
  EXPECT_TRUE(identical(from_bgr_roi.disparity, from_clone.disparity));
}

// ---------------------------------------------------------------------------
// 9. Mono and BGR.
// ---------------------------------------------------------------------------

TEST(MatcherInputs, BgrWithEqualChannelsEqualsMono) {
  MatcherParams params;
  params.compute_variance = true;
  const StereoPair pair = texturedPair(kW, kH, {7.3, 0.0});
  cv::Mat bgr_l, bgr_r;
  cv::merge(std::vector<cv::Mat>{pair.left, pair.left, pair.left}, bgr_l);
  cv::merge(std::vector<cv::Mat>{pair.right, pair.right, pair.right}, bgr_r);
  const MatchResult mono = run(params, pair.left, pair.right);
  const MatchResult colour = run(params, bgr_l, bgr_r);
  EXPECT_TRUE(identical(mono.disparity, colour.disparity));
  EXPECT_TRUE(identical(mono.confidence, colour.confidence));
  EXPECT_TRUE(identical(mono.variance, colour.variance));
  EXPECT_GT(density(mono.disparity), 0.9);
}

TEST(MatcherInputs, BgrPixelIsBlackOnlyWhenAllChannelsAreZero) {
  // Isolated left pixels on a 7 px grid are set to (1, 0, 0), whose grey
  // level rounds to 0 but which is not black, or to (0, 0, 0), which is.
  // Only the latter are outside the view and get no estimate.
  const StereoPair pair = texturedPair(kW, kH, {7.3, 0.0});
  cv::Mat bgr_l, bgr_r;
  cv::merge(std::vector<cv::Mat>{pair.left, pair.left, pair.left}, bgr_l);
  cv::merge(std::vector<cv::Mat>{pair.right, pair.right, pair.right}, bgr_r);
  const int margin = accuracyMargin(MatcherParams{});
  for (const cv::Vec3b& marker : {cv::Vec3b(1, 0, 0), cv::Vec3b(0, 0, 0)}) {
    const bool black = marker == cv::Vec3b(0, 0, 0);
    SCOPED_TRACE(black ? "black markers" : "dark markers");
    cv::Mat left = bgr_l.clone();
    int markers = 0, estimated = 0;
    for (int y = margin; y < kH - margin; y += 7) {
      for (int x = margin; x < kW - margin; x += 7) left.at<cv::Vec3b>(y, x) = marker, ++markers;
    }
    const MatchResult r = run(MatcherParams{}, left, bgr_r);
    for (int y = margin; y < kH - margin; y += 7) {
      for (int x = margin; x < kW - margin; x += 7) estimated += r.disparity.at<float>(y, x) >= 0.f;
    }
    if (black) {
      EXPECT_EQ(estimated, 0);
    } else {
      EXPECT_GE(estimated, 0.95 * markers);
    }
  }
}

// ---------------------------------------------------------------------------
// 10. Reuse.
// ---------------------------------------------------------------------------

TEST(MatcherReuse, RepeatedAndInterleavedSizesGiveIdenticalResults) {
  MatcherParams params;
  params.compute_variance = true;
  const StereoPair a = texturedPair(kW, kH, {7.3, 0.0}, 1);
  const StereoPair b = texturedPair(161, 97, {3.3, 0.0}, 2);
  Matcher m(params);
  MatchResult first, second, reused;
  m.compute(a.left, a.right, first);
  m.compute(a.left, a.right, second);
  EXPECT_TRUE(identical(first.disparity, second.disparity));
  EXPECT_TRUE(identical(first.confidence, second.confidence));
  EXPECT_TRUE(identical(first.variance, second.variance));

  // A different size in between, into the same result object.
  reused = second;  // shares buffers with `second`: must be reallocated, not overwritten
  m.compute(b.left, b.right, reused);
  expectValidResult(reused, b.left.size(), true);
  const MatchResult fresh_b = run(params, b.left, b.right);
  EXPECT_TRUE(identical(reused.disparity, fresh_b.disparity));
  EXPECT_TRUE(identical(reused.confidence, fresh_b.confidence));
  EXPECT_TRUE(identical(second.disparity, first.disparity)) << "earlier result was overwritten";

  m.compute(a.left, a.right, reused);
  EXPECT_TRUE(identical(reused.disparity, first.disparity));
  EXPECT_TRUE(identical(reused.confidence, first.confidence));
  EXPECT_TRUE(identical(reused.variance, first.variance));
}

TEST(MatcherReuse, ResultObjectFromOtherUseIsOverwrittenCompletely) {
  // A MatchResult holding stale, wrongly typed buffers: compute replaces them.
  const StereoPair a = texturedPair(160, 120, {5.6, 0.0});
  MatchResult stale;
  stale.disparity = cv::Mat(120, 160, CV_8UC1, cv::Scalar(7));
  stale.confidence = cv::Mat(5, 5, CV_32FC1, cv::Scalar(2.f));
  stale.variance = cv::Mat(120, 160, CV_32FC1, cv::Scalar(3.f));
  Matcher m;  // compute_variance off
  m.compute(a.left, a.right, stale);
  expectValidResult(stale, a.left.size(), false);
  EXPECT_TRUE(identical(stale.disparity, run(MatcherParams{}, a.left, a.right).disparity));
}

TEST(MatcherReuse, SetParamsBetweenFramesActsLikeAFreshMatcher) {
  const StereoPair a = texturedPair(kW, kH, {7.3, 0.0});
  Matcher m;
  MatchResult r;
  m.compute(a.left, a.right, r);
  std::vector<MatcherParams> changes;
  MatcherParams p;
  p.patch_size = 12;
  changes.push_back(p);
  p.window_half_width = 3;
  p.window_step = 0.5f;
  changes.push_back(p);
  p.compute_variance = true;
  p.overlap = 0.6f;
  changes.push_back(p);
  p.coarsest_level = 3;
  changes.push_back(p);
  p.finest_level = 2;  // a coarser finest level
  changes.push_back(p);
  changes.push_back(MatcherParams::preset("fast"));
  for (size_t i = 0; i < changes.size(); ++i) {
    SCOPED_TRACE("change " + std::to_string(i));
    m.setParams(changes[i]);
    EXPECT_EQ(bdis::toYaml(m.params()), bdis::toYaml(changes[i]));
    m.compute(a.left, a.right, r);
    const MatchResult fresh = run(changes[i], a.left, a.right);
    EXPECT_TRUE(identical(r.disparity, fresh.disparity));
    EXPECT_TRUE(identical(r.confidence, fresh.confidence));
    EXPECT_TRUE(identical(r.variance, fresh.variance));
  }
}

// Regression test for a bug found while writing these tests (allocate() in
// src/core/matcher.cpp): its "already sized" early return compared size, level
// count, patch size and window but not finest_level, although the level-sized
// buffers (fused_num ... level_disparity) are allocated at the finest level's
// size. After a frame with finest_level = 1, setParams(finest_level = 0) on a
// frame of the same size kept the half-size buffers and compute() threw
// cv::Exception from `fused_num(roi)` in fuseLevel (without that ROI check the
// level_disparity writes would have run past the buffer). Fixed; DISABLED_
// until then.
TEST(MatcherReuse, SetParamsToAFinerFinestLevelBetweenFrames) {
  const StereoPair a = texturedPair(kW, kH, {7.3, 0.0});
  Matcher m;
  MatchResult r;
  m.compute(a.left, a.right, r);
  MatcherParams finer;
  finer.finest_level = 0;
  m.setParams(finer);
  ASSERT_NO_THROW(m.compute(a.left, a.right, r));
  EXPECT_TRUE(identical(r.disparity, run(finer, a.left, a.right).disparity));
}

TEST(MatcherReuse, MovedMatcherKeepsWorking) {
  const StereoPair a = texturedPair(160, 120, {5.6, 0.0});
  MatcherParams params = MatcherParams::preset("accurate");
  Matcher original(params);
  MatchResult before;
  original.compute(a.left, a.right, before);
  Matcher moved(std::move(original));
  MatchResult after;
  moved.compute(a.left, a.right, after);
  EXPECT_TRUE(identical(before.disparity, after.disparity));
  EXPECT_EQ(bdis::toYaml(moved.params()), bdis::toYaml(params));
  Matcher assigned;
  assigned = std::move(moved);
  assigned.compute(a.left, a.right, after);
  EXPECT_TRUE(identical(before.disparity, after.disparity));
}

}  // namespace

// ---------------------------------------------------------------------------
// 9. SIMD and scalar kernels give the same matcher output.
// BDIS_SIMD=off forces the scalar kernels, =baseline the SSE2/NEON ones. Float
// sums in another order move a cost by ~1e-6 relative, which can tip a rare
// discrete decision (a propagation candidate, the local-minimum test). Measured on the scene below:
// all pixels agree on having an estimate or not; largest disparity difference
// 1.3e-4 px (AVX2) and 4e-5 px (SSE2).
// ---------------------------------------------------------------------------

TEST(MatcherKernels, SimdAndScalarPathsAgree) {
  if (bdis::detail::bestKernelIsa() == bdis::detail::KernelIsa::Scalar) {
    GTEST_SKIP() << "BDIS_SIMD=off is set";
  }
  const char* saved = std::getenv("BDIS_SIMD");
  for (const char* simd : {"", "baseline"}) {  // best available, then the baseline ISA
    for (const char* preset : {"fast", "balanced"}) {
      const MatcherParams params = MatcherParams::preset(preset);
      StereoPair pair = texturedPair(kW, kH, {6.0, 0.03}, 21);
      // Masked-path patches too: invalid pixels in the template, and matches
      // that touch invalid right pixels.
      pair.left.colRange(0, 20).setTo(0);
      pair.right.rowRange(kH - 12, kH).colRange(30, kW).setTo(0);
      setenv("BDIS_SIMD", simd, 1);
      const char* kernels = bdis::detail::kernelsFor(params.patch_size, bdis::detail::bestKernelIsa()).name;
      const MatchResult fast = run(params, pair.left, pair.right);
      setenv("BDIS_SIMD", "off", 1);
      const MatchResult scalar = run(params, pair.left, pair.right);
      const cv::Mat fast_has = fast.disparity >= 0.f, scalar_has = scalar.disparity >= 0.f;
      const int differ = cv::countNonZero(fast_has != scalar_has);
      const cv::Mat both = fast_has & scalar_has;
      double max_diff = 0;
      cv::minMaxLoc(cv::abs(fast.disparity - scalar.disparity), nullptr, &max_diff, nullptr, nullptr, both);
      std::printf("[measured] %s, %s kernels vs scalar: %d px differ in having an estimate, "
                  "max |d| diff %.2e px\n", preset, kernels, differ, max_diff);
      EXPECT_STRNE(kernels, "scalar");
      EXPECT_LE(differ, kW * kH / 1000);
      EXPECT_LT(max_diff, 1e-2);
    }
  }
  if (saved) setenv("BDIS_SIMD", saved, 1); else unsetenv("BDIS_SIMD");
}
