// The inner loops of the patch search (src/core/patch_kernels.hpp) against a
// plain per-pixel reference, so any faster path must give the same sums.
#include <gtest/gtest.h>

#include <cmath>
#include <algorithm>
#include <cstdio>
#include <ostream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "patch_kernels.hpp"

namespace {

using namespace bdis::detail;

/// Reference: mean (optionally mean-normalised) squared residual of the p x p
/// template at (x0, y0) against the right image sampled at x - u, bilinear in x.
double referenceCost(const cv::Mat1f& right, const std::vector<float>& T, int x0, int y0, int p,
                     double u, bool mean_normalization) {
  double s = 0, ss = 0;
  for (int y = 0; y < p; ++y) {
    for (int x = 0; x < p; ++x) {
      const double xs = x0 + x - u;
      const int b = static_cast<int>(std::floor(xs));
      const double f = xs - b;
      const double sample = (1 - f) * right(y0 + y, b) + f * right(y0 + y, b + 1);
      const double d = sample - T[static_cast<size_t>(y * p + x)];
      s += d;
      ss += d * d;
    }
  }
  const double n = p * p, mean = s / n;
  return ss / n - (mean_normalization ? mean * mean : 0.0);
}

struct KernelCase {
  int p, half_width, step;
  bool mean_normalization;
};

void PrintTo(const KernelCase& c, std::ostream* os) {
  *os << "p=" << c.p << " n=" << c.half_width << " step=" << c.step
      << (c.mean_normalization ? " mean-normalised" : " plain");
}

class WindowCosts : public ::testing::TestWithParam<KernelCase> {};

TEST_P(WindowCosts, SharedRowsGiveThePerSampleCosts) {
  const KernelCase c = GetParam();
  cv::RNG rng(11);
  cv::Mat1f right(40, 160);
  rng.fill(right, cv::RNG::UNIFORM, 0.f, 255.f);
  const int x0 = 70, y0 = 5, samples = 2 * c.half_width + 1;
  std::vector<float> T(static_cast<size_t>(c.p * c.p));
  for (float& t : T) t = rng.uniform(0.f, 255.f);
  std::vector<float> row(static_cast<size_t>(c.p + 2 * c.half_width * c.step + 2));
  std::vector<float> sum(samples), sum_sq(samples), costs(samples);
  for (double u : {3.0, 12.25, 17.7, 30.999}) {
    const SampleSpan lo = sampleSpan(x0, static_cast<float>(u + c.half_width * c.step));
    windowCostsAllValid(right[y0], right.step1(), c.p, lo.base, lo.frac, samples, c.step,
                        PatchView{T.data(), nullptr, static_cast<size_t>(c.p)},
                        c.mean_normalization, row.data(), sum.data(), sum_sq.data(),
                        costs.data());
    for (int j = 0; j < samples; ++j) {
      const double uj = u + (j - c.half_width) * c.step;
      const double want = referenceCost(right, T, x0, y0, c.p, uj, c.mean_normalization);
      EXPECT_NEAR(costs[static_cast<size_t>(j)], want, 2e-4 * want)
          << "p=" << c.p << " u=" << u << " sample " << j;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(PatchKernels, WindowCosts,
                         ::testing::Values(KernelCase{8, 2, 1, true}, KernelCase{8, 2, 1, false},
                                           KernelCase{5, 4, 2, true}, KernelCase{12, 1, 3, true}));

TEST(PatchKernels, AllValidSumsMatchTheMaskedPathWhenEverythingIsValid) {
  cv::RNG rng(3);
  const int p = 8, x0 = 50, y0 = 4;
  cv::Mat1f right(20, 120);
  rng.fill(right, cv::RNG::UNIFORM, 0.f, 255.f);
  cv::Mat1b valid(right.size(), uchar(1));
  std::vector<float> T(p * p), G(p * p);
  std::vector<uchar> M(p * p, 1);
  for (float& t : T) t = rng.uniform(0.f, 255.f);
  for (float& g : G) g = rng.uniform(-20.f, 20.f);
  const PatchView view{T.data(), G.data(), p};
  const SampleSpan span = sampleSpan(x0, 9.37f);
  ResidualSums fast, masked;
  sumsAllValid(right[y0], right.step1(), p, span, view, fast);
  sumsMasked(right[y0], right.step1(), valid[y0], valid.step1(), right.cols, p, span, view, M.data(), p,
             /*with_gradient=*/true, masked);
  EXPECT_EQ(fast.count, masked.count);
  EXPECT_NEAR(fast.diff, masked.diff, 1e-3 * std::fabs(masked.diff) + 1e-2);
  EXPECT_NEAR(fast.diff_sq, masked.diff_sq, 1e-4 * masked.diff_sq);
  EXPECT_NEAR(fast.g_diff, masked.g_diff, 1e-3 * std::fabs(masked.g_diff) + 1e-1);
  EXPECT_NEAR(referenceCost(right, T, x0, y0, p, 9.37, false), masked.diff_sq / masked.count,
              1e-3 * masked.diff_sq / masked.count);
}

// Every kernel set this library has (scalar, baseline fixed-size, AVX2 where
// the CPU has it) against the double-precision reference, for each patch size
// with a fixed-size version and one without.
TEST(PatchKernels, EveryIsaAgreesWithTheReference) {
  cv::RNG rng(5);
  cv::Mat1f right(48, 200);
  rng.fill(right, cv::RNG::UNIFORM, 0.f, 255.f);
  int sets_checked = 0;
  for (KernelIsa isa : {KernelIsa::Scalar, KernelIsa::Baseline, KernelIsa::Avx2}) {
    if (!kernelIsaAvailable(isa)) continue;
    for (int p : {4, 8, 12, 16, 24, 32, 10}) {
      const KernelSet& k = kernelsFor(p, isa);
      ++sets_checked;
      const int x0 = 90, y0 = 7, n = 2, step = 1, samples = 2 * n + 1;
      std::vector<float> T(static_cast<size_t>(p * p)), G(T.size());
      for (float& t : T) t = rng.uniform(0.f, 255.f);
      for (float& g : G) g = rng.uniform(-30.f, 30.f);
      std::vector<float> row(static_cast<size_t>(p + 2 * n * step + 2));
      std::vector<float> sum(samples), sum_sq(samples), costs(samples);
      for (double u : {2.0, 11.3, 25.75}) {
        const SampleSpan span = sampleSpan(x0, static_cast<float>(u));
        ResidualSums r;
        const PatchView view{T.data(), G.data(), static_cast<size_t>(p)};
        k.sums_all_valid(right[y0], right.step1(), p, span, view, r);
        const double want = referenceCost(right, T, x0, y0, p, u, false);
        EXPECT_EQ(r.count, p * p) << k.name << " p=" << p;
        EXPECT_NEAR(r.diff_sq / r.count, want, 2e-4 * want) << k.name << " p=" << p << " u=" << u;
        // A cost alone: the same sums, bit for bit, without the gradient's.
        ResidualSums cost;
        k.sums_all_valid_no_gradient(right[y0], right.step1(), p, span, view, cost);
        EXPECT_EQ(cost.count, r.count) << k.name << " p=" << p;
        EXPECT_EQ(cost.diff, r.diff) << k.name << " p=" << p << " u=" << u;
        EXPECT_EQ(cost.diff_sq, r.diff_sq) << k.name << " p=" << p << " u=" << u;
        // Up to three spans at once (propagation's costs): each as sums_all_valid_no_gradient gives it.
        const SampleSpan spans[kMaxBatchSpans] = {span, sampleSpan(x0, static_cast<float>(u) + 0.4f),
                                                  sampleSpan(x0, static_cast<float>(u) - 3.7f)};
        for (int count = 1; count <= kMaxBatchSpans; ++count) {
          ResidualSums batch[kMaxBatchSpans];
          k.sums_no_gradient_batch(right[y0], right.step1(), p, spans, count, view, batch);
          for (int i = 0; i < count; ++i) {
            ResidualSums single;
            k.sums_all_valid_no_gradient(right[y0], right.step1(), p, spans[i], view, single);
            EXPECT_EQ(batch[i].count, single.count) << k.name << " p=" << p << " span " << i << " of " << count;
            EXPECT_EQ(batch[i].diff, single.diff) << k.name << " p=" << p << " span " << i << " of " << count;
            EXPECT_EQ(batch[i].diff_sq, single.diff_sq) << k.name << " p=" << p << " span " << i << " of " << count;
          }
        }
        const SampleSpan lo = sampleSpan(x0, static_cast<float>(u + n * step));
        k.window_costs(right[y0], right.step1(), p, lo.base, lo.frac, samples, step, view, true,
                       row.data(), sum.data(), sum_sq.data(), costs.data());
        for (int j = 0; j < samples; ++j) {
          const double wj = referenceCost(right, T, x0, y0, p, u + (j - n) * step, true);
          EXPECT_NEAR(costs[static_cast<size_t>(j)], wj, 2e-4 * wj)
              << k.name << " p=" << p << " u=" << u << " sample " << j;
        }
      }
    }
  }
  std::printf("[measured] kernel sets checked: %d (AVX2 %s)\n", sets_checked,
              kernelIsaAvailable(KernelIsa::Avx2) ? "available" : "not available here");
  EXPECT_GE(sets_checked, 14);
  // The fixed-size sets exist where they should.
  EXPECT_STREQ(kernelsFor(8, KernelIsa::Baseline).name, "baseline");
  EXPECT_STREQ(kernelsFor(10, KernelIsa::Baseline).name, "scalar");
}

// Every kernel set's template constants (sum gx, sum gx^2, grey-level
// variance) against double-precision sums, on bright, nearly flat templates
// too, where a variance from plain sums of squares would cancel in float.
TEST(PatchKernels, EveryIsaTemplateSumsMatchTheReference) {
  cv::RNG rng(21);
  int sets_checked = 0;
  for (KernelIsa isa : {KernelIsa::Scalar, KernelIsa::Baseline, KernelIsa::Avx2}) {
    if (!kernelIsaAvailable(isa)) continue;
    for (int p : {4, 8, 16, 32, 10}) {
      const KernelSet& k = kernelsFor(p, isa);
      ++sets_checked;
      const int stride = p + 5;  // rows of a wider level
      for (const auto& [lo, hi] : {std::pair<float, float>{0.f, 255.f}, {250.f, 250.5f}}) {
        std::vector<float> T(static_cast<size_t>(stride * p)), G(T.size());
        for (float& t : T) t = rng.uniform(lo, hi);
        for (float& g : G) g = rng.uniform(-40.f, 40.f);
        double sg = 0, sgg = 0, st = 0, stt = 0;
        for (int y = 0; y < p; ++y) {
          for (int x = 0; x < p; ++x) {
            const double t = T[static_cast<size_t>(y * stride + x)], g = G[static_cast<size_t>(y * stride + x)];
            sg += g, sgg += g * g, st += t, stt += t * t;
          }
        }
        const double n = p * p, variance = stt / n - (st / n) * (st / n);
        TemplateSums got;
        k.template_sums(p, PatchView{T.data(), G.data(), static_cast<size_t>(stride)}, got);
        const std::string where = std::string(k.name) + " p=" + std::to_string(p) + " grey " +
                                  std::to_string(lo) + ".." + std::to_string(hi);
        EXPECT_NEAR(got.g, sg, 1e-4 * n * 40) << where;
        EXPECT_NEAR(got.g_sq, sgg, 1e-5 * sgg) << where;
        EXPECT_NEAR(got.variance, variance, 1e-3 * variance + 1e-6) << where;
        EXPECT_GT(got.variance, 0.f) << where;
      }
    }
  }
  EXPECT_GE(sets_checked, 10);
}

// Every kernel set's fusion of a patch adds what the scalar loop adds (up to
// the rounding of a fused multiply-add), on rows of a wider image.
TEST(PatchKernels, EveryIsaAccumulatesAPatchLikeTheScalarLoop) {
  cv::RNG rng(13);
  int sets_checked = 0;
  for (KernelIsa isa : {KernelIsa::Baseline, KernelIsa::Avx2}) {
    if (!kernelIsaAvailable(isa)) continue;
    for (int p : {8, 16, 32, 10}) {
      const KernelSet& k = kernelsFor(p, isa);
      ++sets_checked;
      std::vector<float> spatial(static_cast<size_t>(p * p));
      for (float& g : spatial) g = rng.uniform(0.f, 1.f);
      cv::Mat1f sums[2][4];
      for (cv::Mat1f& m : sums[0]) {
        m.create(p + 3, p + 7);
        rng.fill(m, cv::RNG::UNIFORM, 0.f, 10.f);
      }
      for (int i = 0; i < 4; ++i) sums[1][i] = sums[0][i].clone();
      for (int patch = 0; patch < 3; ++patch) {
        const float post = rng.uniform(0.f, 1.f), d = rng.uniform(0.f, 40.f), ev = rng.uniform(0.f, 1.f);
        const int x0 = patch + 1, y0 = patch;
        k.accumulate_patch(p, spatial.data(), post, d, ev, &sums[0][0](y0, x0), &sums[0][1](y0, x0),
                           &sums[0][2](y0, x0), &sums[0][3](y0, x0), sums[0][0].step1());
        accumulatePatch(p, spatial.data(), post, d, ev, &sums[1][0](y0, x0), &sums[1][1](y0, x0),
                        &sums[1][2](y0, x0), &sums[1][3](y0, x0), sums[1][0].step1());
      }
      for (int i = 0; i < 4; ++i) {
        EXPECT_LE(cv::norm(sums[0][i], sums[1][i], cv::NORM_INF), 1e-6 * cv::norm(sums[1][i], cv::NORM_INF))
            << k.name << " p=" << p;
      }
    }
  }
  EXPECT_GE(sets_checked, 4);
}

// Every kernel set's clipped sums (the fixed-size ones read whole rows from
// the padding and mask them) against the per-pixel masked path, at matches
// reaching past either image edge; without the gradient's sums, the same
// others bit for bit.
TEST(PatchKernels, ClippedSumsMatchTheMaskedPathAtTheImageEdges) {
  cv::RNG rng(9);
  const int y0 = 2, width = 70;
  cv::Mat1f padded(40, width + 2 * kRightPadding, 0.f);
  cv::Mat1f right = padded.colRange(kRightPadding, kRightPadding + width);
  rng.fill(right, cv::RNG::UNIFORM, 0.f, 255.f);
  const cv::Mat1b valid(right.size(), uchar(1));
  int partial = 0, sets_checked = 0;
  for (KernelIsa isa : {KernelIsa::Scalar, KernelIsa::Baseline, KernelIsa::Avx2}) {
    if (!kernelIsaAvailable(isa)) continue;
    for (int p : {8, 16, 32, 10}) {
      const KernelSet& k = kernelsFor(p, isa);
      ++sets_checked;
      std::vector<float> T(static_cast<size_t>(p * p)), G(T.size());
      std::vector<uchar> M(T.size(), 1);
      for (float& t : T) t = rng.uniform(0.f, 255.f);
      for (float& g : G) g = rng.uniform(-20.f, 20.f);
      const PatchView view{T.data(), G.data(), static_cast<size_t>(p)};
      for (int x0 : {0, 3, width - p - 5, width - p - 2, width - p}) {
        for (float u : {-6.5f, -2.f, 0.f, 0.25f, 4.f, 7.75f, 12.f, static_cast<float>(p) + 3.5f}) {
          const SampleSpan span = sampleSpan(x0, u);
          ResidualSums clipped, masked, cost_only;
          k.sums_clipped(right[y0], right.step1(), p, span, columnsInside(width, p, span), view,
                         /*with_gradient=*/true, clipped);
          k.sums_clipped(right[y0], right.step1(), p, span, columnsInside(width, p, span), view,
                         /*with_gradient=*/false, cost_only);
          EXPECT_EQ(cost_only.count, clipped.count);
          EXPECT_EQ(cost_only.diff, clipped.diff);
          EXPECT_EQ(cost_only.diff_sq, clipped.diff_sq);
          EXPECT_EQ(cost_only.g_diff + cost_only.g + cost_only.g_sq, 0.f);
          sumsMasked(right[y0], right.step1(), valid[y0], valid.step1(), width, p, span, view, M.data(),
                     static_cast<size_t>(p), /*with_gradient=*/true, masked);
          EXPECT_EQ(clipped.count, masked.count) << k.name << " p=" << p << " x0=" << x0 << " u=" << u;
          EXPECT_NEAR(clipped.diff, masked.diff, 1e-3 * std::fabs(masked.diff) + 1e-1);
          EXPECT_NEAR(clipped.diff_sq, masked.diff_sq, 1e-4 * masked.diff_sq + 1e-3);
          EXPECT_NEAR(clipped.g_diff, masked.g_diff, 1e-3 * std::fabs(masked.g_diff) + 1e-1);
          EXPECT_NEAR(clipped.g, masked.g, 1e-3 * std::fabs(masked.g) + 1e-2);
          EXPECT_NEAR(clipped.g_sq, masked.g_sq, 1e-4 * masked.g_sq + 1e-3);
          if (masked.count > 0 && masked.count < p * p) ++partial;
        }
      }
    }
  }
  EXPECT_GE(sets_checked, 8);
  EXPECT_GE(partial, 40);  // the cases do reach past the edges
}

/// A right image of random grey levels inside the pyramid's zero padding,
/// and its validity (all 0 here, the padding's stays 0), as the masked and
/// clipped kernels read them.
struct PaddedRight {
  cv::Mat1f padded, image;
  cv::Mat1b valid_padded, valid;
};
PaddedRight paddedRight(cv::RNG& rng, int width, int height) {
  PaddedRight r;
  r.padded = cv::Mat1f(height, width + 2 * kRightPadding, 0.f);
  r.image = r.padded.colRange(kRightPadding, kRightPadding + width);
  rng.fill(r.image, cv::RNG::UNIFORM, 0.f, 255.f);
  r.valid_padded = cv::Mat1b(height, width + 2 * kRightPadding, uchar(0));
  r.valid = r.valid_padded.colRange(kRightPadding, kRightPadding + width);
  return r;
}

// Every kernel set's masked sums (the fixed-size ones mask lanes by the
// validity bytes, any non-zero byte valid, and read the zero padding for
// columns outside the image), with and without the gradient's sums,
// against a per-pixel double-precision reference, with invalid pixels in the
// template and in the right image and matches reaching past either edge.
TEST(PatchKernels, EveryIsaMaskedSumsMatchThePerPixelReference) {
  cv::RNG rng(17);
  const int width = 90, height = 48;
  const PaddedRight padded = paddedRight(rng, width, height);
  const cv::Mat1f& right = padded.image;
  cv::Mat1b valid = padded.valid;
  for (int y = 0; y < height; ++y) {
    // One in five invalid; the valid ones any non-zero byte, which counts as 1.
    for (int x = 0; x < width; ++x) valid(y, x) = static_cast<uchar>(rng.uniform(0, 5) * 60);
  }
  int sets_checked = 0, cases = 0, partial = 0;
  for (KernelIsa isa : {KernelIsa::Scalar, KernelIsa::Baseline, KernelIsa::Avx2}) {
    if (!kernelIsaAvailable(isa)) continue;
    for (int p : {8, 16, 32, 10}) {
      const KernelSet& k = kernelsFor(p, isa);
      ++sets_checked;
      std::vector<float> T(static_cast<size_t>(p * p)), G(T.size());
      std::vector<uchar> M(T.size());
      for (float& t : T) t = rng.uniform(0.f, 255.f);
      for (float& g : G) g = rng.uniform(-20.f, 20.f);
      for (uchar& m : M) m = static_cast<uchar>(rng.uniform(0, 4) * 85);
      const PatchView view{T.data(), G.data(), static_cast<size_t>(p)};
      const int y0 = 3;
      for (int x0 : {0, 5, width / 2, width - p - 3, width - p}) {
        for (float u : {-7.5f, -1.f, 0.f, 0.25f, 3.f, 9.6f, 21.f, static_cast<float>(p) + 4.5f, 80.f}) {
          const SampleSpan span = sampleSpan(x0, u);
          ResidualSums got, cost_only;
          k.sums_masked(right[y0], right.step1(), valid[y0], valid.step1(), width, p, span, view, M.data(),
                        static_cast<size_t>(p), /*with_gradient=*/true, got);
          k.sums_masked(right[y0], right.step1(), valid[y0], valid.step1(), width, p, span, view, M.data(),
                        static_cast<size_t>(p), /*with_gradient=*/false, cost_only);
          // Sums, and sums of magnitudes that bound the float rounding.
          double n = 0, sd = 0, sdd = 0, sgd = 0, sg = 0, sgg = 0, abs_d = 0, abs_gd = 0, abs_g = 0;
          for (int y = 0; y < p; ++y) {
            for (int i = 0; i < p; ++i) {
              const int xr = span.base + i, taps = span.frac > 0.f ? 1 : 0;
              if (!M[y * p + i] || xr < 0 || xr + taps >= width) continue;
              if (!valid(y0 + y, xr) || !valid(y0 + y, xr + taps)) continue;
              const double sample = (1.0 - span.frac) * right(y0 + y, xr) +
                                    (taps ? span.frac * right(y0 + y, xr + 1) : 0.0);
              const double d = sample - T[y * p + i], g = G[y * p + i];
              n += 1;
              sd += d;
              sdd += d * d;
              sgd += g * d;
              sg += g;
              sgg += g * g;
              abs_d += std::fabs(d);
              abs_gd += std::fabs(g * d);
              abs_g += std::fabs(g);
            }
          }
          const std::string where = std::string(k.name) + " p=" + std::to_string(p) +
                                    " x0=" + std::to_string(x0) + " u=" + std::to_string(u);
          EXPECT_EQ(got.count, n) << where;
          EXPECT_NEAR(got.diff, sd, 1e-4 * abs_d + 1e-3) << where;
          EXPECT_NEAR(got.diff_sq, sdd, 1e-4 * sdd + 1e-3) << where;
          EXPECT_NEAR(got.g_diff, sgd, 1e-4 * abs_gd + 1e-3) << where;
          EXPECT_NEAR(got.g, sg, 1e-4 * abs_g + 1e-3) << where;
          EXPECT_NEAR(got.g_sq, sgg, 1e-4 * sgg + 1e-3) << where;
          // A cost's sums alone: the same bits, and no gradient's.
          EXPECT_EQ(cost_only.count, got.count) << where;
          EXPECT_EQ(cost_only.diff, got.diff) << where;
          EXPECT_EQ(cost_only.diff_sq, got.diff_sq) << where;
          EXPECT_EQ(cost_only.g_diff + cost_only.g + cost_only.g_sq, 0.f) << where;
          ++cases;
          if (n > 0 && n < p * p / 2) ++partial;
        }
      }
    }
  }
  EXPECT_GE(sets_checked, 8);
  EXPECT_GE(partial, 40);  // many patches mostly masked or past an edge
  EXPECT_GE(cases, 8 * 45);
}

/// paddedRight with one pixel in six invalid; the valid ones any non-zero byte.
PaddedRight paddedRightWithInvalidPixels(cv::RNG& rng, int width, int height) {
  PaddedRight r = paddedRight(rng, width, height);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) r.valid(y, x) = static_cast<uchar>(rng.uniform(0, 6) * 50);
  }
  return r;
}

/// A cost's masked sums, bit for bit `want`'s, and no gradient's.
void expectTheseMaskedSums(const ResidualSums& got, const ResidualSums& want, const std::string& where) {
  EXPECT_EQ(got.count, want.count) << where;
  EXPECT_EQ(got.diff, want.diff) << where;
  EXPECT_EQ(got.diff_sq, want.diff_sq) << where;
  EXPECT_EQ(got.g_diff + got.g + got.g_sq, 0.f) << where;
}

// Every kernel set's batch of masked sums, plain and with support weights,
// gives each span the masked sums of that span alone, bit for bit, for spans
// with their own interpolation weights reaching past either edge of the
// image and over invalid pixels of both views.
TEST(PatchKernels, EveryIsaMaskedBatchSumsAreEachSpansMaskedSums) {
  cv::RNG rng(31);
  const int width = 90, height = 48, y0 = 5;
  const PaddedRight padded = paddedRightWithInvalidPixels(rng, width, height);
  const cv::Mat1f& right = padded.image;
  const cv::Mat1b& valid = padded.valid;
  int sets_checked = 0, spans_checked = 0, partial = 0, outside = 0;
  for (KernelIsa isa : {KernelIsa::Scalar, KernelIsa::Baseline, KernelIsa::Avx2}) {
    if (!kernelIsaAvailable(isa)) continue;
    for (int p : {8, 16, 10}) {
      const KernelSet& k = kernelsFor(p, isa);
      ASSERT_NE(k.weighted, nullptr);
      std::vector<float> T(static_cast<size_t>(p * p)), G(T.size()), W(T.size());
      std::vector<uchar> M(T.size());
      for (float& t : T) t = rng.uniform(0.f, 255.f);
      for (float& g : G) g = rng.uniform(-20.f, 20.f);  // read by the scalar sums_masked only
      for (float& w : W) w = rng.uniform(0.05f, 1.f);
      for (uchar& m : M) m = static_cast<uchar>(rng.uniform(0, 5) * 60);
      const PatchView plain{T.data(), G.data(), static_cast<size_t>(p)};
      const PatchView weighted{T.data(), G.data(), static_cast<size_t>(p), W.data()};
      for (const KernelSet* set : {&k, k.weighted}) {
        const PatchView& view = set == &k ? plain : weighted;
        ++sets_checked;
        for (int trial = 0; trial < 300; ++trial) {
          const int n = rng.uniform(1, kMaxBatchSpans + 1);
          SampleSpan spans[kMaxBatchSpans];
          for (int i = 0; i < n; ++i) {
            const float frac = rng.uniform(0, 3) == 0 ? 0.f : rng.uniform(0.f, 1.f);
            spans[i] = {rng.uniform(-kRightPadding, width + kRightPadding - p), frac};
          }
          ResidualSums batch[kMaxBatchSpans];
          set->sums_masked_no_gradient_batch(right[y0], right.step1(), valid[y0], valid.step1(), width, p, spans, n,
                                             view, M.data(), static_cast<size_t>(p), batch);
          for (int i = 0; i < n; ++i) {
            ResidualSums one;
            set->sums_masked(right[y0], right.step1(), valid[y0], valid.step1(), width, p, spans[i], view, M.data(),
                             static_cast<size_t>(p), /*with_gradient=*/false, one);
            const std::string where = std::string(set->name) + (set == &k ? " plain" : " weighted") +
                                      " p=" + std::to_string(p) + " base=" + std::to_string(spans[i].base) +
                                      " frac=" + std::to_string(spans[i].frac) + " span " + std::to_string(i);
            expectTheseMaskedSums(batch[i], one, where);
            ++spans_checked;
            if (one.count > 0.f && (spans[i].base < 0 || spans[i].base + p >= width)) ++partial;
            if (columnsInside(width, p, spans[i]).empty()) ++outside;
          }
        }
      }
    }
  }
  EXPECT_GE(sets_checked, 12);
  EXPECT_GE(spans_checked, 12 * 500);
  EXPECT_GE(partial, 100);  // spans across an edge of the image
  EXPECT_GE(outside, 100);  // and spans wholly past it: no sums
}

// Every kernel set's window of masked sums gives each sample the masked sums
// of its own span, bit for bit (the fixed-size kernels run the same
// operations with the template read once), for windows reaching past either
// edge of the image and over invalid pixels of both views.
TEST(PatchKernels, EveryIsaWindowMaskedSumsAreEachSamplesMaskedSums) {
  cv::RNG rng(23);
  const int width = 90, height = 48, y0 = 3;
  const PaddedRight padded = paddedRightWithInvalidPixels(rng, width, height);
  const cv::Mat1f& right = padded.image;
  const cv::Mat1b& valid = padded.valid;
  int sets_checked = 0, samples_checked = 0, partial = 0, outside = 0;
  for (KernelIsa isa : {KernelIsa::Scalar, KernelIsa::Baseline, KernelIsa::Avx2}) {
    if (!kernelIsaAvailable(isa)) continue;
    for (int p : {8, 16, 10}) {
      const KernelSet& k = kernelsFor(p, isa);
      ++sets_checked;
      std::vector<float> T(static_cast<size_t>(p * p)), G(T.size());
      std::vector<uchar> M(T.size());
      for (float& t : T) t = rng.uniform(0.f, 255.f);
      for (float& g : G) g = rng.uniform(-20.f, 20.f);  // read by the scalar sums_masked, not by the window
      for (uchar& m : M) m = static_cast<uchar>(rng.uniform(0, 5) * 60);
      const PatchView view{T.data(), G.data(), static_cast<size_t>(p)};
      for (int half_width : {2, 1, 4}) {
        for (int step : {1, 2}) {
          const int samples = 2 * half_width + 1, span_len = p + step * (samples - 1);
          // From past the left edge to past the right one, all within the padding.
          for (int base_lo = -kRightPadding; base_lo + span_len < width + kRightPadding; base_lo += 7) {
            for (float frac : {0.f, 0.375f, 0.9f}) {
              std::vector<ResidualSums> window(static_cast<size_t>(samples));
              k.window_sums_masked(right[y0], right.step1(), valid[y0], valid.step1(), width, p, base_lo, frac,
                                   samples, step, view, M.data(), static_cast<size_t>(p), window.data());
              for (int j = 0; j < samples; ++j) {
                const SampleSpan span{base_lo + step * (samples - 1 - j), frac};
                ResidualSums one;
                k.sums_masked(right[y0], right.step1(), valid[y0], valid.step1(), width, p, span, view, M.data(),
                              static_cast<size_t>(p), /*with_gradient=*/false, one);
                const ResidualSums& got = window[static_cast<size_t>(j)];
                const std::string where = std::string(k.name) + " p=" + std::to_string(p) +
                                          " base=" + std::to_string(span.base) + " frac=" + std::to_string(frac) +
                                          " step=" + std::to_string(step) + " sample " + std::to_string(j);
                expectTheseMaskedSums(got, one, where);
                ++samples_checked;
                if (one.count > 0.f && (span.base < 0 || span.base + p >= width)) ++partial;
                if (columnsInside(width, p, span).empty()) ++outside;
              }
            }
          }
        }
      }
    }
  }
  EXPECT_GE(sets_checked, 6);
  EXPECT_GE(samples_checked, 6 * 1000);
  EXPECT_GE(partial, 100);  // samples across an edge of the image
  EXPECT_GE(outside, 100);  // and samples wholly past it: no sums
}

// Every kernel set's weighted twin with support weights in the view
// (docs/method.md, "Support weights"): each sum weighs its pixel's terms, the count is the sum
// of the weights, against a per-pixel double-precision reference; the masked
// and clipped paths too; the template constants weighted; and with every
// weight 1 the same sums as without weights (bit for bit but the variance).
TEST(PatchKernels, EveryIsaWeighsEachPixelBySupportWeights) {
  cv::RNG rng(29);
  const int width = 90, height = 48, y0 = 4;
  const PaddedRight padded = paddedRight(rng, width, height);
  const cv::Mat1f& right = padded.image;
  cv::Mat1b valid = padded.valid;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) valid(y, x) = rng.uniform(0, 6) ? 1 : 0;
  }
  int sets_checked = 0, cases = 0;
  for (KernelIsa isa : {KernelIsa::Scalar, KernelIsa::Baseline, KernelIsa::Avx2}) {
    if (!kernelIsaAvailable(isa)) continue;
    for (int p : {4, 8, 12, 16, 24, 32, 10}) {
      const KernelSet& k = kernelsFor(p, isa);
      ASSERT_NE(k.weighted, nullptr);
      const KernelSet& kw = *k.weighted;  // the sums that read the weights
      ++sets_checked;
      const size_t n_px = static_cast<size_t>(p * p);
      std::vector<float> T(n_px), G(n_px), W(n_px), ones(n_px, 1.f);
      std::vector<uchar> M(n_px);
      for (float& t : T) t = rng.uniform(0.f, 255.f);
      for (float& g : G) g = rng.uniform(-20.f, 20.f);
      for (float& w : W) w = rng.uniform(0.01f, 1.f);
      for (uchar& m : M) m = rng.uniform(0, 4) ? 1 : 0;
      const PatchView plain{T.data(), G.data(), static_cast<size_t>(p)};
      PatchView weighted = plain, unit = plain;
      weighted.weight = W.data();
      unit.weight = ones.data();
      const std::string set = std::string(k.name) + " p=" + std::to_string(p);

      // The weights themselves, alone and with the constants under them.
      const float centre = T[0], inv_sq = 1.f / 64.f;
      std::vector<float> got_w(n_px), got_w_too(n_px);
      const float support = k.support_weights(p, plain, centre, inv_sq, got_w.data(), nullptr);
      double expected_support = 0.0;
      for (size_t i = 0; i < n_px; ++i) {
        const double d = T[i] - centre;
        EXPECT_NEAR(got_w[i], 1.0 / (1.0 + d * d / 64.0), 1e-6) << set << " pixel " << i;
        expected_support += got_w[i];
      }
      EXPECT_EQ(got_w[0], 1.f) << set;
      // The weights' sum, which tells a thin structure (a small share) from one side of an edge.
      EXPECT_NEAR(support, expected_support, 1e-5 * expected_support) << set;
      // How far the template strays from the centre, which decides whether
      // the weights are used, with the plain constants in the same pass.
      float most = 0.f;
      for (size_t i = 0; i < n_px; ++i) most = std::max(most, (T[i] - centre) * (T[i] - centre));
      TemplateSums with_deviation, plain_sums;
      EXPECT_EQ(k.template_sums_and_deviation(p, plain, centre, with_deviation), most) << set;
      k.template_sums(p, plain, plain_sums);
      EXPECT_EQ(with_deviation.g, plain_sums.g) << set;
      EXPECT_EQ(with_deviation.g_sq, plain_sums.g_sq) << set;
      EXPECT_EQ(with_deviation.variance, plain_sums.variance) << set;
      const float last = T[n_px - 1];
      EXPECT_EQ(k.template_sums_and_deviation(p, plain, last, with_deviation), maxSquaredDeviation(p, plain, last))
          << set;
      TemplateSums fused, separate;
      EXPECT_EQ(k.support_weights(p, plain, centre, inv_sq, got_w_too.data(), &fused), support) << set;
      EXPECT_EQ(got_w_too, got_w) << set;
      PatchView with_got_w = plain;
      with_got_w.weight = got_w.data();
      kw.template_sums(p, with_got_w, separate);
      EXPECT_NEAR(fused.g, separate.g, 1e-5 * (std::fabs(separate.g) + n_px)) << set;
      EXPECT_NEAR(fused.g_sq, separate.g_sq, 1e-5 * separate.g_sq) << set;
      EXPECT_NEAR(fused.variance, separate.variance, 1e-5 * separate.variance) << set;

      // Template constants: sum w g, sum w g^2, the weighted variance.
      double sw = 0, sg = 0, sgg = 0, st = 0, stt = 0;
      for (size_t i = 0; i < n_px; ++i) {
        sw += W[i], sg += W[i] * G[i], sgg += W[i] * G[i] * G[i], st += W[i] * T[i], stt += W[i] * T[i] * T[i];
      }
      TemplateSums constants, plain_constants, unit_constants;
      kw.template_sums(p, weighted, constants);
      k.template_sums(p, plain, plain_constants);
      kw.template_sums(p, unit, unit_constants);
      // The plain set leaves a view's weights unread (the scalar one serves both).
      if (&kw != &k) {
        TemplateSums ignoring;
        k.template_sums(p, weighted, ignoring);
        EXPECT_EQ(ignoring.g, plain_constants.g) << set;
        EXPECT_EQ(ignoring.variance, plain_constants.variance) << set;
      }
      EXPECT_NEAR(constants.g, sg, 1e-4 * n_px * 20) << set;
      EXPECT_NEAR(constants.g_sq, sgg, 1e-5 * sgg) << set;
      const double variance = stt / sw - (st / sw) * (st / sw);
      EXPECT_NEAR(constants.variance, variance, 1e-3 * variance) << set;
      EXPECT_EQ(unit_constants.g, plain_constants.g) << set;
      EXPECT_EQ(unit_constants.g_sq, plain_constants.g_sq) << set;
      // (the weights' sum in place of the constant count: the last bit may differ)
      EXPECT_NEAR(unit_constants.variance, plain_constants.variance, 1e-6 * plain_constants.variance) << set;

      for (int x0 : {0, 30, width - p - 2}) {
        for (float u : {-3.5f, 0.f, 2.25f, 9.6f, 20.f}) {
          const SampleSpan span = sampleSpan(x0, u);
          const int taps = span.frac > 0.f ? 1 : 0;
          // Reference over the pixels each path sums: all (in the image), those
          // inside the image (clipped), those valid in both views (masked).
          struct Sums {
            double n = 0, sd = 0, sdd = 0, sgd = 0, sg = 0, sgg = 0, abs_d = 0, abs_gd = 0;
          } all, inside, masked;
          for (int y = 0; y < p; ++y) {
            for (int i = 0; i < p; ++i) {
              const size_t at = static_cast<size_t>(y * p + i);
              const int xr = span.base + i;
              const bool in_image = xr >= 0 && xr + taps < width;
              const double sample = in_image ? (1.0 - span.frac) * right(y0 + y, xr) +
                                                   (taps ? span.frac * right(y0 + y, xr + 1) : 0.0)
                                             : 0.0;
              const double w = W[at], d = sample - T[at], g = G[at];
              auto add = [&](Sums& s) {
                s.n += w, s.sd += w * d, s.sdd += w * d * d, s.sgd += w * g * d, s.sg += w * g, s.sgg += w * g * g;
                s.abs_d += std::fabs(w * d), s.abs_gd += std::fabs(w * g * d);
              };
              if (!in_image) continue;
              add(all);
              add(inside);
              if (M[at] && valid(y0 + y, xr) && valid(y0 + y, xr + taps)) add(masked);
            }
          }
          auto expectSums = [&](const ResidualSums& r, const Sums& want, bool gradient, const char* path) {
            const std::string where = set + " " + path + " x0=" + std::to_string(x0) + " u=" + std::to_string(u);
            EXPECT_NEAR(r.count, want.n, 1e-5 * p * p) << where;
            EXPECT_NEAR(r.diff, want.sd, 1e-4 * want.abs_d + 1e-3) << where;
            EXPECT_NEAR(r.diff_sq, want.sdd, 1e-4 * want.sdd + 1e-3) << where;
            if (gradient) {
              EXPECT_NEAR(r.g_diff, want.sgd, 1e-4 * want.abs_gd + 1e-3) << where;
            }
          };
          const bool whole = span.base >= 0 && span.base + p + 1 <= width;
          if (whole) {
            ResidualSums r, cost, unit_r, plain_r;
            kw.sums_all_valid(right[y0], right.step1(), p, span, weighted, r);
            expectSums(r, all, true, "all valid");
            kw.sums_all_valid_no_gradient(right[y0], right.step1(), p, span, weighted, cost);
            EXPECT_EQ(cost.count, r.count) << set;
            EXPECT_EQ(cost.diff, r.diff) << set;
            EXPECT_EQ(cost.diff_sq, r.diff_sq) << set;
            const SampleSpan spans[kMaxBatchSpans] = {span, sampleSpan(x0, u + 0.4f), sampleSpan(x0, u - 1.7f)};
            ResidualSums batch[kMaxBatchSpans];
            kw.sums_no_gradient_batch(right[y0], right.step1(), p, spans, 1, weighted, batch);
            EXPECT_EQ(batch[0].count, cost.count) << set;
            EXPECT_EQ(batch[0].diff, cost.diff) << set;
            EXPECT_EQ(batch[0].diff_sq, cost.diff_sq) << set;
            // Unit weights: the plain sums, bit for bit.
            kw.sums_all_valid(right[y0], right.step1(), p, span, unit, unit_r);
            k.sums_all_valid(right[y0], right.step1(), p, span, plain, plain_r);
            EXPECT_EQ(unit_r.count, plain_r.count) << set;
            EXPECT_EQ(unit_r.diff, plain_r.diff) << set;
            EXPECT_EQ(unit_r.diff_sq, plain_r.diff_sq) << set;
            EXPECT_EQ(unit_r.g_diff, plain_r.g_diff) << set;
          }
          ResidualSums clipped, masked_r;
          kw.sums_clipped(right[y0], right.step1(), p, span, columnsInside(width, p, span), weighted,
                         /*with_gradient=*/true, clipped);
          expectSums(clipped, inside, true, "clipped");
          EXPECT_NEAR(clipped.g, inside.sg, 1e-4 * p * p * 20 + 1e-3) << set;
          EXPECT_NEAR(clipped.g_sq, inside.sgg, 1e-4 * inside.sgg + 1e-3) << set;
          kw.sums_masked(right[y0], right.step1(), valid[y0], valid.step1(), width, p, span, weighted, M.data(),
                        static_cast<size_t>(p), /*with_gradient=*/true, masked_r);
          expectSums(masked_r, masked, true, "masked");
          ++cases;
        }
      }
    }
  }
  EXPECT_GE(sets_checked, 14);
  EXPECT_GE(cases, 14 * 15);
}

}  // namespace
