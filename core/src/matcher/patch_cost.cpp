#include "patch_cost.hpp"

#include <algorithm>
#include <cmath>

namespace bdis {
namespace detail {
namespace {

/// Adds each column's invalid pixels (valid is 0 or 1) of one mask row to `count`.
BDIS_ROW_LOOP
void countInvalidRow(int w, const uchar* __restrict valid, uchar* __restrict count) {
  for (int x = 0; x < w; ++x) count[x] = static_cast<uchar>(count[x] + 1 - valid[x]);
}

/// The invalid pixels of rows y0 .. y0 + p - 1 of `valid` per column, as
/// prefix sums along the row; false when there are none.
bool bandPrefix(const uchar* valid, size_t stride, int w, int p, uchar* count, int* prefix) {
  std::fill(count, count + w, uchar{0});
  for (int y = 0; y < p; ++y) countInvalidRow(w, valid + static_cast<size_t>(y) * stride, count);
  int sum = 0;
  prefix[0] = 0;
  for (int x = 0; x < w; ++x) {
    sum += count[x];
    prefix[x + 1] = sum;
  }
  return sum > 0;
}

size_t rowStride(const cv::Mat1f& m) { return m.step1(); }

}  // namespace

void PatchCost::configure(const KernelSet& kernels, int patch_size, bool mean_normalization,
                          int window_half_width, float window_step, int band_rows) {
  kept_bands_ = band_rows > 0 ? std::min(band_rows, kMaxKeptBands) : kMaxKeptBands;
  kernels_ = &kernels;
  search_kernels_ = &kernels;
  p_ = patch_size;
  centre_index_[0] = static_cast<size_t>(patch_size - 1) / 2;
  centre_index_[1] = static_cast<size_t>(patch_size) / 2;
  mean_normalization_ = mean_normalization;
  window_half_width_ = window_half_width;
  window_step_ = window_step;
}

void PatchCost::allocate(int max_width) {
  const size_t window = static_cast<size_t>(2 * window_half_width_ + 1);
  const int max_window_span =
      static_cast<int>(std::ceil(2.f * static_cast<float>(window_half_width_) * window_step_));
  row_buf_.resize(static_cast<size_t>(p_ + max_window_span + 2));
  window_sum_.resize(window);
  window_sq_.resize(window);
  window_sums_.resize(window);
  const size_t prefix_len = static_cast<size_t>(max_width) + 1;
  kept_prefix_.resize(2 * static_cast<size_t>(kept_bands_) * prefix_len);
  kept_.resize(static_cast<size_t>(kept_bands_));
  for (size_t i = 0; i < kept_.size(); ++i) {
    kept_[i].left_prefix = kept_prefix_.data() + 2 * i * prefix_len;
    kept_[i].right_prefix = kept_[i].left_prefix + prefix_len;
  }
  column_count_.resize(static_cast<size_t>(max_width));
  support_weights_.resize(static_cast<size_t>(p_) * static_cast<size_t>(p_));
  forgetBands();
}

void PatchCost::useSupportWeights(float grey, float edge_grey) {
  support_inv_grey_sq_ = grey > 0.f ? 1.f / (grey * grey) : 0.f;
  support_edge_sq_ = edge_grey * edge_grey;
  search_kernels_ = kernels_;
}

void PatchCost::forgetBands() {
  for (ValidityBand& band : kept_) band.y0 = -1;
  next_kept_ = 0;
  band_.y0 = -1;
}

void PatchCost::loadBand(const PyramidLevel& L, int y0) {
  for (const ValidityBand& band : kept_) {
    if (band.y0 == y0) {
      band_ = band;
      return;
    }
  }
  ValidityBand& band = kept_[static_cast<size_t>(next_kept_)];
  // kept_ as allocated: a configure() since may have changed kept_bands_.
  next_kept_ = (next_kept_ + 1) % static_cast<int>(kept_.size());
  band.y0 = y0;
  band.left_all_valid = L.left_all_valid ||
      !bandPrefix(L.leftValidRow(y0), L.left_valid.step1(), L.width, p_, column_count_.data(), band.left_prefix);
  band.right_all_valid = L.right_all_valid ||
      !bandPrefix(L.rightValidRow(y0), L.right_valid.step1(), L.width, p_, column_count_.data(), band.right_prefix);
  band_ = band;
}

void PatchCost::setPatch(const PyramidLevel& L, int x0, int y0, bool left_all_valid,
                         const TemplateSums& constants) {
  cur_.level = &L;
  cur_.x0 = x0;
  cur_.y0 = y0;
  cur_.view = {L.leftRow(y0) + x0, L.gradientRow(y0) + x0, rowStride(L.left)};
  cur_.valid = L.leftValidRow(y0) + x0;
  cur_.left_all_valid = left_all_valid;
  cur_.no_invalid_pixels = left_all_valid && band_.right_all_valid;
  cur_.right_rows = L.rightRow(y0);
  cur_.right_stride = rowStride(L.right);
  cur_.width = L.width;
  cur_.constants = constants;
  // With support weights, decided when a sum is first asked for (searchView), unless recalled.
  support_resolved_ = false;
}

bool PatchCost::supportCentreOfValid(float& centre) const {
  const float* t = cur_.view.tmpl;
  const size_t stride = cur_.view.stride;
  const size_t valid_stride = cur_.level->left_valid.step1();
  float sum = 0.f, count = 0.f;
  for (size_t y : centre_index_) {
    for (size_t x : centre_index_) {
      if (!cur_.valid[y * valid_stride + x]) continue;
      sum += t[y * stride + x];
      count += 1.f;
    }
  }
  if (count == 0.f) return false;
  centre = sum / count;
  return true;
}

bool PatchCost::searchWeighted(float centre, TemplateSums* sums) {
  TemplateSums weighted;
  const float inv_grey_sq = support_inv_grey_sq_ / supportContrastShareSq(centre);
  const float support = kernels_->support_weights(p_, cur_.view, centre, inv_grey_sq,
                                                  support_weights_.data(), sums ? &weighted : nullptr);
  if (support < kMinSupportShare * static_cast<float>(p_ * p_)) {
    searchPlain();
    return false;
  }
  if (sums) *sums = weighted;
  weighted_view_ = cur_.view;
  weighted_view_.weight = support_weights_.data();
  search_view_ = &weighted_view_;
  search_kernels_ = kernels_->weighted;
  return true;
}

void PatchCost::resolveSupportWeights(SupportWeighting known) {
  support_resolved_ = true;
  float centre = 0.f;
  // Without a valid centre there is nothing to be like: every pixel weighs the same.
  if (known == SupportWeighting::Plain || !supportCentre(centre)) {
    searchPlain();
    return;
  }
  // Rare here (loadPatch decides the fully valid templates): the scalar test.
  if (known == SupportWeighting::Unknown && support_edge_sq_ > 0.f &&
      maxSquaredDeviation(p_, cur_.view, centre) <= support_edge_sq_ * supportContrastShareSq(centre)) {
    searchPlain();
    return;
  }
  searchWeighted(centre, nullptr);
}

void PatchCost::loadPatch(const PyramidLevel& L, int x0, int y0, bool left_all_valid) {
  setPatch(L, x0, y0, left_all_valid, cur_.constants);
  if (!left_all_valid) return;
  if (support_inv_grey_sq_ > 0.f) {
    loadSupportWeighted();
    return;
  }
  kernels_->template_sums(p_, cur_.view, cur_.constants);
}

void PatchCost::loadSupportWeighted() {
  // The plain constants and how far the template strays from its centre in
  // one pass; for a patch with an edge, the weights and the constants under
  // them in another.
  support_resolved_ = true;
  float centre = 0.f;
  supportCentre(centre);
  if (support_edge_sq_ > 0.f) {
    if (kernels_->template_sums_and_deviation(p_, cur_.view, centre, cur_.constants) <=
        support_edge_sq_ * supportContrastShareSq(centre)) {
      searchPlain();
    } else {
      searchWeighted(centre, &cur_.constants);  // or plain, on the plain constants
    }
    return;
  }
  if (!searchWeighted(centre, &cur_.constants)) kernels_->template_sums(p_, cur_.view, cur_.constants);
}

void PatchCost::sums(float u, ResidualSums& r, bool with_gradient) {
  const PatchView& view = searchView();  // first: it picks search_kernels_
  sumsOf(*search_kernels_, view, u, r, with_gradient);
}

void PatchCost::sumsOf(const KernelSet& k, const PatchView& view, float u, ResidualSums& r, bool with_gradient) {
  const SampleSpan span = sampleSpan(cur_.x0, u);
  // Fast path: the span and its right neighbour column inside the image and valid.
  if (allValidColumns(span.base, span.base + p_ + 1)) {
    (with_gradient ? k.sums_all_valid : k.sums_all_valid_no_gradient)(
        cur_.right_rows, cur_.right_stride, p_, span, view, r);
    r.g = cur_.constants.g;
    r.g_sq = cur_.constants.g_sq;
    return;
  }
  sumsNearInvalidOrEdge(k, view, span, with_gradient, r);
}

void PatchCost::sumsNearInvalidOrEdge(const KernelSet& k, const PatchView& view, SampleSpan span,
                                      bool with_gradient, ResidualSums& r) {
  const PyramidLevel& L = *cur_.level;
  // Near or past the image edge with a fully valid template: sum over the
  // columns inside the image, if those are valid.
  if (cur_.left_all_valid) {
    const ColumnRange cols = columnsInside(L.width, p_, span);
    const int taps = span.frac > 0.f ? 1 : 0;
    const int lo = span.base + cols.begin, hi = span.base + cols.end + taps;
    if (cols.empty() || band_.rightInvalid(lo, hi) == 0) {
      k.sums_clipped(cur_.right_rows, cur_.right_stride, p_, span, cols, view, with_gradient, r);
      return;
    }
  }
  // Invalid pixels in the template or under the span: every pixel weighted by both validities.
  k.sums_masked(cur_.right_rows, cur_.right_stride, L.rightValidRow(cur_.y0), L.right_valid.step1(), L.width, p_,
                span, view, cur_.valid, L.left_valid.step1(), with_gradient, r);
}

float PatchCost::templateVariance() {
  if (cur_.left_all_valid) return cur_.constants.variance;
  const float* weights = searchView().weight;
  const float ref = cur_.view.tmpl[0];  // sums of t - t[0]: see templateSums
  const size_t valid_stride = cur_.level->left_valid.step1();
  float sum = 0.f, sum_sq = 0.f, count = 0.f;
  for (int y = 0; y < p_; ++y) {
    const float* t = cur_.view.tmpl + static_cast<size_t>(y) * cur_.view.stride;
    const uchar* valid = cur_.valid + static_cast<size_t>(y) * valid_stride;
    for (int x = 0; x < p_; ++x) {
      const float w = valid[x] ? (weights ? weights[y * p_ + x] : 1.f) : 0.f;
      const float v = t[x] - ref;
      sum += w * v;
      sum_sq += w * v * v;
      count += w;
    }
  }
  if (count <= 0.f) return 0.f;
  const float mean = sum / count;
  return std::max(0.f, sum_sq / count - mean * mean);
}

float PatchCost::cost(float u) {
  ResidualSums r;
  sums(u, r, /*with_gradient=*/false);
  return meanSquaredResidual(r);
}

void PatchCost::costs(const float* u, int n, float* out) {
  SampleSpan spans[kMaxBatchSpans] = {};
  // All spans' columns valid: sums() would take the all-valid kernel for each.
  int lo = cur_.width, hi = 0;
  for (int i = 0; i < n; ++i) {
    spans[i] = sampleSpan(cur_.x0, u[i]);
    lo = std::min(lo, spans[i].base);
    hi = std::max(hi, spans[i].base + p_ + 1);
  }
  ResidualSums r[kMaxBatchSpans];
  if (!allValidColumns(lo, hi)) {
    // Over invalid pixels: the masked sums of every span in one pass (a span
    // the all-valid or clipped kernels would take gets their sums, bit for
    // bit). Spans that only cross the image's edge keep those kernels.
    if (lo >= -kRightPadding && hi <= cur_.width + kRightPadding &&
        (!cur_.left_all_valid || band_.rightInvalid(std::max(lo, 0), std::min(hi, cur_.width)) > 0)) {
      const PatchView& view = searchView();  // first: it picks search_kernels_
      const PyramidLevel& L = *cur_.level;
      search_kernels_->sums_masked_no_gradient_batch(cur_.right_rows, cur_.right_stride, L.rightValidRow(cur_.y0),
                                                     L.right_valid.step1(), L.width, p_, spans, n, view, cur_.valid,
                                                     L.left_valid.step1(), r);
      for (int i = 0; i < n; ++i) out[i] = meanSquaredResidual(r[i]);
      return;
    }
    for (int i = 0; i < n; ++i) out[i] = cost(u[i]);
    return;
  }
  const PatchView& view = searchView();  // first: it picks search_kernels_
  search_kernels_->sums_no_gradient_batch(cur_.right_rows, cur_.right_stride, p_, spans, n, view, r);
  for (int i = 0; i < n; ++i) out[i] = meanSquaredResidual(r[i]);
}

float PatchCost::windowCosts(float u, float* out) {
  const int n = window_half_width_;
  const float delta = window_step_;
  const int step = static_cast<int>(delta);
  if (static_cast<float>(step) == delta) {
    // Samples whole pixels apart: one interpolated row serves them all.
    const SampleSpan lo = sampleSpan(cur_.x0, u + static_cast<float>(n) * delta);
    const int last = lo.base + p_ + 2 * n * step;  // rightmost column read
    if (allValidColumns(lo.base, last + 1)) {
      kernels_->window_costs(cur_.right_rows, cur_.right_stride, p_, lo.base, lo.frac, 2 * n + 1, step,
                             cur_.view, mean_normalization_, row_buf_.data(), window_sum_.data(),
                             window_sq_.data(), out);
      return static_cast<float>(p_ * p_);
    }
    // Over invalid pixels: the masked sums of every sample in one pass (a
    // sample the all-valid or clipped kernels would take gets their sums, bit
    // for bit). A window that only crosses the image's edge keeps those
    // kernels, which are cheaper than the masks.
    if (lo.base >= -kRightPadding && last < cur_.width + kRightPadding &&
        (!cur_.left_all_valid ||
         band_.rightInvalid(std::max(lo.base, 0), std::min(last + 1, cur_.width)) > 0)) {
      const PyramidLevel& L = *cur_.level;
      kernels_->window_sums_masked(cur_.right_rows, cur_.right_stride, L.rightValidRow(cur_.y0),
                                   L.right_valid.step1(), L.width, p_, lo.base, lo.frac, 2 * n + 1, step,
                                   cur_.view, cur_.valid, L.left_valid.step1(), window_sums_.data());
      for (int j = 0; j <= 2 * n; ++j) out[j] = meanSquaredResidual(window_sums_[static_cast<size_t>(j)]);
      return window_sums_[static_cast<size_t>(n)].count;
    }
  }
  float valid_at_optimum = 0.f;
  for (int j = -n; j <= n; ++j) {
    ResidualSums r;
    sumsOf(*kernels_, cur_.view, u + static_cast<float>(j) * delta, r, /*with_gradient=*/false);
    if (j == 0) valid_at_optimum = r.count;
    out[j + n] = meanSquaredResidual(r);
  }
  return valid_at_optimum;
}

}  // namespace detail
}  // namespace bdis
