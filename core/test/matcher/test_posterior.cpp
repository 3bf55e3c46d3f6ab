// The patch posterior (posterior.hpp) on hand-computed windows of costs.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "posterior.hpp"

namespace {

using bdis::detail::expOfNonPositive;
using bdis::detail::fitWindowVariance;
using bdis::detail::isStrictLocalMinimum;
using bdis::detail::kMaxResidualShareOfTemplate;
using bdis::detail::PatchEstimate;
using bdis::detail::patchPosterior;
using bdis::detail::PosteriorSettings;

/// n = 2, delta = 1, sigma_r = 1, no contrast share, 16 valid pixels needed.
PosteriorSettings paperSettings() {
  PosteriorSettings s;
  s.half_width = 2;
  s.step = 1.f;
  s.min_valid_pixels = 16.f;
  s.sigma_r_squared = 1.f;
  s.contrast_share = 0.f;
  s.variance = false;
  return s;
}

const auto kTexturedTemplate = [] { return 100.f; };

TEST(Posterior, LocalMinimumTestNeedsEveryOtherCostHigher) {
  const float minimum[] = {3.f, 2.f, 1.f, 2.f, 3.f};
  const float tie[] = {3.f, 1.f, 1.f, 2.f, 3.f};
  const float slope[] = {1.f, 2.f, 3.f, 4.f, 5.f};
  const float flat[] = {2.f, 2.f, 2.f, 2.f, 2.f};
  const float far_lower[] = {0.5f, 2.f, 1.f, 2.f, 3.f};
  EXPECT_TRUE(isStrictLocalMinimum(minimum, 2));
  EXPECT_FALSE(isStrictLocalMinimum(tie, 2));
  EXPECT_FALSE(isStrictLocalMinimum(slope, 2));
  EXPECT_FALSE(isStrictLocalMinimum(flat, 2));
  EXPECT_FALSE(isStrictLocalMinimum(far_lower, 2));  // the window's edge counts too
  const float three[] = {9.f, 4.f, 1.f, 0.f, 1.f, 4.f, 9.f};
  EXPECT_TRUE(isStrictLocalMinimum(three, 3));
}

TEST(Posterior, ExpOfNonPositiveIsWithinAnUlpOfExp) {
  // Every exponent the likelihood can take, 0 down to past the float range,
  // against the double-precision exp rounded to float.
  double worst = 0.0;
  for (int i = 0; i <= 2000000; ++i) {
    const float x = -static_cast<float>(i) * 4.35e-5f;  // 0 .. -87
    const double exact = std::exp(static_cast<double>(x));
    worst = std::max(worst, std::fabs(expOfNonPositive(x) - exact) / exact);
  }
  EXPECT_LT(worst, 1.2e-7);  // float's ulp is 6e-8 - 1.2e-7 of the value
  EXPECT_EQ(expOfNonPositive(0.f), 1.f);
  // 0 where exp leaves the normal floats (-87.34), as with denormals flushed
  // to zero: the variance fit leaves samples of likelihood 0 out.
  EXPECT_GT(expOfNonPositive(-87.3f), 1e-38f);
  EXPECT_EQ(expOfNonPositive(-87.4f), 0.f);
  EXPECT_EQ(expOfNonPositive(-200.f), 0.f);
  EXPECT_EQ(expOfNonPositive(-std::numeric_limits<float>::infinity()), 0.f);
}

TEST(Posterior, BoltzmannLikelihoodOverTheWindow) {
  // E = {4, 1, 0, 1, 4}, sigma^2 = 1: likelihoods e^-2, e^-0.5, 1, e^-0.5, e^-2,
  // sum 1 + 2 e^-0.5 + 2 e^-2 = 2.483725; posterior 1 / sum = 0.402620;
  // evidence (0.402620 - 1/5) / (1 - 1/5) = 0.253275.
  const float costs[] = {4.f, 1.f, 0.f, 1.f, 4.f};
  const PatchEstimate e = patchPosterior(7.25f, costs, 64.f, kTexturedTemplate, paperSettings());
  EXPECT_EQ(e.disparity, 7.25f);
  EXPECT_NEAR(e.posterior, 0.402620f, 1e-6f);
  EXPECT_NEAR(e.evidence, 0.253275f, 1e-6f);
  EXPECT_EQ(e.variance, 0.f);  // not asked for
}

TEST(Posterior, ContrastShareWidensTheLikelihoodWithTheOptimumsResidual) {
  // E_0 = 2, sigma^2 = 1 + 0.5 * 2 = 2: likelihoods exp(-(E - 2) / 4) =
  // e^-1, e^-0.25, 1, e^-0.25, e^-1; sum 3.293361; posterior 0.303641.
  const float costs[] = {6.f, 3.f, 2.f, 3.f, 6.f};
  PosteriorSettings s = paperSettings();
  s.contrast_share = 0.5f;
  const PatchEstimate e = patchPosterior(1.f, costs, 64.f, kTexturedTemplate, s);
  EXPECT_NEAR(e.posterior, 0.303641f, 1e-6f);
  // The same window without the share is sharper: sigma^2 = 1.
  const PatchEstimate sharp = patchPosterior(1.f, costs, 64.f, kTexturedTemplate, paperSettings());
  EXPECT_GT(sharp.posterior, e.posterior);
}

TEST(Posterior, InfiniteCostsAwayFromTheOptimumHaveNoLikelihood) {
  // Samples past the image edge: likelihood 0. Sum 1 + 2 e^-0.5 = 2.213061.
  const float inf = std::numeric_limits<float>::infinity();
  const float costs[] = {inf, 1.f, 0.f, 1.f, inf};
  const PatchEstimate e = patchPosterior(3.f, costs, 64.f, kTexturedTemplate, paperSettings());
  EXPECT_NEAR(e.posterior, 0.451863f, 1e-6f);
}

TEST(Posterior, DiscardsAndSaysSoWithPosteriorZero) {
  const float good[] = {4.f, 1.f, 0.5f, 1.f, 4.f};
  const float inf = std::numeric_limits<float>::infinity();
  const float at_edge[] = {4.f, 1.f, inf, 1.f, 4.f};
  const float saddle[] = {4.f, 0.5f, 0.5f, 1.f, 4.f};
  int template_calls = 0;
  auto counted = [&] {
    ++template_calls;
    return 100.f;
  };
  const PosteriorSettings s = paperSettings();
  // Too few valid pixels at the optimum (16 needed).
  EXPECT_EQ(patchPosterior(2.f, good, 15.f, counted, s).posterior, 0.f);
  // No cost at the optimum.
  EXPECT_EQ(patchPosterior(2.f, at_edge, 64.f, counted, s).posterior, 0.f);
  // Not a strict local minimum.
  EXPECT_EQ(patchPosterior(2.f, saddle, 64.f, counted, s).posterior, 0.f);
  // The cheaper tests come first: the template's variance was not needed yet.
  EXPECT_EQ(template_calls, 0);
  // A residual of 1.5 times the template's variance or more: the match does
  // not explain the template (E_0 = 0.5 against variance 1/3 and 0.34).
  EXPECT_EQ(patchPosterior(2.f, good, 64.f, [] { return 0.5f / kMaxResidualShareOfTemplate; }, s).posterior, 0.f);
  EXPECT_GT(patchPosterior(2.f, good, 64.f, [] { return 0.34f; }, s).posterior, 0.f);
  EXPECT_GT(patchPosterior(2.f, good, 64.f, counted, s).posterior, 0.f);
  EXPECT_EQ(template_calls, 1);
  // A discarded patch keeps its disparity (it still initialises nothing: weight 0).
  EXPECT_EQ(patchPosterior(2.f, saddle, 64.f, counted, s).disparity, 2.f);
}

TEST(Posterior, NearlyFlatWindowIsNotConfident) {
  // A strict minimum by 0.01 grey levels^2: posterior 1 / (1 + 4 e^-0.005)
  // = 0.200801, barely above chance (0.2): evidence 0.001002.
  const float costs[] = {0.01f, 0.01f, 0.f, 0.01f, 0.01f};
  const PatchEstimate e = patchPosterior(2.f, costs, 64.f, kTexturedTemplate, paperSettings());
  EXPECT_NEAR(e.posterior, 0.200801f, 1e-6f);
  EXPECT_NEAR(e.evidence, 0.001002f, 2e-6f);
}

TEST(Posterior, VarianceFitRecoversAGaussianWindow) {
  // Window posteriors of a Gaussian of variance 1.5 (delta 1): log p_j is
  // exactly linear in j^2 with slope -1 / 3.
  std::vector<float> likelihood;
  for (int j = -2; j <= 2; ++j) likelihood.push_back(std::exp(-static_cast<float>(j * j) / 3.f));
  float sum = 0.f;
  for (float l : likelihood) sum += l;
  EXPECT_NEAR(fitWindowVariance(likelihood.data(), sum, 2, 1.f, 16.f), 1.5f, 1e-4f);
  // The same shape sampled at delta = 0.5: x_j = j^2 / 4, so v = 1.5 / 4.
  EXPECT_NEAR(fitWindowVariance(likelihood.data(), sum, 2, 0.5f, 4.f), 0.375f, 1e-4f);
  // Capped at the maximum.
  EXPECT_EQ(fitWindowVariance(likelihood.data(), sum, 2, 1.f, 1.f), 1.f);
  // Flat or rising away from the optimum: the fit fails, maximal variance.
  const float flat[] = {1.f, 1.f, 1.f, 1.f, 1.f};
  const float rising[] = {2.f, 1.5f, 1.f, 1.5f, 2.f};
  EXPECT_EQ(fitWindowVariance(flat, 5.f, 2, 1.f, 16.f), 16.f);
  EXPECT_EQ(fitWindowVariance(rising, 8.f, 2, 1.f, 16.f), 16.f);
  // Samples with likelihood 0 are left out of the fit.
  const float clipped[] = {0.f, likelihood[1], likelihood[2], likelihood[3], 0.f};
  EXPECT_NEAR(fitWindowVariance(clipped, sum, 2, 1.f, 16.f), 1.5f, 1e-4f);
}

TEST(Posterior, VarianceOfTheEstimateComesFromItsOwnWindow) {
  // sigma^2 = 1 and E_j = j^2 / 3: likelihoods exp(-j^2 / 6), a Gaussian of
  // variance 3 over the window.
  PosteriorSettings s = paperSettings();
  s.variance = true;
  const float costs[] = {4.f / 3.f, 1.f / 3.f, 0.f, 1.f / 3.f, 4.f / 3.f};
  const PatchEstimate e = patchPosterior(5.f, costs, 64.f, kTexturedTemplate, s);
  EXPECT_NEAR(e.variance, 3.f, 1e-3f);
  // The failed-fit variance: a Gaussian twice as wide as the window (n delta = 2).
  EXPECT_EQ(s.maxVariance(), 16.f);
  s.step = 0.5f;
  EXPECT_EQ(s.maxVariance(), 4.f);
}

}  // namespace
