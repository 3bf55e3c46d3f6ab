#include "inverse_search.hpp"

#include <algorithm>
#include <cmath>

namespace bdis {
namespace detail {

void PatchSearch::configure(const MatcherParams& params) {
  p_ = params.patch_size;
  iterations_ = params.iterations;
  propagation_ = params.propagation;
  mean_normalization_ = params.mean_normalization;
  min_valid_share_ = params.min_valid_share;
  posterior_.half_width = params.window_half_width;
  posterior_.step = params.window_step;
  posterior_.min_valid_pixels = params.min_valid_share * static_cast<float>(p_ * p_);
  posterior_.sigma_r_squared = params.sigma_r * params.sigma_r;
  posterior_.contrast_share = params.contrast_share;
  posterior_.variance = params.compute_variance;
  cost_.configure(kernelsFor(p_, bestKernelIsa()), p_, params.mean_normalization,
                  params.window_half_width, params.window_step, params.search_band_rows);
  coarser_posterior_ = posterior_;
  coarser_posterior_.step = 0.5f * params.window_step;
  coarser_cost_.configure(kernelsFor(p_, bestKernelIsa()), p_, params.mean_normalization,
                          params.window_half_width, coarser_posterior_.step, params.search_band_rows);
}

void PatchSearch::beginLevel(const PyramidLevel& L, int stride, const PyramidLevel* coarser, float max_change,
                             float support_grey, float support_edge_grey) {
  coarser_ = coarser;
  coarser_max_change_ = max_change;
  cost_.useSupportWeights(support_grey, support_edge_grey);
  grid_.layout(L.width, L.height, p_, stride);
  // Only grown: the finer level has more patches than the coarser one before
  // it, and resizing down and up again would construct them anew every level.
  // Every entry of the grid is written by the forward pass before it is read.
  if (estimates_.size() < grid_.size()) {
    estimates_.resize(grid_.size());
    loaded_.resize(grid_.size());
  }
}

void PatchSearch::searchBand(const PyramidLevel& L, const cv::Mat1f& coarse, int top, int bottom) {
  // The masks behind the kept validity bands may differ from the last band's
  // (another level, frame or mirrored band): only the two passes below share them.
  cost_.forgetBands();
  coarser_cost_.forgetBands();
  forwardPass(L, coarse, top, bottom);
  backwardPass(L, coarse, top, bottom);
}

void PatchSearch::forwardPass(const PyramidLevel& L, const cv::Mat1f& coarse, int top, int bottom) {
  const int pp = p_ * p_;
  const int nx = grid_.columns();
  // Raster order: start from the coarser level's disparity at the patch
  // centre, times 2, or from the left or upper neighbour's result when that
  // fits this patch better (spatial propagation, as in DIS).
  for (int iy = top; iy < bottom; ++iy) {
    const int y0 = grid_.ys[static_cast<size_t>(iy)];
    cost_.loadBand(L, y0);
    for (int ix = 0; ix < nx; ++ix) {
      const size_t k = static_cast<size_t>(iy * nx + ix);
      const int x0 = grid_.xs[static_cast<size_t>(ix)];
      float u = 2.f * coarse(coarseCell(x0, y0, p_, coarse));
      estimates_[k] = PatchEstimate{u, 0.f, 0.f};
      LoadedPatch& record = loaded_[k];
      const int left_invalid = cost_.leftInvalid(x0);
      // Mostly outside the rectified view: not searched.
      record.loaded = !(static_cast<float>(pp - left_invalid) < min_valid_share_ * static_cast<float>(pp));
      if (!record.loaded) continue;
      cost_.loadPatch(L, x0, y0, left_invalid == 0);
      record.constants = cost_.constants();
      record.left_all_valid = cost_.leftAllValid();
      if (propagation_) {
        float candidates[2];
        propagate(u, candidates, neighbourCandidates(k, ix > 0, -1, iy > 0, -nx, candidates));
      }
      estimates_[k].disparity = refinePatch(u);
      record.support = cost_.supportWeighting();
    }
  }
}

void PatchSearch::backwardPass(const PyramidLevel& L, const cv::Mat1f& coarse, int top, int bottom) {
  const int nx = grid_.columns();
  const int half_p = p_ / 2;
  float window[2 * kMaxWindowHalfWidth + 1];
  // The right and lower neighbours get their say, then the patch's
  // posterior is taken at its final disparity.
  for (int iy = bottom - 1; iy >= top; --iy) {
    const int y0 = grid_.ys[static_cast<size_t>(iy)];
    cost_.loadBand(L, y0);
    // The doubled footprint, rows y0 - p/2 .. y0 + 3p/2 - 1, is p rows of
    // the coarser level from yc; rows it would not fit get no second look.
    // Its validity band is loaded for the row's first second look only.
    const int yc = (y0 - half_p + 1) / 2;
    const bool look_coarser = coarser_ != nullptr && y0 >= half_p && yc + p_ <= coarser_->height;
    bool coarser_band_loaded = false;
    for (int ix = nx - 1; ix >= 0; --ix) {
      const size_t k = static_cast<size_t>(iy * nx + ix);
      const LoadedPatch& record = loaded_[k];
      if (!record.loaded) continue;
      cost_.setPatch(L, grid_.xs[static_cast<size_t>(ix)], y0, record.left_all_valid, record.constants);
      cost_.recallSupportWeighting(record.support);
      float u = estimates_[k].disparity;
      if (propagation_) {
        float candidates[2];
        const int m = neighbourCandidates(k, ix + 1 < nx, 1, iy + 1 < bottom, nx, candidates);
        if (propagate(u, candidates, m)) u = refinePatch(u);
      }
      const float valid_at_optimum = cost_.windowCosts(u, window);
      estimates_[k] = patchPosterior(u, window, valid_at_optimum,
                                     [this] { return cost_.templateVariance(); }, posterior_);
      const int x0 = grid_.xs[static_cast<size_t>(ix)];
      const int xc = (x0 - half_p + 1) / 2;
      if (look_coarser && estimates_[k].evidence < kCoarserLookBelowEvidence && x0 >= half_p &&
          xc + p_ <= coarser_->width && flatAtCoarserScale(x0, y0, coarse)) {
        if (!coarser_band_loaded) coarser_cost_.loadBand(*coarser_, yc);
        coarser_band_loaded = true;
        lookCoarser(k, xc, yc, u);
      }
    }
  }
}

bool PatchSearch::flatAtCoarserScale(int x0, int y0, const cv::Mat1f& coarse) const {
  // The slope of the coarser disparity (the same in its px as in this
  // level's) by central differences around the patch centre's cell.
  const cv::Point c = coarseCell(x0, y0, p_, coarse);
  const int left = std::max(c.x - 1, 0), right = std::min(c.x + 1, coarse.cols - 1);
  const int up = std::max(c.y - 1, 0), down = std::min(c.y + 1, coarse.rows - 1);
  const float slope_x = right > left ? std::fabs(coarse(c.y, right) - coarse(c.y, left)) / static_cast<float>(right - left) : 0.f;
  const float slope_y = down > up ? std::fabs(coarse(down, c.x) - coarse(up, c.x)) / static_cast<float>(down - up) : 0.f;
  return std::max(slope_x, slope_y) * static_cast<float>(2 * p_) < coarser_max_change_;
}

void PatchSearch::lookCoarser(size_t k, int xc, int yc, float u) {
  const int pp = p_ * p_;
  const int left_invalid = coarser_cost_.leftInvalid(xc);
  if (static_cast<float>(pp - left_invalid) < min_valid_share_ * static_cast<float>(pp)) return;
  coarser_cost_.loadPatch(*coarser_, xc, yc, left_invalid == 0);
  // Disparities halve one level up; so do the window's samples (see
  // configure), so that both posteriors weigh the same disparity span.
  const float uc = refinePatch(coarser_cost_, 0.5f * u);
  float window[2 * kMaxWindowHalfWidth + 1];
  const float valid_at_optimum = coarser_cost_.windowCosts(uc, window);
  PatchEstimate coarser = patchPosterior(uc, window, valid_at_optimum,
                                         [this] { return coarser_cost_.templateVariance(); }, coarser_posterior_);
  if (!(coarser.evidence > estimates_[k].evidence)) return;
  coarser.disparity *= 2.f;
  coarser.variance *= 4.f;
  estimates_[k] = coarser;
}

bool PatchSearch::propagate(float& u, const float* candidates, int n) {
  // A candidate this close to the current choice is not worth a cost: the
  // refinement would end where it ends from there (the scores on the colon
  // and generated sequences do not change).
  constexpr float kMinCandidateDistance = 0.1f;
  auto far = [](float a, float b) { return std::fabs(a - b) >= kMinCandidateDistance; };
  // The costs the rule below may compare, in one batch: u's, and each
  // candidate's that is far from u or from an earlier candidate (which may
  // have replaced u by then).
  float values[kMaxBatchSpans] = {u};
  int slot[kMaxBatchSpans - 1] = {-1, -1};  // candidate i's index in values
  int m = 1;
  for (int i = 0; i < n; ++i) {
    bool may_be_tried = far(candidates[i], u);
    for (int j = 0; j < i; ++j) may_be_tried |= slot[j] >= 0 && far(candidates[i], candidates[j]);
    if (may_be_tried) {
      slot[i] = m;
      values[m++] = candidates[i];
    }
  }
  if (m == 1) return false;
  float costs[kMaxBatchSpans];
  cost_.costs(values, m, costs);
  float best = costs[0];
  bool moved = false;
  for (int i = 0; i < n; ++i) {
    if (!far(candidates[i], u)) continue;  // else slot[i] >= 0
    const float c = costs[slot[i]];
    if (!(c < best)) continue;
    u = candidates[i];
    best = c;
    moved = true;
  }
  return moved;
}

float PatchSearch::refinePatch(PatchCost& cost, float u_start) {
  // Inverse-compositional Gauss-Newton along x, d >= 0.
  const float max_u = static_cast<float>(cost.levelWidth());
  float u = u_start;
  ResidualSums r;
  for (int it = 0; it < iterations_; ++it) {
    cost.sums(u, r);
    if (r.count <= 0.f) break;
    float b = r.g_diff, H = r.g_sq;
    if (mean_normalization_) {
      const float inv_count = 1.f / r.count;  // one division, not two: each is three additions' latency
      b -= r.diff * r.g * inv_count;
      H -= r.g * r.g * inv_count;
    }
    if (H <= 1e-6f) break;  // no texture: nothing to align on
    const float step = b / H;
    u = std::clamp(u + step, 0.f, max_u);
    if (std::fabs(step) < 0.01f) break;  // converged: far below what a match resolves
  }
  // Outlier guard: wandered more than a patch from its start.
  if (std::fabs(u - u_start) > static_cast<float>(p_)) u = u_start;
  return u;
}

}  // namespace detail
}  // namespace bdis
