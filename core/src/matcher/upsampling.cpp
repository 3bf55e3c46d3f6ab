#include "upsampling.hpp"

#include <algorithm>
#include <limits>
#include <utility>

#include "patch_kernels.hpp"  // BDIS_ROW_LOOP

namespace bdis {
namespace detail {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

/// Blends two level rows with weights (1 - a, a), counting only pixels with
/// an estimate: the weight, weighted disparity and, with kConfidence,
/// weighted confidence.
template <bool kConfidence>
inline __attribute__((always_inline)) void blendRowsOf(int n, const float* __restrict d0, const float* __restrict d1,
                                                       const float* __restrict c0, const float* __restrict c1, float a,
                                                       float* __restrict weight, float* __restrict disparity,
                                                       float* __restrict confidence) {
  for (int x = 0; x < n; ++x) {
    const float w0 = d0[x] >= 0.f ? 1.f - a : 0.f;
    const float w1 = d1[x] >= 0.f ? a : 0.f;
    weight[x] = w0 + w1;
    disparity[x] = w0 * d0[x] + w1 * d1[x];
    if (kConfidence) confidence[x] = w0 * c0[x] + w1 * c1[x];
  }
}

// One function per variant, each cloned per ISA (BDIS_ROW_LOOP does not take templates).
BDIS_ROW_LOOP
void blendRows(int n, const float* d0, const float* d1, const float* c0, const float* c1, float a, float* weight,
               float* disparity, float* confidence) {
  blendRowsOf<true>(n, d0, d1, c0, c1, a, weight, disparity, confidence);
}
BDIS_ROW_LOOP
void blendDisparityRows(int n, const float* d0, const float* d1, float a, float* weight, float* disparity) {
  blendRowsOf<false>(n, d0, d1, nullptr, nullptr, a, weight, disparity, nullptr);
}

/// dst[x] = (1 - ax[x]) src[x0[x]] + ax[x] src[x1[x]]: one level row
/// interpolated to the output columns.
void interpolateColumns(int n, const int* x0, const int* x1, const float* ax, const float* __restrict src,
                        float* __restrict dst) {
  for (int x = 0; x < n; ++x) dst[x] = (1.f - ax[x]) * src[x0[x]] + ax[x] * src[x1[x]];
}

/// The same for exactly k = 2^s times the level width (the usual case:
/// k = 2 at 640 px, 8 at 1920 px with the default levels), where the taps
/// repeat: the k output columns from k i + k/2 on lie (m + 0.5) / k of the
/// way from level column i to i + 1 (m = 0..k-1), and the k/2 outermost
/// columns on each side copy the outermost level columns. The weights are
/// exact in float, so the values are those of interpolateColumns, from a
/// loop that vectorises.
template <int K>
inline __attribute__((always_inline)) void interpolateColumnsBy(int level_width, const float* __restrict src,
                                                                float* __restrict dst) {
  constexpr int kHalf = K / 2;
  for (int j = 0; j < kHalf; ++j) dst[j] = src[0];
  for (int i = 0; i + 1 < level_width; ++i) {
    const float a = src[i], b = src[i + 1];
    float* __restrict out = dst + K * i + kHalf;
    for (int m = 0; m < K; ++m) {
      const float w = (static_cast<float>(m) + 0.5f) / static_cast<float>(K);
      out[m] = (1.f - w) * a + w * b;
    }
  }
  for (int j = 0; j < kHalf; ++j) dst[K * level_width - kHalf + j] = src[level_width - 1];
}

// One function per factor, each cloned per ISA (BDIS_ROW_LOOP does not take templates).
BDIS_ROW_LOOP
void interpolateColumnsBy2(int level_width, const float* src, float* dst) {
  interpolateColumnsBy<2>(level_width, src, dst);
}
BDIS_ROW_LOOP
void interpolateColumnsBy4(int level_width, const float* src, float* dst) {
  interpolateColumnsBy<4>(level_width, src, dst);
}
BDIS_ROW_LOOP
void interpolateColumnsBy8(int level_width, const float* src, float* dst) {
  interpolateColumnsBy<8>(level_width, src, dst);
}
BDIS_ROW_LOOP
void interpolateColumnsBy16(int level_width, const float* src, float* dst) {
  interpolateColumnsBy<16>(level_width, src, dst);
}

using ColumnInterpolation = void (*)(int level_width, const float* src, float* dst);

/// The loop for exactly `factor` times the level width; null for another width.
ColumnInterpolation integerColumnInterpolation(int factor, int out_width, int level_width) {
  if (out_width != factor * level_width) return nullptr;
  switch (factor) {
    case 2:
      return interpolateColumnsBy2;
    case 4:
      return interpolateColumnsBy4;
    case 8:
      return interpolateColumnsBy8;
    case 16:
      return interpolateColumnsBy16;
    default:
      return nullptr;
  }
}

/// Final output row: weighted means where the input pixel is valid and the
/// estimates around it carry more than a quarter of the weight; the
/// confidence too with kConfidence.
template <bool kConfidence>
inline __attribute__((always_inline)) void upsampledRowOf(int n, const uchar* __restrict valid,
                                                          const float* __restrict weight,
                                                          const float* __restrict disparity,
                                                          const float* __restrict confidence, float scale,
                                                          float* __restrict d_out, float* __restrict c_out) {
  for (int x = 0; x < n; ++x) {
    const bool keep = (valid[x] != 0) & (weight[x] > 0.25f);  // & : no branch
    const float inv_w = 1.f / std::max(weight[x], 0.25f);  // one division for both maps
    const float d = scale * disparity[x] * inv_w;
    d_out[x] = keep ? d : kNoDisparity;
    if (kConfidence) {
      const float c = confidence[x] * inv_w;
      c_out[x] = keep ? c : 0.f;
    }
  }
}

BDIS_ROW_LOOP
void upsampledRow(int n, const uchar* valid, const float* weight, const float* disparity, const float* confidence,
                  float scale, float* d_out, float* c_out) {
  upsampledRowOf<true>(n, valid, weight, disparity, confidence, scale, d_out, c_out);
}
BDIS_ROW_LOOP
void upsampledDisparityRow(int n, const uchar* valid, const float* weight, const float* disparity, float scale,
                           float* d_out) {
  upsampledRowOf<false>(n, valid, weight, disparity, nullptr, scale, d_out, nullptr);
}

/// Level row and weight of output row y: rows y0 and y1 with weight (1 - a, a).
struct RowTaps {
  int y0, y1;
  float a;
};

RowTaps rowTaps(int y, int level_height, float inv_scale) {
  const float fy = std::clamp((static_cast<float>(y) + 0.5f) * inv_scale - 0.5f, 0.f,
                              static_cast<float>(level_height - 1));
  const int y0 = static_cast<int>(fy);
  return {y0, std::min(y0 + 1, level_height - 1), fy - static_cast<float>(y0)};
}

}  // namespace

void Upsampler::columnTaps(int out_width, int level_width, float inv_scale) {
  x0_.resize(static_cast<size_t>(out_width));
  x1_.resize(static_cast<size_t>(out_width));
  ax_.resize(static_cast<size_t>(out_width));
  for (int x = 0; x < out_width; ++x) {
    const float fx = std::clamp((static_cast<float>(x) + 0.5f) * inv_scale - 0.5f, 0.f,
                                static_cast<float>(level_width - 1));
    x0_[static_cast<size_t>(x)] = static_cast<int>(fx);
    x1_[static_cast<size_t>(x)] = std::min(static_cast<int>(fx) + 1, level_width - 1);
    ax_[static_cast<size_t>(x)] = fx - static_cast<float>(static_cast<int>(fx));
  }
}

void Upsampler::upsample(const LevelMaps& level, int s, const cv::Mat1b& full_valid, bool with_confidence,
                         MatchResult& out) {
  const int W = full_valid.cols, H = full_valid.rows;
  const int level_width = level.disparity.cols, level_height = level.disparity.rows;
  out.disparity.create(H, W, CV_32FC1);
  if (with_confidence) {
    out.confidence.create(H, W, CV_32FC1);
  } else {
    out.confidence.release();
  }
  const float scale = static_cast<float>(1 << s);
  const float inv = 1.f / scale;
  const ColumnInterpolation by_factor = integerColumnInterpolation(1 << s, W, level_width);
  columnTaps(W, level_width, inv);
  for (std::vector<float>* v : {&weight_, &disparity_, &confidence_}) {
    v->resize(static_cast<size_t>(std::max(W, level_width)));
  }
  for (std::vector<float>* v : {&row_weight_, &row_disparity_, &row_confidence_}) v->resize(static_cast<size_t>(W));
  const auto interpolate = [&](const float* level_row, float* out_row) {
    if (by_factor) {
      by_factor(level_width, level_row, out_row);
    } else {
      interpolateColumns(W, x0_.data(), x1_.data(), ax_.data(), level_row, out_row);
    }
  };
  for (int y = 0; y < H; ++y) {
    // Blend the two level rows first (weights of rows with an estimate, and
    // weighted values), then the two columns of each output pixel.
    const RowTaps t = rowTaps(y, level_height, inv);
    if (with_confidence) {
      blendRows(level_width, level.disparity[t.y0], level.disparity[t.y1], level.confidence[t.y0],
                level.confidence[t.y1], t.a, weight_.data(), disparity_.data(), confidence_.data());
    } else {
      blendDisparityRows(level_width, level.disparity[t.y0], level.disparity[t.y1], t.a, weight_.data(),
                         disparity_.data());
    }
    interpolate(weight_.data(), row_weight_.data());
    interpolate(disparity_.data(), row_disparity_.data());
    if (with_confidence) {
      interpolate(confidence_.data(), row_confidence_.data());
      upsampledRow(W, full_valid[y], row_weight_.data(), row_disparity_.data(), row_confidence_.data(), scale,
                   out.disparity.ptr<float>(y), out.confidence.ptr<float>(y));
    } else {
      upsampledDisparityRow(W, full_valid[y], row_weight_.data(), row_disparity_.data(), scale,
                            out.disparity.ptr<float>(y));
    }
  }
}

void Upsampler::upsampleVariance(const LevelMaps& level, int s, MatchResult& out, float calibration) {
  const int W = out.disparity.cols, H = out.disparity.rows;
  const int level_width = level.disparity.cols, level_height = level.disparity.rows;
  out.variance.create(H, W, CV_32FC1);
  const float scale = static_cast<float>(1 << s);
  const float inv = 1.f / scale;
  const float var_scale = scale * scale * calibration;
  variance_.resize(static_cast<size_t>(level_width));
  for (int y = 0; y < H; ++y) {
    const RowTaps t = rowTaps(y, level_height, inv);
    const float *d0 = level.disparity[t.y0], *d1 = level.disparity[t.y1];
    const float *v0 = level.variance[t.y0], *v1 = level.variance[t.y1];
    // The weights of upsample()'s blend, and the variances blended alike
    // (NaN where there is no estimate: only weighted where there is one).
    for (int x = 0; x < level_width; ++x) {
      const float w0 = d0[x] >= 0.f ? 1.f - t.a : 0.f;
      const float w1 = d1[x] >= 0.f ? t.a : 0.f;
      weight_[static_cast<size_t>(x)] = w0 + w1;
      variance_[static_cast<size_t>(x)] = (d0[x] >= 0.f ? (1.f - t.a) * v0[x] : 0.f) + (d1[x] >= 0.f ? t.a * v1[x] : 0.f);
    }
    const float* d_out = out.disparity.ptr<float>(y);
    float* v_out = out.variance.ptr<float>(y);
    for (int x = 0; x < W; ++x) {
      const size_t i0 = static_cast<size_t>(x0_[static_cast<size_t>(x)]);
      const size_t i1 = static_cast<size_t>(x1_[static_cast<size_t>(x)]);
      const float ax = ax_[static_cast<size_t>(x)];
      const float wsum = (1.f - ax) * weight_[i0] + ax * weight_[i1];
      const float vsum = (1.f - ax) * variance_[i0] + ax * variance_[i1];
      v_out[x] = d_out[x] >= 0.f ? var_scale * vsum / wsum : kNaN;
    }
  }
}

}  // namespace detail
}  // namespace bdis
