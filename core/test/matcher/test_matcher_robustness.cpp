// The matcher where matching is hard: textureless regions, black borders and
// holes, flat or saturated pairs, occlusions and the left-right check.
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

#include "bdis_stereo/error_analysis.hpp"
#include "bdis_stereo/matcher.hpp"
#include "cues_product_params.hpp"
#include "matcher_test_util.hpp"
#include "test_images.hpp"

using namespace matcher_test;

namespace {

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
// preset, current library): density 0.016, max confidence 0.016, max
// confidence of a >= 1 px error 0.000 (with the posterior window's samples
// 1 px apart 0.008, 0.047 and 0.039); with the raw-posterior version:
// density 0.47-0.90, median error 2-5 px, max confidence 0.215.
// The "flat interior" excludes a band one full-resolution patch wide along
// the region's border, because a patch there also sees texture and may be
// legitimately confident; see the DISABLED_ test below for that band.
// ---------------------------------------------------------------------------

// On the cues' product's scale: the tests run with cuesProductParams().
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
  const MatcherParams params = cuesProductParams();
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

// In the band one patch wide inside the flat region's border, the fused
// disparity mixes the textured patches that reach into the band with flat
// patches whose disparity is wherever the noise put it, and the mean evidence
// of the covering patches is raised by the textured ones. Measured with the
// default preset before the slant cue, pixels with confidence >=
// kLowConfidence off by >= 2 px: 164, 63, 25, 48 of the 6656 band pixels for
// d = 3.4, 7.3, 12.6, 20.2 (at most 2.5 %), errors up to 4.8 px. The mixed
// disparities vary across the band, so the slant cue lowers their confidence:
// 0 of 6656 for every d now. Measured alternatives that cleaned the band
// before it all cost accuracy on the real sequences (diffuse median error
// 0.526 px -> 0.56-0.58, past the journal release's 0.54): fusion weights
// times (evidence + lambda), lambda 0.03-0.3; a Cauchy re-weighting of the
// patches against the first fused value; confidence times a patch-spread
// penalty (which also loses density: 0.584 -> 0.495 on specular); a
// gradient-energy texture test (specular density 0.584 -> 0.411); the slant
// cue changes the confidence only.
TEST(MatcherRobustness, FlatRegionBorderBandConfidentOutliersStayRare) {
  const MatcherParams params = cuesProductParams();
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
    EXPECT_LE(share, 0.005);
    EXPECT_LT(max_error, 5.0);
  }
}

// ---------------------------------------------------------------------------
// 5. Black borders: outside the rectified view.
// Measured (default): no estimate on the black left columns; of the left
// pixels whose match falls in the right image's black strip or border,
// 74 % keep an estimate, all within 0.13 px of the truth (81-94 % within
// 0.18 px with the posterior window's samples 1 px apart: the wider window
// reaches the black sooner, and a patch whose window costs are summed over
// fewer valid pixels fails the local-minimum test more often).
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

/// Frames an image as rectification does: black columns [0, left) and
/// [w - right, w), each followed inwards by a dark seam (grey 18 down to 2,
/// `seam` px) and one pixel blended halfway between the seam and the image.
void rectificationFrame(cv::Mat& image, int left, int right, int seam) {
  const int w = image.cols;
  for (int y = 0; y < image.rows; ++y) {
    uchar* row = image.ptr<uchar>(y);
    for (const int side : {+1, -1}) {
      const int edge = side > 0 ? left : w - 1 - right;  // first pixel inside the frame
      for (int x = side > 0 ? 0 : w - right; x < (side > 0 ? left : w); ++x) row[x] = 0;
      for (int i = 0; i < seam; ++i) row[edge + side * i] = static_cast<uchar>(18 - 16 * i / std::max(1, seam - 1));
      uchar& blend = row[edge + side * seam];
      blend = static_cast<uchar>((blend + 10) / 2);
    }
  }
}

// The frames of the two views of a rectified pair sit at different offsets,
// and their edges (black, a dark seam, a blended pixel) are the strongest
// texture near the border. Matched to each other, they would give a strip of
// disparities equal to the frames' offset along the border (in endoscope
// recordings 5-20 px wide). Left frame 40 px, right 18 px, at a disparity
// of 12 px; right-hand frames 30 and 45 px, seams of 3 to 5 px.
TEST(MatcherRobustness, RectificationFramesGiveNoStripOfWrongDisparity) {
  const double d = 12.0;
  for (int seam : {3, 5}) {
    SCOPED_TRACE("seam " + std::to_string(seam));
    StereoPair pair = texturedPair(kW, kH, {d, 0.0}, 9);
    rectificationFrame(pair.left, 40, 30, seam);
    rectificationFrame(pair.right, 18, 45, seam);
    for (const char* preset : {"fast", "balanced", "accurate"}) {
      SCOPED_TRACE(preset);
      const MatchResult r = run(MatcherParams::preset(preset), pair.left, pair.right);
      expectValidResult(r, pair.left.size(), false);
      // Per row, within 16 px of the frames' inner edges: no estimate off
      // by more than 1 px, and no strip of them against the inner median.
      int near_border = 0, wrong = 0;
      for (int y = 16; y < kH - 16; ++y) {
        for (const int x0 : {40, kW - 30 - 16}) {
          for (int x = x0; x < x0 + 16; ++x) {
            const float e = r.disparity.at<float>(y, x);
            if (e < 0.f) continue;
            ++near_border;
            wrong += std::fabs(e - pair.gt.at<float>(y, x)) > 1.f ? 1 : 0;
          }
        }
      }
      const bdis::BorderStripScore strips = bdis::scoreBorderStrips(r.disparity, pair.left);
      std::printf("[measured] %s, seam %d px: %d estimates within 16 px of the frames, %d off by > 1 px; "
                  "border strips %.1f %% outliers of %.0f\n",
                  preset, seam, near_border, wrong, 100 * strips.rate(), strips.estimates);
      EXPECT_GT(near_border, 0);
      EXPECT_EQ(wrong, 0);
      EXPECT_EQ(strips.outliers, 0);
      EXPECT_GT(strips.estimates, 0);
    }
  }
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
  const MatcherParams params = cuesProductParams();
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

}  // namespace
