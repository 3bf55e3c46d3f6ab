// The patch search of one level (inverse_search.hpp), on its own: the second
// look one level coarser that a patch without evidence gets at the finest
// level (docs/method.md, "A second look one level coarser"), and the support
// weights that let a patch beside a depth edge match its centre's surface
// ("Support weights").
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "bdis_stereo/params.hpp"
#include "inverse_search.hpp"
#include "pyramid.hpp"

namespace {

using bdis::detail::PatchEstimate;
using bdis::detail::PatchSearch;
using bdis::detail::PyramidLevel;
using bdis::detail::StereoPyramid;

constexpr int kW = 320, kH = 240;
constexpr int kDisparity = 8;  // input px; 4 at level 1
constexpr int kStride = 3;

/// Dark tissue, with little signal for an 8 px patch at level 1: a texture of
/// `texture_grey` (standard deviation) that varies over about 10 input px,
/// under a sensor noise of `noise_grey` of its own in each view, in 8-bit
/// grey levels. The right view is the left shifted by kDisparity.
std::pair<cv::Mat, cv::Mat> weakTexturePair(double texture_grey, double noise_grey) {
  cv::RNG rng(11);
  cv::Mat1f field(kH, kW + kDisparity);
  rng.fill(field, cv::RNG::NORMAL, 0.0, 1.0);
  cv::GaussianBlur(field, field, cv::Size(0, 0), 4.0);
  cv::Scalar mean, stddev;
  cv::meanStdDev(field, mean, stddev);
  field = (field - mean[0]) * (texture_grey / stddev[0]) + 60.0;
  // left(x) = right(x - d)
  cv::Mat1f left = field.colRange(0, kW).clone();
  cv::Mat1f right = field.colRange(kDisparity, kW + kDisparity).clone();
  cv::Mat1f noise(kH, kW);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, noise_grey);
  left += noise;
  rng.fill(noise, cv::RNG::NORMAL, 0.0, noise_grey);
  right += noise;
  cv::Mat left8, right8;
  left.convertTo(left8, CV_8U);
  right.convertTo(right8, CV_8U);
  return {left8, right8};
}

struct SearchResult {
  int patches = 0;
  int with_evidence = 0;   // evidence >= 0.05
  int right = 0;           // ... and within 0.5 level px of the truth
  std::vector<PatchEstimate> estimates;
};

/// Level 1 of the pair searched from `coarse` (level 2's disparity), with or
/// without the second look on level 2.
SearchResult searchLevel1(const StereoPyramid& pyramid, const cv::Mat1f& coarse, bool second_look,
                          float max_change_level_px) {
  const bdis::MatcherParams params;
  PatchSearch search;
  search.configure(params);
  const PyramidLevel& L = pyramid.level(1);
  search.allocate(L.width);
  search.beginLevel(L, kStride, second_look ? &pyramid.level(2) : nullptr, max_change_level_px);
  search.searchBand(L, coarse, 0, search.grid().rows());
  SearchResult r;
  r.estimates = search.estimates();
  r.estimates.resize(search.grid().size());
  const float truth = 0.5f * kDisparity;
  for (const PatchEstimate& e : r.estimates) {
    ++r.patches;
    if (e.evidence < 0.05f) continue;
    ++r.with_evidence;
    if (std::fabs(e.disparity - truth) <= 0.5f) ++r.right;
  }
  return r;
}

// Measured (texture and noise of 0.7 grey levels): without the second look
// 391 of the 2028 patches stay below an evidence of 0.05 and 1364 are
// within 0.5 level px of the truth; with it 62 and 1697, and the share of
// right ones among those with evidence rises from 83.3 % to 86.3 %. (With a
// texture of 1 grey level, 1968 of them clear 0.05 on their own.)
TEST(CoarserLook, GivesPatchesWithoutSignalAnEstimateFromTwiceTheFootprint) {
  const auto [left, right] = weakTexturePair(0.7, 0.7);
  StereoPyramid pyramid;
  pyramid.build(left, right, 4, 1);
  const cv::Mat1f coarse(pyramid.level(2).height, pyramid.level(2).width, 0.25f * kDisparity);
  const SearchResult alone = searchLevel1(pyramid, coarse, false, 1.f);
  const SearchResult looked = searchLevel1(pyramid, coarse, true, 1.f);
  std::printf("[measured] with evidence: %d / %d patches alone, %d with the second look; "
              "within 0.5 px: %.1f %% / %.1f %%\n",
              alone.with_evidence, alone.patches, looked.with_evidence,
              100.0 * alone.right / std::max(1, alone.with_evidence),
              100.0 * looked.right / std::max(1, looked.with_evidence));
  const int alone_without = alone.patches - alone.with_evidence;
  const int looked_without = looked.patches - looked.with_evidence;
  EXPECT_GT(alone_without, alone.patches / 10);
  EXPECT_LT(looked_without, alone_without / 3);
  EXPECT_GT(looked.right, 1.2 * alone.right);
  EXPECT_GE(static_cast<double>(looked.right) / looked.with_evidence,
            static_cast<double>(alone.right) / alone.with_evidence);
}

// Where the coarser disparity changes by more than the limit across the
// doubled footprint (slanted tissue, a depth edge), nothing changes.
TEST(CoarserLook, StaysOffWhereTheCoarserDisparityChangesAcrossTheFootprint) {
  const auto [left, right] = weakTexturePair(0.7, 0.7);
  StereoPyramid pyramid;
  pyramid.build(left, right, 4, 1);
  // A ramp of 0.1 per level-2 px: 1.6 level-1 px across a doubled 8 px
  // footprint (16 px), above a limit of 1 level px.
  cv::Mat1f coarse(pyramid.level(2).height, pyramid.level(2).width);
  for (int y = 0; y < coarse.rows; ++y) {
    for (int x = 0; x < coarse.cols; ++x) coarse(y, x) = 0.25f * kDisparity + 0.1f * static_cast<float>(x - coarse.cols / 2);
  }
  const SearchResult alone = searchLevel1(pyramid, coarse, false, 1.f);
  const SearchResult gated = searchLevel1(pyramid, coarse, true, 1.f);
  ASSERT_EQ(alone.estimates.size(), gated.estimates.size());
  for (size_t k = 0; k < alone.estimates.size(); ++k) {
    EXPECT_EQ(gated.estimates[k].disparity, alone.estimates[k].disparity) << "patch " << k;
    EXPECT_EQ(gated.estimates[k].evidence, alone.estimates[k].evidence) << "patch " << k;
  }
  // The same ramp under a limit of 2 level px: the second look runs.
  const SearchResult open = searchLevel1(pyramid, coarse, true, 2.f);
  EXPECT_GT(open.with_evidence, alone.with_evidence);
}

/// Level L searched whole from `coarse` with `params`, support weights of
/// `support_grey` (0: none) and the parameters' edge test.
PatchSearch searchWithSupportWeights(const PyramidLevel& L, const cv::Mat1f& coarse, const bdis::MatcherParams& params,
                                     float support_grey) {
  PatchSearch s;
  s.configure(params);
  s.allocate(L.width);
  s.beginLevel(L, kStride, nullptr, 0.f, support_grey, params.support_edge_grey);
  s.searchBand(L, coarse, 0, s.grid().rows());
  return s;
}

/// A textured background at `kBackground` px and, in front of it, a brighter
/// textured strip (input columns 150-229 of the left view) at `kForeground`
/// px; the right view drawn back to front, so the strip hides what lies
/// behind it there. Grey levels: the background's and the strip's means and
/// their texture's standard deviation.
constexpr int kBackground = 4, kForeground = 24;
constexpr int kStripBegin = 150, kStripEnd = 230;
std::pair<cv::Mat, cv::Mat> stripInFrontPair(double background_grey = 60.0, double strip_grey = 170.0,
                                             double spread = 6.0) {
  cv::RNG rng(3);
  auto texture = [&](double grey, double spread) {
    cv::Mat1f t(kH, 2 * kW);
    rng.fill(t, cv::RNG::NORMAL, 0.0, 1.0);
    cv::GaussianBlur(t, t, cv::Size(0, 0), 1.5);
    cv::Scalar mean, stddev;
    cv::meanStdDev(t, mean, stddev);
    return cv::Mat1f((t - mean[0]) * (spread / stddev[0]) + grey);
  };
  const cv::Mat1f background = texture(background_grey, spread), strip = texture(strip_grey, spread);
  cv::Mat1f left(kH, kW), right(kH, kW);
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) {
      const bool on_strip = x >= kStripBegin && x < kStripEnd;
      left(y, x) = on_strip ? strip(y, x + kW / 2) : background(y, x + kW / 2);
      // Right pixel xr sees the strip if xr + kForeground lies on it in the left view.
      const int xl_strip = x + kForeground;
      right(y, x) = xl_strip >= kStripBegin && xl_strip < kStripEnd ? strip(y, xl_strip + kW / 2)
                                                                      : background(y, x + kBackground + kW / 2);
    }
  }
  cv::Mat left8, right8;
  left.convertTo(left8, CV_8U);
  right.convertTo(right8, CV_8U);
  return {left8, right8};
}

/// Patches near the strip's right edge (centres 0.5-3.5 level px right of
/// it: 1-4 of the footprint's 8 columns on the strip) and away from it
/// (10-40 px), searched plain and with the default support weights from the
/// truth one level coarser: how many end within 0.5 level px of the
/// background's disparity, and how many are wrong with evidence >= 0.05.
struct StripEdgeTally {
  int patches = 0, right = 0, wrong_with_evidence = 0;
};
struct StripEdgeSearch {
  StripEdgeTally plain_near, weighted_near, plain_far, weighted_far;
};
StripEdgeSearch searchBesideTheStripEdge(const std::pair<cv::Mat, cv::Mat>& pair) {
  StereoPyramid pyramid;
  pyramid.build(pair.first, pair.second, 4, 1);
  const PyramidLevel& L = pyramid.level(1);
  // Start from the truth at level 2 (scale 1/4): the search alone decides.
  cv::Mat1f coarse(pyramid.level(2).height, pyramid.level(2).width, 0.25f * kBackground);
  coarse.colRange(kStripBegin / 4, kStripEnd / 4).setTo(0.25f * kForeground);
  const bdis::MatcherParams params;
  const PatchSearch plain = searchWithSupportWeights(L, coarse, params, 0.f);
  const PatchSearch weighted = searchWithSupportWeights(L, coarse, params, params.support_grey);
  const float background = 0.5f * kBackground, edge = 0.5f * kStripEnd;  // level 1
  auto tally = [&](const PatchSearch& s, float from, float to) {
    StripEdgeTally t;
    for (int iy = 0; iy < s.grid().rows(); ++iy) {
      for (int ix = 0; ix < s.grid().columns(); ++ix) {
        const float centre =
            static_cast<float>(s.grid().xs[static_cast<size_t>(ix)]) + 0.5f * static_cast<float>(params.patch_size - 1);
        if (centre - edge < from || centre - edge >= to) continue;
        const PatchEstimate& e = s.estimates()[static_cast<size_t>(iy * s.grid().columns() + ix)];
        ++t.patches;
        const bool right_one = std::fabs(e.disparity - background) <= 0.5f;
        if (right_one) ++t.right;
        if (!right_one && e.evidence >= 0.05f) ++t.wrong_with_evidence;
      }
    }
    return t;
  };
  return {tally(plain, 0.5f, 3.5f), tally(weighted, 0.5f, 3.5f), tally(plain, 10.f, 40.f),
          tally(weighted, 10.f, 40.f)};
}

void printStripEdgeSearch(const StripEdgeSearch& r) {
  std::printf("[measured] beside the edge (%d patches): right %d plain / %d weighted, wrong with evidence %d / %d; "
              "away from it (%d): right %d / %d\n",
              r.plain_near.patches, r.plain_near.right, r.weighted_near.right, r.plain_near.wrong_with_evidence,
              r.weighted_near.wrong_with_evidence, r.plain_far.patches, r.plain_far.right, r.weighted_far.right);
}

// Patches whose centre lies on the background, but whose footprint reaches
// the strip's right edge (the side both views see): without support weights
// the strip's edge pulls them to its disparity, and the posterior, which
// sees that edge match, lets them through; with the weights they match the
// background their centre sees (and the posterior, on the plain cost, where
// the strip's edge still mismatches, gives them little say). Measured: of
// 39 patches beside the edge, 0 plain / 34 weighted within 0.5 level px of
// the background's disparity; wrong with evidence 39 / 5 (those at the edge
// itself, whose centre's side covers less than half the patch, keep the
// plain search); away from the edge 390 of 390 right either way. (37 and 2
// before the weights' grey levels scaled with a centre darker than 64: the
// background's 60 takes 0.94 of them.)
TEST(SupportWeights, PatchesBesideADepthEdgeMatchTheSurfaceOfTheirCentre) {
  ASSERT_GT(bdis::MatcherParams().support_grey, 0.f);
  const StripEdgeSearch r = searchBesideTheStripEdge(stripInFrontPair());
  printStripEdgeSearch(r);
  ASSERT_GT(r.plain_near.patches, 30);
  EXPECT_GE(r.weighted_near.right, r.plain_near.right + r.plain_near.patches * 3 / 4);
  EXPECT_GT(r.plain_near.wrong_with_evidence, r.plain_near.patches / 2);
  EXPECT_LE(r.weighted_near.wrong_with_evidence, r.plain_near.wrong_with_evidence / 4);
  EXPECT_EQ(r.weighted_far.right, r.weighted_far.patches);
  EXPECT_EQ(r.plain_far.right, r.plain_far.patches);
}

// The same scene in the dark, as an instrument beside dark tissue: the
// background at 12 grey levels, the strip at 28, texture 2. The edge is 16
// grey levels, below the 24 the edge test asks of a lit patch; scaled with
// the centre's grey level (a quarter at 12: 6, and the weights' 8 to 2) it
// is an edge, and the patches beside it match the background. With the
// thresholds the lit patches take, none would take the weights and the
// weighted search would be the plain one (0 of 39 right, as plain). Measured: 0 plain / 29
// weighted right, wrong with evidence 39 / 10; away from the edge 390 of 390 right either way.
TEST(SupportWeights, InTheDarkPatchesBesideADepthEdgeStillMatchTheirCentre) {
  const StripEdgeSearch r = searchBesideTheStripEdge(stripInFrontPair(12.0, 28.0, 2.0));
  printStripEdgeSearch(r);
  ASSERT_GT(r.plain_near.patches, 30);
  EXPECT_GT(r.plain_near.wrong_with_evidence, r.plain_near.patches / 2);
  EXPECT_GE(r.weighted_near.right, r.plain_near.right + r.plain_near.patches / 2);
  EXPECT_LE(r.weighted_near.wrong_with_evidence, r.plain_near.wrong_with_evidence / 2);
}

// The weights cost a pass over the template and weighted sums, and change
// little where no pixel strays far from the centre's grey level: a patch
// whose pixels all lie within support_edge_grey of it keeps the plain
// search, bit for bit. On weak texture (3 grey levels, so no pixel strays
// 22.5 from its centre, the edge test at its grey level of 60) every estimate equals the plain one; on strong
// texture (20 grey levels) patches with an edge take the weights and their
// estimates move, those centred on one side of it (a random texture's peaks
// and pits, whose centre's surface covers less than half the patch, stay
// plain). Measured: 0 of 2028 estimates changed on the weak texture, 375
// on the strong one (1824 before the thin structures' rule, 475 before the
// grey levels scaled with a centre darker than 64: the texture sits at 60).
TEST(SupportWeights, OnlyPatchesThatSpanAnEdgeTakeThem) {
  const bdis::MatcherParams defaults;
  ASSERT_GT(defaults.support_grey, 0.f);
  ASSERT_GE(defaults.support_edge_grey, 20.f);  // above the weak texture's strays (about 18 at most)
  auto changed = [&](double texture_grey) {
    const auto [left, right] = weakTexturePair(texture_grey, 0.7);
    StereoPyramid pyramid;
    pyramid.build(left, right, 4, 1);
    const PyramidLevel& L = pyramid.level(1);
    const cv::Mat1f coarse(pyramid.level(2).height, pyramid.level(2).width, 0.25f * kDisparity);
    auto search = [&](float grey) {
      const PatchSearch s = searchWithSupportWeights(L, coarse, defaults, grey);
      std::vector<PatchEstimate> e = s.estimates();
      e.resize(s.grid().size());
      return e;
    };
    const std::vector<PatchEstimate> plain = search(0.f), weighted = search(defaults.support_grey);
    int n = 0;
    for (size_t k = 0; k < plain.size(); ++k) {
      if (plain[k].disparity != weighted[k].disparity || plain[k].posterior != weighted[k].posterior ||
          plain[k].evidence != weighted[k].evidence)
        ++n;
    }
    return std::make_pair(n, static_cast<int>(plain.size()));
  };
  const auto [weak_changed, weak_patches] = changed(3.0);
  const auto [strong_changed, strong_patches] = changed(20.0);
  std::printf("[measured] estimates changed by the support weights: %d of %d on weak texture, %d of %d on strong\n",
              weak_changed, weak_patches, strong_changed, strong_patches);
  ASSERT_GT(weak_patches, 1000);
  EXPECT_EQ(weak_changed, 0);
  EXPECT_GT(strong_changed, strong_patches / 8);
}

}  // namespace
