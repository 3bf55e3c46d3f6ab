// The Bayesian patch posterior (docs/method.md, "Patch posterior"): from the
// photometric costs of a window of disparities around a patch's optimum to
// the patch's estimate, its weight in the fusion and, optionally, a variance.
// Pure functions of their arguments; called once per patch.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

namespace bdis {
namespace detail {

/// Result of one patch at one level.
struct PatchEstimate {
  float disparity = 0.f;  ///< at the level's scale
  float posterior = 0.f;  ///< 0 when discarded
  /// Posterior above chance: 0 for a flat window (posterior 1/(2n+1)), 1 for a
  /// single peak. A flat cost must never look confident.
  float evidence = 0.f;
  float variance = 0.f;  ///< px^2 at the level's scale; only when asked for
};

/// Largest window half-width n the parameters allow (MatcherParams::window_half_width).
constexpr int kMaxWindowHalfWidth = 10;

/// A patch's residual at its optimum must stay below this share of its
/// template's variance. Measured on the colon sequences (balanced): 1.5
/// lowers the mean error 1.74 -> 1.71 / 1.77 -> 1.71 px at 0.1-0.4 points of
/// density; 1.0 cuts deeper (1.64 / 1.71 px) but costs specular 1.3 points
/// of density.
constexpr float kMaxResidualShareOfTemplate = 1.5f;

/// What the posterior depends on besides the window.
struct PosteriorSettings {
  int half_width = 2;              ///< n: the window holds 2n+1 costs
  float step = 1.f;                ///< delta: px at the level between window samples
  float min_valid_pixels = 16.f;   ///< gamma * p^2: fewer valid pixels at the optimum discard the patch
  float sigma_r_squared = 0.25f;   ///< brightness noise, grey levels^2
  float contrast_share = 0.3f;     ///< share of the optimum's residual added to sigma_r^2
  bool variance = false;           ///< also fit the variance

  /// Variance of a failed fit: a Gaussian twice as wide as the window, px^2 at the level.
  float maxVariance() const {
    const float half_span = static_cast<float>(half_width) * step;
    return 4.f * half_span * half_span;
  }
};

/// The local-minimum test: false when any other cost of the window is as
/// low as the optimum's (costs[n]), i.e. the search ended on a flat or
/// saddle-shaped cost rather than at a converged match.
inline bool isStrictLocalMinimum(const float* costs, int n) {
  const float e0 = costs[n];
  for (int j = 0; j < 2 * n + 1; ++j) {
    if (j != n && costs[j] <= e0) return false;
  }
  return true;
}

/// exp(x) for x <= 0, within 1e-7 of the exact value relative to it (about
/// one ulp), and 0 below -87.3 where exp leaves the normal floats (as with
/// denormals flushed to zero). Inline and branch-free: the library's expf was
/// a call of about 50 instructions per window sample, 3 % of a balanced
/// frame. Cephes' expf: x = n ln 2 + f with |f| <= ln 2 / 2, a degree-7
/// polynomial for exp(f), 2^n written into the exponent bits. A likelihood
/// that underflows must be 0, not the smallest value: the variance fit
/// leaves samples of likelihood 0 out.
inline float expOfNonPositive(float x) {
  constexpr float kLowest = -87.33654f;  // log(FLT_MIN)
  const bool underflows = x < kLowest;
  x = std::max(x, kLowest);
  // n = round(x / ln 2) by the float adder: past 2^23 the sum keeps integers only.
  constexpr float kRoundingShift = 12582912.f;  // 1.5 * 2^23
  const float shifted = x * 1.44269504088896341f + kRoundingShift;
  const float n = shifted - kRoundingShift;
  int32_t shifted_bits;
  std::memcpy(&shifted_bits, &shifted, sizeof shifted_bits);
  const int32_t n_int = shifted_bits - 0x4B400000;  // the integer n, from the mantissa
  const float f = (x - n * 0.693359375f) + n * 2.12194440e-4f;  // ln 2 in two parts: exact n ln2_hi
  float p = 1.9875691500e-4f;
  p = p * f + 1.3981999507e-3f;
  p = p * f + 8.3334519073e-3f;
  p = p * f + 4.1665795894e-2f;
  p = p * f + 1.6666665459e-1f;
  p = p * f + 5.0000001201e-1f;
  p = p * f * f + f + 1.f;
  const int32_t scale_bits = (n_int + 127) << 23;
  float scale;
  std::memcpy(&scale, &scale_bits, sizeof scale);
  return underflows ? 0.f : p * scale;
}

/// Least-squares fit of a zero-mean Gaussian with a free scale through the
/// window posteriors likelihood[j] / sum: log p_j = a - x_j / (2 v) with
/// x_j = (j delta)^2. Returns v, px^2 at the level, capped at
/// `max_variance`, which is also the answer when the fit fails (no
/// decrease away from the optimum). Samples with likelihood 0 are left out.
inline float fitWindowVariance(const float* likelihood, float sum, int n, float delta, float max_variance) {
  float sx = 0, sy = 0, sxx = 0, sxy = 0, cnt = 0;
  for (int j = -n; j <= n; ++j) {
    const float l = likelihood[j + n];
    if (l <= 0.f) continue;
    const float x = static_cast<float>(j * j) * delta * delta;
    const float yv = std::log(l / sum);
    sx += x, sy += yv, sxx += x * x, sxy += x * yv, cnt += 1;
  }
  const float denom = cnt * sxx - sx * sx;
  const float slope = denom > 0.f ? (cnt * sxy - sx * sy) / denom : 0.f;
  return slope < 0.f ? std::min(max_variance, -0.5f / slope) : max_variance;
}

/// The estimate of a patch whose search ended at disparity u, from the
/// mean squared residuals `costs` at u + j * delta, j = -n..n, and the
/// number of valid pixels at u. The patch is discarded (posterior 0) when it
/// has too few valid pixels, its cost at u is not finite, u is not a strict
/// local minimum, or its residual reaches kMaxResidualShareOfTemplate times
/// the template's own grey-level variance (the match does not explain the
/// template: a flat or saturated left patch against texture).
/// `template_variance()` is only called for patches that pass the cheaper
/// tests. The likelihood of sample j is exp(-(E_j - E_0) / (2 sigma^2)) with
/// sigma^2 = sigma_r^2 + contrast_share * E_0; the posterior is the
/// optimum's likelihood over the window's sum.
template <class TemplateVariance>
PatchEstimate patchPosterior(float u, const float* costs, float valid_at_optimum,
                             TemplateVariance&& template_variance, const PosteriorSettings& s) {
  PatchEstimate est;
  est.disparity = u;
  const int n = s.half_width;
  if (valid_at_optimum < s.min_valid_pixels) return est;
  const float e0 = costs[n];
  if (!std::isfinite(e0)) return est;
  if (!isStrictLocalMinimum(costs, n)) return est;
  if (!(e0 < kMaxResidualShareOfTemplate * template_variance())) return est;
  const float sigma2 = s.sigma_r_squared + s.contrast_share * e0;
  const float inv = 1.f / (2.f * sigma2);
  float likelihood[2 * kMaxWindowHalfWidth + 1];
  float sum = 0.f;
  // Every other cost exceeds e0 (the strict minimum), so the exponents are negative.
  for (int j = 0; j < 2 * n + 1; ++j) {
    const float e = costs[j];
    likelihood[j] = std::isfinite(e) ? expOfNonPositive(-(e - e0) * inv) : 0.f;
  }
  likelihood[n] = 1.f;
  for (int j = 0; j < 2 * n + 1; ++j) sum += likelihood[j];
  est.posterior = 1.f / sum;
  const float chance = 1.f / static_cast<float>(2 * n + 1);
  est.evidence = std::max(0.f, (est.posterior - chance) / (1.f - chance));
  if (s.variance) est.variance = fitWindowVariance(likelihood, sum, n, s.step, s.maxVariance());
  return est;
}

}  // namespace detail
}  // namespace bdis
