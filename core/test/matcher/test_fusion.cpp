// Fusion (fusion.hpp) of hand-made patch estimates on small levels.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "bdis_stereo/matcher.hpp"
#include "confidence.hpp"
#include "fusion.hpp"

namespace {

using bdis::kNoDisparity;
using bdis::detail::Fusion;
using bdis::detail::LevelMaps;
using bdis::detail::PatchEstimate;
using bdis::detail::PatchGrid;
using bdis::detail::kSpreadVarianceShare;
using bdis::detail::kWindowVarianceShare;

constexpr float kSigmaS = 2.f;

/// The spatial weight of patch-local pixel (x, y) in a p x p patch.
float spatial(int p, int x, int y) {
  const float c = 0.5f * static_cast<float>(p - 1);
  return std::exp(-((x - c) * (x - c) + (y - c) * (y - c)) / (2.f * kSigmaS * kSigmaS));
}

struct Level {
  PatchGrid grid;
  std::vector<PatchEstimate> estimates;
  LevelMaps maps;
};

Level fused(int width, int height, int p, int stride, std::vector<PatchEstimate> estimates,
            float confidence_floor = 0.f, bool variance = false, int band_rows = 0,
            float coarse_value = 0.f) {
  Level l;
  l.grid.layout(width, height, p, stride);
  l.estimates = std::move(estimates);
  EXPECT_EQ(l.estimates.size(), l.grid.size());
  Fusion f;
  f.configure(bdis::detail::kernelsFor(p, bdis::detail::KernelIsa::Scalar), p, kSigmaS, confidence_floor, 16.f);
  f.allocate(band_rows > 0 ? band_rows : height, width, height, variance);
  l.maps.disparity.create(height, width);
  l.maps.confidence.create(height, width);
  if (variance) l.maps.variance.create(height, width);
  const cv::Mat1f coarse(height / 2 + 1, width / 2 + 1, coarse_value);
  f.fuseFinest(l.grid, l.estimates, width, height, coarse, /*spread_halving=*/1e6f, true, variance, l.maps);
  return l;
}

TEST(Fusion, OnePatchGivesItsDisparityAndEvidenceEverywhereItCovers) {
  // One 4x4 patch on a 4x4 level: every pixel has exactly this patch.
  const Level l = fused(4, 4, 4, 4, {{3.5f, 0.5f, 0.8f, 0.f}});
  for (int y = 0; y < 4; ++y) {
    for (int x = 0; x < 4; ++x) {
      EXPECT_FLOAT_EQ(l.maps.disparity(y, x), 3.5f);
      EXPECT_FLOAT_EQ(l.maps.confidence(y, x), 0.8f);
    }
  }
}

TEST(Fusion, OverlappingPatchesAverageByPosteriorTimesSpatialWeight) {
  // Two 4x4 patches at x = 0 and 2 on a 6x4 level. Column 2 is patch-local
  // column 2 of the first and column 0 of the second.
  const PatchEstimate a{2.f, 1.f, 0.6f, 0.f}, b{4.f, 0.5f, 0.2f, 0.f};
  const Level l = fused(6, 4, 4, 2, {a, b});
  ASSERT_EQ(l.grid.xs, (std::vector<int>{0, 2}));
  for (int y = 0; y < 4; ++y) {
    const float wa = a.posterior * spatial(4, 2, y), wb = b.posterior * spatial(4, 0, y);
    EXPECT_NEAR(l.maps.disparity(y, 2), (wa * 2.f + wb * 4.f) / (wa + wb), 1e-5f);
    // Confidence: the mean evidence of the covering patches.
    EXPECT_FLOAT_EQ(l.maps.confidence(y, 2), (0.6f + 0.2f) / 2.f);
    // Columns 0-1 only a, 4-5 only b.
    EXPECT_FLOAT_EQ(l.maps.disparity(y, 1), 2.f);
    EXPECT_FLOAT_EQ(l.maps.disparity(y, 5), 4.f);
    EXPECT_FLOAT_EQ(l.maps.confidence(y, 5), 0.2f);
  }
}

TEST(Fusion, DiscardedPatchesWeighNothingButCountInTheConfidence) {
  const PatchEstimate kept{2.f, 1.f, 0.6f, 0.f}, discarded{9.f, 0.f, 0.f, 0.f};
  const Level l = fused(6, 4, 4, 2, {kept, discarded});
  // Column 2: both cover it, only `kept` weighs; confidence (0.6 + 0) / 2.
  EXPECT_FLOAT_EQ(l.maps.disparity(1, 2), 2.f);
  EXPECT_FLOAT_EQ(l.maps.confidence(1, 2), 0.3f);
  // Column 5: only the discarded patch covers it: no estimate, confidence 0.
  EXPECT_EQ(l.maps.disparity(1, 5), kNoDisparity);
  EXPECT_EQ(l.maps.confidence(1, 5), 0.f);
}

TEST(Fusion, DisagreeingPatchesLowerTheConfidence) {
  // Two patches of equal evidence over one column: where they agree the
  // confidence is their evidence; 2 px apart (a spread of about 1 px) it is
  // about halved at a halving of 1 px. The floor still gates on the evidence.
  const PatchEstimate a{5.f, 1.f, 0.8f, 0.f};
  for (const float other : {5.f, 7.f, 15.f}) {
    const PatchEstimate b{other, 1.f, 0.8f, 0.f};
    Level l;
    l.grid.layout(6, 4, 4, 2);
    l.estimates = {a, b};
    Fusion f;
    f.configure(bdis::detail::kernelsFor(4, bdis::detail::KernelIsa::Scalar), 4, kSigmaS, 0.5f, 16.f);
    f.allocate(4, 6, 4, false);
    l.maps.disparity.create(4, 6);
    l.maps.confidence.create(4, 6);
    f.fuseFinest(l.grid, l.estimates, 6, 4, cv::Mat1f(3, 4, 0.f), /*spread_halving=*/1.f, true, false, l.maps);
    const float wa = spatial(4, 2, 1), wb = spatial(4, 0, 1);
    const float d = (wa * 5.f + wb * other) / (wa + wb);
    const float spread_sq = (wa * (5.f - d) * (5.f - d) + wb * (other - d) * (other - d)) / (wa + wb);
    EXPECT_NEAR(l.maps.confidence(1, 2), 0.8f / (1.f + spread_sq), 1e-4f) << other;
    EXPECT_GE(l.maps.disparity(1, 2), 0.f) << "evidence 0.8 passes the floor of 0.5: " << other;
    EXPECT_FLOAT_EQ(l.maps.confidence(1, 0), 0.8f);  // one patch only: no spread
  }
}

TEST(Fusion, ConfidenceFloorDropsTheEstimate) {
  const Level l = fused(4, 4, 4, 4, {{3.f, 0.5f, 0.1f, 0.f}}, /*confidence_floor=*/0.2f);
  EXPECT_EQ(l.maps.disparity(2, 2), kNoDisparity);
  EXPECT_EQ(l.maps.confidence(2, 2), 0.f);
  const Level kept = fused(4, 4, 4, 4, {{3.f, 0.5f, 0.2f, 0.f}}, 0.2f);
  EXPECT_FLOAT_EQ(kept.maps.disparity(2, 2), 3.f);
}

TEST(Fusion, VarianceIsTheWindowFitsShareAndTheSpread) {
  // A share of the squared-weight average of the patches' window variances,
  // plus a share of the squared spread of their disparities around the fused one.
  const PatchEstimate a{2.f, 1.f, 0.6f, 1.f}, b{4.f, 0.5f, 0.2f, 3.f};
  const Level l = fused(6, 4, 4, 2, {a, b}, 0.f, /*variance=*/true);
  for (int y = 0; y < 4; ++y) {
    const float wa = a.posterior * spatial(4, 2, y), wb = b.posterior * spatial(4, 0, y);
    const float window = (wa * wa * 1.f + wb * wb * 3.f) / (wa * wa + wb * wb);
    const float fused_d = (wa * 2.f + wb * 4.f) / (wa + wb);
    const float spread_sq = (wa * (2.f - fused_d) * (2.f - fused_d) + wb * (4.f - fused_d) * (4.f - fused_d)) / (wa + wb);
    EXPECT_NEAR(l.maps.variance(y, 2), kWindowVarianceShare * window + kSpreadVarianceShare * spread_sq, 1e-4f);
    // One patch: no spread.
    EXPECT_FLOAT_EQ(l.maps.variance(y, 0), kWindowVarianceShare * 1.f);
    EXPECT_FLOAT_EQ(l.maps.variance(y, 5), kWindowVarianceShare * 3.f);
  }
  // NaN where there is no estimate.
  const Level none = fused(4, 4, 4, 4, {{3.f, 0.f, 0.f, 2.f}}, 0.f, true);
  EXPECT_TRUE(std::isnan(none.maps.variance(0, 0)));
}

TEST(Fusion, ABandSmallerThanTheLevelGivesTheSameResult) {
  // 20 rows of 4x4 patches at stride 2 on a 12x40 level, every patch its
  // own disparity and weight: a 6-row accumulator band slides down the level.
  const int w = 12, h = 40, p = 4, stride = 2;
  PatchGrid grid;
  grid.layout(w, h, p, stride);
  std::vector<PatchEstimate> estimates;
  for (size_t k = 0; k < grid.size(); ++k) {
    const float f = static_cast<float>(k);
    estimates.push_back({1.f + 0.37f * f, 0.2f + 0.01f * f, 0.5f, 0.1f * f});
  }
  const Level whole = fused(w, h, p, stride, estimates, 0.f, true, h);
  const Level banded = fused(w, h, p, stride, estimates, 0.f, true, p + 2);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      ASSERT_EQ(banded.maps.disparity(y, x), whole.maps.disparity(y, x)) << x << "," << y;
      ASSERT_EQ(banded.maps.confidence(y, x), whole.maps.confidence(y, x)) << x << "," << y;
      ASSERT_EQ(banded.maps.variance(y, x), whole.maps.variance(y, x)) << x << "," << y;
    }
  }
}

TEST(Fusion, CoarseLevelFallsBackToTwiceTheCoarserLevel) {
  // A coarse level initialises the next finer one: where no patch survived,
  // it keeps twice the coarser level's value.
  PatchGrid grid;
  grid.layout(8, 4, 4, 4);  // patches at x = 0 and 4
  const std::vector<PatchEstimate> estimates = {{5.f, 1.f, 0.5f, 0.f}, {7.f, 0.f, 0.f, 0.f}};
  Fusion f;
  f.configure(bdis::detail::kernelsFor(4, bdis::detail::KernelIsa::Scalar), 4, kSigmaS, 0.f, 16.f);
  f.allocate(4, 8, 4, false);
  const cv::Mat1f coarse(2, 4, 1.25f);
  cv::Mat1f init(4, 8);
  f.fuseInitialisation(grid, estimates, coarse, init);
  EXPECT_FLOAT_EQ(init(1, 1), 5.f);
  EXPECT_FLOAT_EQ(init(1, 6), 2.5f);
}

}  // namespace
