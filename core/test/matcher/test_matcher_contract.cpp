// The matcher's contract: output sizes, types and ranges at odd sizes and
// extreme parameters, input validation, mono and BGR, reuse of a matcher and
// its buffers, and agreement of the SIMD kernels with the scalar ones.
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

#include "bdis_stereo/matcher.hpp"
#include "patch_kernels.hpp"
#include "matcher_test_util.hpp"
#include "test_images.hpp"

using namespace matcher_test;

namespace {

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

// With two_scales the coarser result is brought to the finest level and
// chosen from there: odd sizes (levels not exactly half the next), tiny ones
// and HD, where the patch shrinks with the width but not in the coarser
// search, which sets its finest level.
TEST(MatcherOutputs, TwoScalesKeepTheOutputContractAtOddSizesAndInHd) {
  const cv::Size sizes[] = {{33, 47}, {161, 121}, {641, 479}, {1920, 1080}};
  MatcherParams params;
  params.two_scales = true;
  MatcherParams one_scale = params;
  one_scale.two_scales = false;
  for (const bool variance : {false, true}) {
    params.compute_variance = one_scale.compute_variance = variance;
    Matcher matcher(params);
    for (const cv::Size& size : sizes) {
      SCOPED_TRACE(std::to_string(size.width) + "x" + std::to_string(size.height) +
                   (variance ? " with variance" : ""));
      const double d = size.width >= 160 ? 7.3 : 3.3;
      const StereoPair pair = texturedPair(size.width, size.height, {d, 0.0});
      MatchResult r;
      matcher.compute(pair.left, pair.right, r);
      expectValidResult(r, size, variance);
      // No hole is filled, and on one textured plane the choice is as good
      // as the finer scale alone (at HD both are 0.2 px off at the median:
      // the texture is finer than the level-3 patches).
      const MatchResult single = run(one_scale, pair.left, pair.right);
      EXPECT_EQ(density(r.disparity), density(single.disparity));
      EXPECT_GT(density(r.disparity), 0.5);
      if (size.width >= 160) {
        const cv::Rect inner = interior(size.width, size.height, accuracyMargin(params), 8);
        EXPECT_LT(errorStats(r.disparity, pair.gt, inner).median,
                  errorStats(single.disparity, pair.gt, inner).median + 0.01);
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
  all.push_back(with([](MatcherParams& p) { p.two_scales = true, p.min_confidence = 0.5f; }));
  all.push_back(with([](MatcherParams& p) { p.two_scales = true, p.coarsest_level = 1, p.finest_level = 1; }));
  for (size_t i = 0; i < all.size(); ++i) {
    SCOPED_TRACE("parameter set " + std::to_string(i) + ":\n" + bdis::toYaml(all[i]));
    for (bool variance : {false, true}) {
      all[i].compute_variance = variance;
      const MatchResult r = run(all[i], pair.left, pair.right);
      expectValidResult(r, pair.left.size(), variance);
    }
  }
  // The confidence floor gates on the covering patches' mean evidence, which
  // the published confidence never exceeds: a higher floor never adds
  // estimates, and every estimate's confidence stays in (0, 1].
  double previous_density = 1.0;
  for (float floor : {0.f, 0.3f, 0.6f, 0.9f, 1.f}) {
    SCOPED_TRACE("confidence_floor = " + std::to_string(floor));
    MatcherParams p;
    p.confidence_floor = floor;
    const MatchResult r = run(p, pair.left, pair.right);
    const cv::Mat estimated = r.disparity >= 0.f;
    double min_conf = 1.0, max_conf = 0.0;
    if (cv::countNonZero(estimated) > 0) cv::minMaxLoc(r.confidence, &min_conf, &max_conf, nullptr, nullptr, estimated);
    EXPECT_LE(max_conf, 1.0);
    if (floor > 0.f && cv::countNonZero(estimated) > 0) {
      EXPECT_GT(min_conf, 0.0);
    }
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
  // Without the dark floor only the latter are outside the view and get no
  // estimate; with the default floor the dark ones are left out too.
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
    MatcherParams no_floor;
    no_floor.dark_floor_grey = 0;
    const MatchResult r = run(no_floor, left, bgr_r);
    const MatchResult with_floor = run(MatcherParams{}, left, bgr_r);
    int estimated_with_floor = 0;
    for (int y = margin; y < kH - margin; y += 7) {
      for (int x = margin; x < kW - margin; x += 7) {
        estimated += r.disparity.at<float>(y, x) >= 0.f;
        estimated_with_floor += with_floor.disparity.at<float>(y, x) >= 0.f;
      }
    }
    if (black) {
      EXPECT_EQ(estimated, 0);
    } else {
      EXPECT_GE(estimated, 0.95 * markers);
    }
    EXPECT_EQ(estimated_with_floor, 0);
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

/// One matcher fed a, b, a, b gives each time what a fresh matcher gives.
void expectAlternatingPairsGiveFreshResults(const MatcherParams& params, const StereoPair& a, const StereoPair& b) {
  const MatchResult fresh_a = run(params, a.left, a.right);
  const MatchResult fresh_b = run(params, b.left, b.right);
  Matcher m(params);
  MatchResult r;
  for (const StereoPair* pair : {&a, &b, &a, &b}) {
    m.compute(pair->left, pair->right, r);
    const MatchResult& fresh = pair == &a ? fresh_a : fresh_b;
    EXPECT_TRUE(identical(r.disparity, fresh.disparity));
    EXPECT_TRUE(identical(r.confidence, fresh.confidence));
    EXPECT_TRUE(identical(r.variance, fresh.variance));
  }
}

/// A textured pair with invalid pixels: a clipped blob at different places
/// in the two views and a black border down the right view's right side.
StereoPair pairWithClippedBlobAndBlackBorder(unsigned seed) {
  StereoPair pair = texturedPair(kW, kH, {7.3, 0.0}, seed);
  pair.left(cv::Rect(kW / 3, kH / 4, kW / 5, kH / 3)).setTo(255);
  pair.right(cv::Rect(kW / 3 - 20, kH / 4 + 8, kW / 5, kH / 3)).setTo(255);
  pair.right.colRange(kW - 25, kW).setTo(0);
  return pair;
}

// The search keeps the validity of each patch row's band for its backward
// pass: frames whose invalid pixels (black borders, clipped highlights) lie
// elsewhere, one after the other, each give a fresh matcher's result.
TEST(MatcherReuse, FramesWithInvalidPixelsElsewhereGiveFreshResults) {
  MatcherParams params;
  params.compute_variance = true;
  StereoPair a = texturedPair(kW, kH, {7.3, 0.0}, 4);
  const StereoPair b = pairWithClippedBlobAndBlackBorder(5);
  a.left.colRange(0, 30).setTo(0);
  a.right.colRange(0, 30).setTo(0);
  expectAlternatingPairsGiveFreshResults(params, a, b);
}

// Parameters changed on a matcher between frames take effect as in a fresh
// matcher: here the search's band height, which sizes the validity bands
// the search keeps (larger, smaller, the whole level, back to the default),
// on a pair with invalid pixels.
TEST(MatcherReuse, BandHeightChangedBetweenFramesGivesFreshResults) {
  const StereoPair pair = pairWithClippedBlobAndBlackBorder(6);
  Matcher m{MatcherParams{}};
  MatchResult r;
  m.compute(pair.left, pair.right, r);
  for (const int band_rows : {24, 2, 0, MatcherParams{}.search_band_rows}) {
    SCOPED_TRACE("search_band_rows " + std::to_string(band_rows));
    MatcherParams params;
    params.search_band_rows = band_rows;
    m.setParams(params);
    m.compute(pair.left, pair.right, r);
    const MatchResult fresh = run(params, pair.left, pair.right);
    EXPECT_TRUE(identical(r.disparity, fresh.disparity));
    EXPECT_TRUE(identical(r.confidence, fresh.confidence));
  }
}

// A 1920 px frame is searched with a smaller patch than a 640 px one
// (MatcherParams::patchSizeFor): one matcher switched between the two gives
// what a fresh matcher gives, and the HD result is the one of that patch size
// (at the stride of the patch as set) set explicitly.
TEST(MatcherReuse, WidthsOfDifferentPatchSizesInterleave) {
  const MatcherParams params;
  ASSERT_EQ(params.patchSizeFor(640), params.patch_size);
  ASSERT_LT(params.patchSizeFor(1920), params.patch_size);
  const StereoPair sd = texturedPair(640, 480, {20.0, 0.0}, 1);
  const StereoPair hd = texturedPair(1920, 1080, {60.0, 0.0}, 2);
  const MatchResult fresh_hd = run(params, hd.left, hd.right);
  expectAlternatingPairsGiveFreshResults(params, sd, hd);
  Matcher m(params);
  MatchResult r;
  m.compute(hd.left, hd.right, r);
  EXPECT_EQ(m.params().patch_size, params.patch_size) << "the parameters as set are reported";

  MatcherParams explicit_hd = params;
  explicit_hd.finest_level = params.finestLevelFor(1920);
  explicit_hd.patch_size = params.patchSizeFor(1920);
  explicit_hd.lr_check_tolerance = params.checkToleranceFor(1920);
  explicit_hd.overlap = 0.5f;  // 6 px patches at the 8 px patches' stride of 3
  EXPECT_TRUE(identical(run(explicit_hd, hd.left, hd.right).disparity, fresh_hd.disparity));
}

// A node computes only the subscribed maps: the ones left out come back
// empty, the others as with every map, on one matcher switched between frames
// (an output width that is a power-of-two multiple of the level's and one
// that is not take different upsampling paths).
TEST(MatcherReuse, MapsLeftOutAreEmptyAndTheOthersUnchanged) {
  MatcherParams params;
  params.compute_variance = true;
  for (const cv::Size size : {cv::Size(kW, kH), cv::Size(641, 479)}) {
    SCOPED_TRACE(std::to_string(size.width) + "x" + std::to_string(size.height));
    const StereoPair pair = texturedPair(size.width, size.height, {7.3, 0.0}, 3);
    const MatchResult all = run(params, pair.left, pair.right);
    Matcher m(params);
    MatchResult r;
    for (const bool confidence : {false, true, false}) {
      for (const bool variance : {false, true}) {
        SCOPED_TRACE(std::string(confidence ? "confidence" : "no confidence") +
                     (variance ? ", variance" : ", no variance"));
        bdis::MatchOutputs maps;
        maps.confidence = confidence;
        maps.variance = variance;
        m.compute(pair.left, pair.right, r, maps);
        EXPECT_TRUE(identical(r.disparity, all.disparity));
        EXPECT_EQ(r.confidence.empty(), !confidence);
        if (confidence) {
          EXPECT_TRUE(identical(r.confidence, all.confidence));
        }
        EXPECT_EQ(r.variance.empty(), !variance);
        if (variance) {
          EXPECT_TRUE(identical(r.variance, all.variance));
        }
      }
    }
  }
}

// min_confidence keeps exactly the estimates whose confidence reaches it,
// with the disparity, confidence and variance they have without it, and
// drops the others (no estimate, confidence 0, variance NaN); it decides
// whether the confidence is asked for or not, so it is filled either way.
TEST(MatcherOutputs, MinConfidenceDropsExactlyTheLessConfidentEstimates) {
  // With two_scales too: the threshold applies to the chosen estimates.
  for (const bool two_scales : {false, true}) {
    SCOPED_TRACE(two_scales ? "two_scales" : "one scale");
    MatcherParams params;
    params.compute_variance = true;
    params.two_scales = two_scales;
    const StereoPair pair = texturedPair(kW, kH, {7.3, 0.0}, 3);
    const MatchResult all = run(params, pair.left, pair.right);
    // Thresholds at a quarter, half and three quarters of the estimates.
    std::vector<float> confidences;
    for (int y = 0; y < kH; ++y) {
      for (int x = 0; x < kW; ++x) {
        if (all.disparity.at<float>(y, x) != bdis::kNoDisparity) confidences.push_back(all.confidence.at<float>(y, x));
      }
    }
    std::sort(confidences.begin(), confidences.end());
    ASSERT_GT(confidences.size(), 1000u);
    for (const size_t quarter : {1, 2, 3}) {
      const float threshold = confidences[quarter * confidences.size() / 4];
      params.min_confidence = threshold;
      Matcher m(params);
      for (const bool confidence : {true, false}) {
        SCOPED_TRACE("min_confidence " + std::to_string(threshold) + (confidence ? "" : ", confidence not asked for"));
        MatchResult r;
        m.compute(pair.left, pair.right, r, bdis::MatchOutputs{confidence, true});
        ASSERT_FALSE(r.confidence.empty());
        int kept = 0, dropped = 0, wrong = 0;
        for (int y = 0; y < kH; ++y) {
          for (int x = 0; x < kW; ++x) {
            const float d = r.disparity.at<float>(y, x), c = r.confidence.at<float>(y, x);
            const float v = r.variance.at<float>(y, x);
            if (all.disparity.at<float>(y, x) == bdis::kNoDisparity) {
              wrong += d != bdis::kNoDisparity;
            } else if (all.confidence.at<float>(y, x) >= threshold) {
              ++kept;
              wrong += d != all.disparity.at<float>(y, x) || c != all.confidence.at<float>(y, x) ||
                       v != all.variance.at<float>(y, x);
            } else {
              ++dropped;
              wrong += d != bdis::kNoDisparity || c != 0.f || !std::isnan(v);
            }
          }
        }
        EXPECT_EQ(wrong, 0);
        // Both sides are exercised (not a quarter each: estimates of equal
        // confidence, the calibrated confidence's steps near 1, go together).
        EXPECT_GT(kept, 0);
        EXPECT_GT(dropped, 0);
      }
    }
  }
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

// ---------------------------------------------------------------------------
// 9. SIMD and scalar kernels give the same matcher output.
// BDIS_SIMD=off forces the scalar kernels, =baseline the SSE2/NEON ones. Float
// sums in another order move a cost by ~1e-6 relative, which can tip a rare
// discrete decision (a propagation candidate, the local-minimum test). Measured on the scene below:
// all pixels agree on having an estimate or not; largest disparity difference
// 6.2e-4 px (AVX2) and 1.6e-4 px (SSE2).
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

}  // namespace
