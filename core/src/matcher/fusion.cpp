#include "fusion.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "bdis_stereo/matcher.hpp"  // kNoDisparity
#include "confidence.hpp"

namespace bdis {
namespace detail {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// Per-row loops: their rows are __restrict parameters, without which GCC
// gives up vectorising for the possible aliases between outputs and inputs.

/// Fused disparity where any patch survived, else the coarser level's.
BDIS_ROW_LOOP
void fusedRow(int n, const float* __restrict num, const float* __restrict den, const float* __restrict coarser,
              float* __restrict out) {
  for (int x = 0; x < n; ++x) {
    const float d = num[x] / std::max(den[x], std::numeric_limits<float>::min());
    out[x] = den[x] > 0.f ? d : coarser[x];
  }
}

/// fusedRow, and the squared spread of the covering patches' disparities
/// around the fused one: their weighted variance, sq / den - fused^2. One
/// reciprocal of den serves both.
BDIS_ROW_LOOP
void fusedAndSpreadSquaredRow(int n, const float* __restrict num, const float* __restrict den,
                              const float* __restrict sq, const float* __restrict coarser, float* __restrict fused,
                              float* __restrict spread_sq) {
  for (int x = 0; x < n; ++x) {
    const float inv_den = 1.f / std::max(den[x], std::numeric_limits<float>::min());
    const float f = num[x] * inv_den;
    fused[x] = den[x] > 0.f ? f : coarser[x];
    spread_sq[x] = std::max(0.f, sq[x] * inv_den - fused[x] * fused[x]);
  }
}

/// The finest level's output row: fused disparity and confidence where some
/// patch survived and the covering patches' mean evidence reaches the floor.
/// The confidence is that evidence times the agreement of their
/// disparities: the floor gates on what the patches' posteriors say, the
/// confidence also ranks by where they disagree.
BDIS_ROW_LOOP
void floorRow(int n, const float* __restrict fused, const float* __restrict den,
              const float* __restrict spread_sq, const float* __restrict conf_sum,
              const float* __restrict inv_cover_x, float inv_cover_y, float inv_spread_halving_sq,
              float confidence_floor, float* __restrict disparity, float* __restrict confidence) {
  for (int x = 0; x < n; ++x) {
    const float f = fused[x];
    const float evidence = conf_sum[x] * (inv_cover_y * inv_cover_x[x]);
    const float conf = evidence * agreement(spread_sq[x], inv_spread_halving_sq);
    const bool keep = (den[x] > 0.f) & (evidence >= confidence_floor);  // & : no branch
    const float d = keep ? f : kNoDisparity, c = keep ? conf : 0.f;
    disparity[x] = d;
    confidence[x] = c;
  }
}

/// One over the number of patches covering each pixel along one axis of a
/// level (infinite where none does): the mean evidence is then a product,
/// not a division per pixel.
void inverseCoverAlongAxis(const std::vector<int>& origins, int p, std::vector<float>& inv_cover, int extent) {
  std::fill(inv_cover.begin(), inv_cover.begin() + extent, 0.f);
  for (int o : origins) {
    for (int i = o; i < o + p; ++i) inv_cover[static_cast<size_t>(i)] += 1.f;
  }
  for (int i = 0; i < extent; ++i) inv_cover[static_cast<size_t>(i)] = 1.f / inv_cover[static_cast<size_t>(i)];
}

void clearRows(cv::Mat1f& m, int from, int width) {
  for (int y = from; y < m.rows; ++y) std::fill(m[y], m[y] + width, 0.f);
}

/// Moves the `kept` rows from band row `first` up to row 0 and clears the rest.
void carryRows(cv::Mat1f& m, int first, int kept, int width) {
  for (int y = 0; y < kept; ++y) std::copy(m[first + y], m[first + y] + width, m[y]);
  clearRows(m, kept, width);
}

}  // namespace

void coarserLevelRow(const cv::Mat1f& coarse, int y, int width, float* out) {
  const float* c = coarse[std::min(y / 2, coarse.rows - 1)];
  // Pixels 2 bx and 2 bx + 1 read block bx; past the map's last column, the last.
  const int pairs = std::min(coarse.cols, width / 2);
  for (int bx = 0; bx < pairs; ++bx) {
    const float value = 2.f * c[bx];
    out[2 * bx] = value;
    out[2 * bx + 1] = value;
  }
  for (int x = 2 * pairs; x < width; ++x) out[x] = 2.f * c[std::min(x / 2, coarse.cols - 1)];
}

/// Fusion without a variance: every step a no-op.
struct Fusion::NoVariance {
  void clear(int) {}
  void carry(int, int) {}
  void addPatch(const float*, int, const PatchEstimate&, int, int) {}
  void finishRow(int, const float*, const float*, int) const {}
};

/// The squared-weight average of the covering patches' variances: sums of
/// w^2 v and w^2 per pixel of the band, w = posterior x spatial weight.
class Fusion::VarianceSums {
 public:
  VarianceSums(cv::Mat1f& num, cv::Mat1f& den, int width, float max_variance, cv::Mat1f& out)
      : num_(num), den_(den), width_(width), max_variance_(max_variance), out_(out) {}
  void clear(int from) {
    clearRows(num_, from, width_);
    clearRows(den_, from, width_);
  }
  void carry(int first, int kept) {
    carryRows(num_, first, kept, width_);
    carryRows(den_, first, kept, width_);
  }
  void addPatch(const float* spatial, int p, const PatchEstimate& e, int by, int x0) {
    for (int y = 0; y < p; ++y) {
      const float* g = spatial + y * p;
      float* vn = num_[by + y] + x0;
      float* vd = den_[by + y] + x0;
      for (int x = 0; x < p; ++x) {
        const float wt = e.posterior * g[x];
        vn[x] += wt * wt * e.variance;
        vd[x] += wt * wt;
      }
    }
  }
  /// Output row y from band row `by`: NaN where `disparity` has no estimate;
  /// else the covering patches' window variances (the maximal variance
  /// where the squared weights underflowed: a tiny sigma_s), scaled to what
  /// the errors show, plus the squared spread of their disparities.
  void finishRow(int by, const float* disparity, const float* spread_sq, int y) const {
    const float* vn = num_[by];
    const float* vd = den_[by];
    float* out = out_[y];
    for (int x = 0; x < width_; ++x) {
      const float window = vd[x] > 0.f ? vn[x] / vd[x] : max_variance_;
      out[x] = disparity[x] < 0.f ? kNaN : kWindowVarianceShare * window + kSpreadVarianceShare * spread_sq[x];
    }
  }

 private:
  cv::Mat1f& num_;
  cv::Mat1f& den_;
  int width_;
  float max_variance_;
  cv::Mat1f& out_;
};

void Fusion::configure(const KernelSet& kernels, int patch_size, float sigma_s, float confidence_floor,
                       float max_variance) {
  kernels_ = &kernels;
  p_ = patch_size;
  confidence_floor_ = confidence_floor;
  max_variance_ = max_variance;
  const int n = patch_size;
  const float c = 0.5f * static_cast<float>(n - 1);
  const float inv2s2 = 1.f / (2.f * sigma_s * sigma_s);
  spatial_.resize(static_cast<size_t>(n) * static_cast<size_t>(n));
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) {
      const float dx = static_cast<float>(x) - c, dy = static_cast<float>(y) - c;
      spatial_[static_cast<size_t>(y * n + x)] = std::exp(-(dx * dx + dy * dy) * inv2s2);
    }
  }
}

void Fusion::allocate(int band_rows, int max_width, int max_height, bool with_variance) {
  for (cv::Mat1f* m : {&num_, &den_, &conf_, &sq_}) m->create(band_rows, max_width);
  if (with_variance) {
    var_num_.create(band_rows, max_width);
    var_den_.create(band_rows, max_width);
  }
  inv_cover_x_.resize(static_cast<size_t>(max_width));
  inv_cover_y_.resize(static_cast<size_t>(max_height));
  fused_row_.resize(static_cast<size_t>(max_width));
  coarser_row_.resize(static_cast<size_t>(max_width));
  spread_sq_row_.resize(static_cast<size_t>(max_width));
}

template <class Variance, class FinishRows>
void Fusion::accumulate(const PatchGrid& grid, const std::vector<PatchEstimate>& estimates, int width,
                        int height, Variance& variance, FinishRows&& finish) {
  const int p = p_;
  // The band holds level rows [band_top, band_top + band_rows). Patch rows
  // come top to bottom, so when the next one does not fit, the rows above it
  // are final: they are finished, the rest moves up and the band follows.
  // Every pixel sums its patches in the same order as over a whole-level buffer.
  const int band_rows = num_.rows;
  int band_top = 0;
  for (cv::Mat1f* m : {&num_, &den_, &conf_, &sq_}) clearRows(*m, 0, width);
  variance.clear(0);
  // The grid is regular: the patches covering a pixel are those covering its
  // column times those covering its row.
  inverseCoverAlongAxis(grid.xs, p, inv_cover_x_, width);
  inverseCoverAlongAxis(grid.ys, p, inv_cover_y_, height);

  const size_t stride = num_.step1();
  size_t k = 0;
  for (int y0 : grid.ys) {
    if (y0 + p > band_top + band_rows) {
      finish(band_top, y0);
      const int kept = band_top + band_rows - y0;  // < p: rows the next patches add to
      for (cv::Mat1f* m : {&num_, &den_, &conf_, &sq_}) carryRows(*m, y0 - band_top, kept, width);
      variance.carry(y0 - band_top, kept);
      band_top = y0;
    }
    const int by = y0 - band_top;
    for (int x0 : grid.xs) {
      const PatchEstimate& e = estimates[k++];
      if (e.posterior <= 0.f) continue;
      kernels_->accumulate_patch(p, spatial_.data(), e.posterior, e.disparity, e.evidence, num_[by] + x0,
                                 den_[by] + x0, conf_[by] + x0, sq_[by] + x0, stride);
      variance.addPatch(spatial_.data(), p, e, by, x0);
    }
  }
  finish(band_top, height);
}

void Fusion::fusedRowOrCoarse(int width, int by, int y, const cv::Mat1f& coarse, float* out) {
  // The holes are not rare (the strip whose matches leave the right view,
  // dark tissue): a select over the whole row, not a branch per pixel.
  coarserLevelRow(coarse, y, width, coarser_row_.data());
  fusedRow(width, num_[by], den_[by], coarser_row_.data(), out);
}

void Fusion::fuseInitialisation(const PatchGrid& grid, const std::vector<PatchEstimate>& estimates,
                                const cv::Mat1f& coarse, cv::Mat1f& init) {
  NoVariance none;
  const int width = init.cols;
  accumulate(grid, estimates, width, init.rows, none, [&](int band_top, int end) {
    for (int y = band_top; y < end; ++y) fusedRowOrCoarse(width, y - band_top, y, coarse, init[y]);
  });
}

void Fusion::fuseFinest(const PatchGrid& grid, const std::vector<PatchEstimate>& estimates, int width,
                        int height, const cv::Mat1f& coarse, float spread_halving, bool keep_confidence,
                        bool with_variance, LevelMaps& out) {
  const float inv_spread_halving_sq = 1.f / (spread_halving * spread_halving);
  auto finish = [&](int band_top, int end, auto& variance) {
    for (int y = band_top; y < end; ++y) {
      const int by = y - band_top;
      coarserLevelRow(coarse, y, width, coarser_row_.data());
      fusedAndSpreadSquaredRow(width, num_[by], den_[by], sq_[by], coarser_row_.data(), fused_row_.data(),
                               spread_sq_row_.data());
      float* disparity = out.disparity[y];
      floorRow(width, fused_row_.data(), den_[by], spread_sq_row_.data(), conf_[by], inv_cover_x_.data(),
               inv_cover_y_[static_cast<size_t>(y)], inv_spread_halving_sq, confidence_floor_, disparity,
               out.confidence[keep_confidence ? y : 0]);
      variance.finishRow(by, disparity, spread_sq_row_.data(), y);
    }
  };
  if (with_variance) {
    VarianceSums variance(var_num_, var_den_, width, max_variance_, out.variance);
    accumulate(grid, estimates, width, height, variance,
               [&](int band_top, int end) { finish(band_top, end, variance); });
  } else {
    NoVariance none;
    accumulate(grid, estimates, width, height, none, [&](int band_top, int end) { finish(band_top, end, none); });
  }

}

}  // namespace detail
}  // namespace bdis
