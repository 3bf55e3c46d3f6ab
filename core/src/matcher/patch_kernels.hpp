// Inner loops of the patch search: sums over one patch of the residual between
// the right image, sampled at a horizontal sub-pixel offset, and the left
// template. Rectified stereo moves only along x, so one interpolation weight
// serves the whole patch: each sample is a 2-tap filter with constant taps.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>

#include <opencv2/core.hpp>

/// Marks a per-pixel row loop to be compiled twice, for the baseline and for
/// AVX2 (eight floats a vector instead of four), the loader picking the one
/// the CPU runs. AVX2 without FMA: the same operations, so the same values.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define BDIS_ROW_LOOP __attribute__((target_clones("avx2", "default")))
#else
#define BDIS_ROW_LOOP
#endif

namespace bdis {
namespace detail {

/// Sums over the valid pixels of a patch; diff = R(x - u) - T(x).
struct ResidualSums {
  float count = 0;    ///< valid pixels
  float diff = 0;     ///< sum diff
  float diff_sq = 0;  ///< sum diff^2
  float g_diff = 0;   ///< sum gx * diff
  float g = 0;        ///< sum gx (masked path only; fast path takes it from the template constants)
  float g_sq = 0;     ///< sum gx^2 (masked path only)
};

/// Where the right patch is sampled: columns base .. base+p (inclusive) with
/// weight `frac` on the right neighbour.
struct SampleSpan {
  int base;
  float frac;
};

inline SampleSpan sampleSpan(int x0, float disparity) {
  const float xs = static_cast<float>(x0) - disparity;
  // floor without std::floor, which the baseline x86-64 build (no SSE4.1
  // round) expands to a dozen instructions on the Gauss-Newton loop's path.
  const int truncated = static_cast<int>(xs);
  const int base = truncated - (xs < static_cast<float>(truncated) ? 1 : 0);
  return {base, xs - static_cast<float>(base)};
}

/// The template side of a patch, read in place from the left level: grey
/// values and x-gradients at the patch's top-left pixel, rows `stride` floats
/// apart (both images share one row pitch). `weight`, when set, gives each
/// pixel its support weight (p x p, row-major; docs/method.md, "Support
/// weights"): every sum then weighs its pixel's terms, and the count is the
/// weights' sum. The window costs take no weights.
struct PatchView {
  const float* tmpl;
  const float* grad;
  size_t stride;
  const float* weight = nullptr;
};

/// What stays constant over a patch's search when every template pixel is
/// valid: the sums of gx and gx^2 (the parts of the 1-D Hessian) and the
/// template's grey-level variance (the residual test's yardstick); with the
/// view's support weights, all three weighted: the variance is then that of
/// the pixels the patch matches on, the centre's surface.
struct TemplateSums {
  float g = 0;         ///< sum gx
  float g_sq = 0;      ///< sum gx^2
  float variance = 0;  ///< of the grey values, >= 0
};

/// TemplateSums of a p x p template, every pixel valid. Grey values enter as
/// t - t[0], so bright, nearly flat patches lose nothing to cancellation
/// (255 squared swamps float).
/// The scalar kernels' loops are written once for both kinds of view: each
/// is a template on `Weighted`, called once per patch by the kernel, so the
/// plain loops carry no weight.
template <bool Weighted>
inline float supportWeightAt(const PatchView& patch, int p, int y, int i) {
  if constexpr (Weighted) {
    return patch.weight[y * p + i];
  } else {
    return 1.f;
  }
}

template <bool Weighted>
inline void templateSumsOf(int p, const PatchView& patch, TemplateSums& out) {
  const float ref = patch.tmpl[0];
  float sg = 0, sgg = 0, st = 0, stt = 0, sw = 0;
  for (int y = 0; y < p; ++y) {
    const float* t = patch.tmpl + y * patch.stride;
    const float* g = patch.grad + y * patch.stride;
    for (int i = 0; i < p; ++i) {
      const float w = supportWeightAt<Weighted>(patch, p, y, i);
      const float v = t[i] - ref;
      const float wg = w * g[i], wv = w * v;
      sg += wg;
      sgg += wg * g[i];
      st += wv;
      stt += wv * v;
      sw += w;
    }
  }
  const float count = Weighted ? sw : static_cast<float>(p * p);
  const float mean = st / count;
  out = {sg, sgg, std::max(0.f, stt / count - mean * mean)};
}

inline void templateSums(int p, const PatchView& patch, TemplateSums& out) {
  patch.weight ? templateSumsOf<true>(p, patch, out) : templateSumsOf<false>(p, patch, out);
}

/// Support weights of a p x p template (`patch`'s grey values; its weight
/// pointer is not read) into `weights` (p x p, row-major): 1 / (1 + (t -
/// centre)^2 * inv_grey_sq). With `sums`, in the same pass, the template's
/// constants under those weights, as templateSums gives them for a view
/// with them. Returns the weights' sum.
inline float supportWeights(int p, const PatchView& patch, float centre, float inv_grey_sq, float* weights,
                            TemplateSums* sums) {
  float sum = 0.f;
  for (int y = 0; y < p; ++y) {
    const float* t = patch.tmpl + y * patch.stride;
    for (int i = 0; i < p; ++i) {
      const float d = t[i] - centre;
      weights[y * p + i] = 1.f / (1.f + d * d * inv_grey_sq);
      sum += weights[y * p + i];
    }
  }
  if (sums) {
    PatchView weighted = patch;
    weighted.weight = weights;
    templateSums(p, weighted, *sums);
  }
  return sum;
}

/// The largest (t - centre)^2 over a p x p template (`patch`'s grey values):
/// how far its pixels stray from the centre's grey level.
inline float maxSquaredDeviation(int p, const PatchView& patch, float centre) {
  float most = 0.f;
  for (int y = 0; y < p; ++y) {
    const float* t = patch.tmpl + y * patch.stride;
    for (int i = 0; i < p; ++i) {
      const float d = t[i] - centre;
      most = std::max(most, d * d);
    }
  }
  return most;
}

inline float templateSumsAndDeviation(int p, const PatchView& patch, float centre, TemplateSums& out) {
  templateSumsOf<false>(p, patch, out);
  return maxSquaredDeviation(p, patch, centre);
}

/// Interpolates `len` samples of a right-image row starting at column `base`.
inline void interpolateRow(const float* row, int base, float frac, int len, float* out) {
  const float w0 = 1.f - frac;
  const float* r = row + base;
  for (int i = 0; i < len; ++i) out[i] = w0 * r[i] + frac * r[i + 1];
}

/// Fast path: every template pixel valid and the right span [base, base+p]
/// inside the image and valid. `rows` points at column 0 of the patch's first
/// right-image row, `stride` is the row pitch in floats. Leaves g and g_sq
/// alone (the caller has them from templateSums).
template <bool Weighted>
inline void sumsAllValidOf(const float* rows, size_t stride, int p, SampleSpan span, const PatchView& patch,
                           ResidualSums& out) {
  const float w0 = 1.f - span.frac, w1 = span.frac;
  float sd = 0, sdd = 0, sgd = 0, sw = 0;
  for (int y = 0; y < p; ++y) {
    const float* r = rows + y * stride + span.base;
    const float* t = patch.tmpl + y * patch.stride;
    const float* g = patch.grad + y * patch.stride;
    for (int i = 0; i < p; ++i) {
      const float w = supportWeightAt<Weighted>(patch, p, y, i);
      const float d = w0 * r[i] + w1 * r[i + 1] - t[i];
      const float wd = w * d;
      sd += wd;
      sgd += g[i] * wd;
      sdd += wd * d;
      sw += w;
    }
  }
  out.count = Weighted ? sw : static_cast<float>(p * p);
  out.diff = sd;
  out.diff_sq = sdd;
  out.g_diff = sgd;
}

inline void sumsAllValid(const float* rows, size_t stride, int p, SampleSpan span,
                         const PatchView& patch, ResidualSums& out) {
  patch.weight ? sumsAllValidOf<true>(rows, stride, p, span, patch, out)
               : sumsAllValidOf<false>(rows, stride, p, span, patch, out);
}

/// sumsAllValid without the gradient sum, for a cost alone: count, diff and
/// diff_sq as sumsAllValid gives them (the same operations), g_diff 0.
template <bool Weighted>
inline void sumsAllValidNoGradientOf(const float* rows, size_t stride, int p, SampleSpan span,
                                     const PatchView& patch, ResidualSums& out) {
  const float w0 = 1.f - span.frac, w1 = span.frac;
  float sd = 0, sdd = 0, sw = 0;
  for (int y = 0; y < p; ++y) {
    const float* r = rows + y * stride + span.base;
    const float* t = patch.tmpl + y * patch.stride;
    for (int i = 0; i < p; ++i) {
      const float w = supportWeightAt<Weighted>(patch, p, y, i);
      const float d = w0 * r[i] + w1 * r[i + 1] - t[i];
      const float wd = w * d;
      sd += wd;
      sdd += wd * d;
      sw += w;
    }
  }
  out.count = Weighted ? sw : static_cast<float>(p * p);
  out.diff = sd;
  out.diff_sq = sdd;
  out.g_diff = 0.f;
}

inline void sumsAllValidNoGradient(const float* rows, size_t stride, int p, SampleSpan span,
                                   const PatchView& patch, ResidualSums& out) {
  patch.weight ? sumsAllValidNoGradientOf<true>(rows, stride, p, span, patch, out)
               : sumsAllValidNoGradientOf<false>(rows, stride, p, span, patch, out);
}

/// Most spans one call of sums_no_gradient_batch takes: a patch's own
/// disparity and its two neighbours' (spatial propagation).
constexpr int kMaxBatchSpans = 3;

/// sumsAllValidNoGradient at `n` (1..kMaxBatchSpans) spans of the same
/// template, each under the fast path's conditions, into out[0..n).
inline void sumsAllValidNoGradientBatch(const float* rows, size_t stride, int p,
                                        const SampleSpan* spans, int n, const PatchView& patch,
                                        ResidualSums* out) {
  for (int i = 0; i < n; ++i) sumsAllValidNoGradient(rows, stride, p, spans[i], patch, out[i]);
}

/// Window fast path: the costs of `samples` disparities a whole number of
/// pixels (`step`) apart, which share one interpolation weight. Plain: the
/// view's support weights are not read. Sample j reads
/// the right patch at column base_lo + step * (samples - 1 - j), so one
/// interpolated row serves every sample instead of re-interpolating per sample.
/// Requires the columns base_lo .. base_lo + p + step * (samples - 1) valid.
/// Writes the mean squared residual (mean-normalised if asked) per sample.
inline void windowCostsAllValid(const float* rows, size_t stride, int p, int base_lo, float frac,
                                int samples, int step, const PatchView& patch,
                                bool mean_normalization, float* row_buf, float* sum, float* sum_sq,
                                float* costs) {
  const int len = p + step * (samples - 1);
  for (int j = 0; j < samples; ++j) sum[j] = sum_sq[j] = 0.f;
  for (int y = 0; y < p; ++y) {
    interpolateRow(rows + y * stride, base_lo, frac, len, row_buf);
    const float* t = patch.tmpl + y * patch.stride;
    for (int j = 0; j < samples; ++j) {
      const float* r = row_buf + step * (samples - 1 - j);
      float sd = 0, sdd = 0;
      for (int i = 0; i < p; ++i) {
        const float d = r[i] - t[i];
        sd += d;
        sdd += d * d;
      }
      sum[j] += sd;
      sum_sq[j] += sdd;
    }
  }
  const float inv_n = 1.f / static_cast<float>(p * p);
  for (int j = 0; j < samples; ++j) {
    const float mean = sum[j] * inv_n;
    costs[j] = sum_sq[j] * inv_n - (mean_normalization ? mean * mean : 0.f);
  }
}

/// Columns i of a patch whose right samples (x0 - u + i and, with a second
/// tap, its right neighbour) lie inside an image `width` wide: [begin, end).
struct ColumnRange {
  int begin, end;
  bool empty() const { return end <= begin; }
};

inline ColumnRange columnsInside(int width, int p, SampleSpan span) {
  const int taps = span.frac > 0.f ? 1 : 0;
  return {std::max(0, -span.base), std::min(p, width - taps - span.base)};
}

/// Clipped path: every template pixel valid, and the right pixels valid over
/// `cols`, the columns that stay inside the image (a match near or past its
/// edge): sums over those columns without per-pixel tests.
template <bool Weighted>
inline void sumsClippedOf(const float* rows, size_t stride, int p, SampleSpan span, ColumnRange cols,
                          const PatchView& patch, bool with_gradient, ResidualSums& out) {
  out = ResidualSums{};
  if (cols.empty()) return;
  const bool two_taps = span.frac > 0.f;
  const float w0 = 1.f - span.frac, w1 = span.frac;
  float sd = 0, sdd = 0, sgd = 0, sg = 0, sgg = 0, sw = 0;
  for (int y = 0; y < p; ++y) {
    const float* r = rows + y * stride + span.base;
    const float* t = patch.tmpl + y * patch.stride;
    const float* g = patch.grad + y * patch.stride;
    for (int i = cols.begin; i < cols.end; ++i) {
      const float w = supportWeightAt<Weighted>(patch, p, y, i);
      const float sample = two_taps ? w0 * r[i] + w1 * r[i + 1] : r[i];
      const float d = sample - t[i];
      const float wd = w * d, wg = w * g[i];
      sd += wd;
      sdd += wd * d;
      sgd += g[i] * wd;
      sg += wg;
      sgg += wg * g[i];
      sw += w;
    }
  }
  const float count = Weighted ? sw : static_cast<float>((cols.end - cols.begin) * p);
  out = {count, sd, sdd, with_gradient ? sgd : 0.f, with_gradient ? sg : 0.f, with_gradient ? sgg : 0.f};
}

inline void sumsClipped(const float* rows, size_t stride, int p, SampleSpan span, ColumnRange cols,
                        const PatchView& patch, bool with_gradient, ResidualSums& out) {
  patch.weight ? sumsClippedOf<true>(rows, stride, p, span, cols, patch, with_gradient, out)
               : sumsClippedOf<false>(rows, stride, p, span, cols, patch, with_gradient, out);
}

/// General path: pixels invalid in the template (M == 0; rows `mask_stride`
/// bytes apart), outside the image [0, width), or touching an invalid right
/// pixel (right_valid == 0; column 0 of the patch's first row at
/// `right_valid`, rows `valid_stride` bytes apart) are left out of every sum.
/// `rows` and `stride` as for sumsAllValid. Without `with_gradient` the
/// gradient's sums are 0 and the others the same.
template <bool Weighted>
inline void sumsMaskedOf(const float* rows, size_t stride, const uchar* right_valid, size_t valid_stride,
                         int width, int p, SampleSpan span, const PatchView& patch, const uchar* M,
                         size_t mask_stride, bool with_gradient, ResidualSums& out) {
  const bool two_taps = span.frac > 0.f;
  const float w0 = 1.f - span.frac;
  float n = 0, sd = 0, sdd = 0, sgd = 0, sg = 0, sgg = 0;
  for (int y = 0; y < p; ++y) {
    const float* r = rows + y * stride;
    const uchar* rv = right_valid + y * valid_stride;
    const float* t = patch.tmpl + y * patch.stride;
    const float* g = patch.grad + y * patch.stride;
    const uchar* m = M + y * mask_stride;
    for (int i = 0; i < p; ++i) {
      const int xr = span.base + i;
      if (!m[i] || xr < 0 || xr + (two_taps ? 1 : 0) >= width) continue;
      if (!rv[xr] || (two_taps && !rv[xr + 1])) continue;
      const float w = supportWeightAt<Weighted>(patch, p, y, i);
      const float sample = two_taps ? w0 * r[xr] + span.frac * r[xr + 1] : r[xr];
      const float d = sample - t[i];
      const float wd = w * d, wg = w * g[i];
      n += w;
      sd += wd;
      sdd += wd * d;
      sgd += g[i] * wd;
      sg += wg;
      sgg += wg * g[i];
    }
  }
  out = with_gradient ? ResidualSums{n, sd, sdd, sgd, sg, sgg} : ResidualSums{n, sd, sdd, 0.f, 0.f, 0.f};
}

inline void sumsMasked(const float* rows, size_t stride, const uchar* right_valid, size_t valid_stride, int width,
                       int p, SampleSpan span, const PatchView& patch, const uchar* M, size_t mask_stride,
                       bool with_gradient, ResidualSums& out) {
  patch.weight ? sumsMaskedOf<true>(rows, stride, right_valid, valid_stride, width, p, span, patch, M, mask_stride,
                                    with_gradient, out)
               : sumsMaskedOf<false>(rows, stride, right_valid, valid_stride, width, p, span, patch, M,
                                     mask_stride, with_gradient, out);
}

/// sumsMasked without the gradient's sums at `n` (1..kMaxBatchSpans) spans of
/// the same template, into out[0..n): the propagation's costs near invalid pixels.
inline void sumsMaskedNoGradientBatch(const float* rows, size_t stride, const uchar* right_valid,
                                      size_t valid_stride, int width, int p, const SampleSpan* spans, int n,
                                      const PatchView& patch, const uchar* M, size_t mask_stride,
                                      ResidualSums* out) {
  for (int i = 0; i < n; ++i) {
    sumsMasked(rows, stride, right_valid, valid_stride, width, p, spans[i], patch, M, mask_stride,
               /*with_gradient=*/false, out[i]);
  }
}

/// sumsMasked without the gradient's sums at `samples` spans a whole `step`
/// px apart that share `frac`, sample j at column base_lo + step * (samples -
/// 1 - j) (windowCostsAllValid's order): the window costs near invalid pixels
/// or the image edge, into out[0..samples).
inline void windowSumsMasked(const float* rows, size_t stride, const uchar* right_valid, size_t valid_stride,
                             int width, int p, int base_lo, float frac, int samples, int step,
                             const PatchView& patch, const uchar* M, size_t mask_stride, ResidualSums* out) {
  for (int j = 0; j < samples; ++j) {
    const SampleSpan span{base_lo + step * (samples - 1 - j), frac};
    sumsMaskedOf<false>(rows, stride, right_valid, valid_stride, width, p, span, patch, M, mask_stride,
                        /*with_gradient=*/false, out[j]);
  }
}

/// Fusion of one patch: adds posterior * spatial weight w times the
/// disparity, w, the evidence and w times the squared disparity to the p x p
/// pixels at `num`, `den`, `conf`, `sq` (rows `stride` floats apart).
/// `spatial` is the p x p Gaussian, row-major.
inline void accumulatePatch(int p, const float* spatial, float posterior, float disparity, float evidence,
                            float* num, float* den, float* conf, float* sq, size_t stride) {
  for (int y = 0; y < p; ++y) {
    const float* g = spatial + y * p;
    float* nr = num + y * stride;
    float* dr = den + y * stride;
    float* cr = conf + y * stride;
    float* qr = sq + y * stride;
    for (int x = 0; x < p; ++x) {
      const float w = posterior * g[x];
      const float wd = w * disparity;
      nr[x] += wd;
      dr[x] += w;
      cr[x] += evidence;
      qr[x] += wd * disparity;
    }
  }
}

/// The unmasked inner loops, as one swappable set: a scalar reference for
/// any patch size, and fixed-size versions (lane accumulators the compiler
/// vectorises) built once with the baseline instruction set and once for AVX2.
/// They take raw row pointers so the AVX2 translation unit calls no inline
/// function shared with other units (a shared inline compiled for AVX2 could
/// be picked by the linker for every caller).
/// The fixed-size sums_clipped reads columns base .. base + p of every row,
/// also outside `cols` (and multiplies them by 0): those must be readable and
/// finite, which the pyramid's padded right rows (kRightPadding) guarantee.
/// The fixed-size sums_masked reads the same columns of the right image and
/// of its validity, whose padding must be 0 (invalid): that, not a bounds
/// test, leaves the columns outside the image out.
struct KernelSet {
  const char* name;
  void (*sums_all_valid)(const float* rows, size_t stride, int p, SampleSpan span,
                         const PatchView& patch, ResidualSums& out);
  void (*sums_all_valid_no_gradient)(const float* rows, size_t stride, int p, SampleSpan span,
                                     const PatchView& patch, ResidualSums& out);
  /// The same sums, bit for bit, at up to kMaxBatchSpans spans: the template
  /// is read once and the spans' accumulators run side by side.
  void (*sums_no_gradient_batch)(const float* rows, size_t stride, int p, const SampleSpan* spans,
                                 int n, const PatchView& patch, ResidualSums* out);
  void (*sums_clipped)(const float* rows, size_t stride, int p, SampleSpan span, ColumnRange cols,
                       const PatchView& patch, bool with_gradient, ResidualSums& out);
  void (*window_costs)(const float* rows, size_t stride, int p, int base_lo, float frac, int samples,
                       int step, const PatchView& patch, bool mean_normalization, float* row_buf,
                       float* sum, float* sum_sq, float* costs);
  void (*sums_masked)(const float* rows, size_t stride, const uchar* right_valid, size_t valid_stride,
                      int width, int p, SampleSpan span, const PatchView& patch, const uchar* M,
                      size_t mask_stride, bool with_gradient, ResidualSums& out);
  /// sums_masked without the gradient's sums at up to kMaxBatchSpans spans,
  /// bit for bit, the template read once. The fixed-size version reads
  /// columns base .. base + p of every span, which must lie within the padding.
  void (*sums_masked_no_gradient_batch)(const float* rows, size_t stride, const uchar* right_valid,
                                        size_t valid_stride, int width, int p, const SampleSpan* spans, int n,
                                        const PatchView& patch, const uchar* M, size_t mask_stride,
                                        ResidualSums* out);
  /// The plain sums_masked without the gradient's sums (the view's weights
  /// unread) at a window's samples, bit for bit, the template read once for
  /// all of them. The fixed-size version reads every column base_lo ..
  /// base_lo + p + step * (samples - 1) of the right image and its validity,
  /// which must lie within the padding.
  void (*window_sums_masked)(const float* rows, size_t stride, const uchar* right_valid, size_t valid_stride,
                             int width, int p, int base_lo, float frac, int samples, int step,
                             const PatchView& patch, const uchar* M, size_t mask_stride, ResidualSums* out);
  void (*accumulate_patch)(int p, const float* spatial, float posterior, float disparity, float evidence,
                           float* num, float* den, float* conf, float* sq, size_t stride);
  void (*template_sums)(int p, const PatchView& patch, TemplateSums& out);
  float (*support_weights)(int p, const PatchView& patch, float centre, float inv_grey_sq, float* weights,
                           TemplateSums* sums);
  /// template_sums of a plain view, and in the same pass maxSquaredDeviation
  /// from `centre` (returned): whether the patch spans an edge.
  float (*template_sums_and_deviation)(int p, const PatchView& patch, float centre, TemplateSums& out);
  /// The same set for views with support weights: its sums read the view's
  /// weights, while this set's fixed-size sums leave them unread (the plain
  /// path pays nothing for them). The scalar set serves both.
  const KernelSet* weighted;
};

/// Columns every right-image row of the pyramid has readable (and zero) on
/// each side, so fixed-size kernels may read a whole patch row at a match
/// past the image edge: one patch (p <= 32) plus the second tap.
constexpr int kRightPadding = 40;

enum class KernelIsa { Scalar, Baseline, Avx2 };

/// The kernels for `patch_size` on `isa`; the scalar set where no fixed-size
/// version exists for that size or the ISA was not built.
const KernelSet& kernelsFor(int patch_size, KernelIsa isa);

/// The best ISA this CPU runs; the environment variable BDIS_SIMD=off forces
/// the scalar kernels and BDIS_SIMD=baseline the baseline ones (to compare
/// results or rule the SIMD path out). Read when a matcher's parameters are set.
KernelIsa bestKernelIsa();

/// Whether `isa` was built into this library and runs on this CPU.
bool kernelIsaAvailable(KernelIsa isa);

}  // namespace detail
}  // namespace bdis
