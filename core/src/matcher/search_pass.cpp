#include "search_pass.hpp"

#include <algorithm>

#include "confidence.hpp"
#include "patch_grid.hpp"

namespace bdis {
namespace detail {
namespace {

/// Rows of the fusion's accumulator band: one patch and four more patch rows,
/// so the rows carried over when the band moves (fewer than p) are copied once
/// per four patch rows. 28 rows at the defaults: at 1920x1080 the sums take
/// 0.5 MB, where whole-level sums took 10 MB and ran from memory.
int fusionBandRows(const MatcherParams& P) {
  const int p = P.patch_size;
  return p + 4 * std::max(patchStride(p, P.overlap), patchStride(p, P.coarse_overlap));
}

void fill(cv::Mat1f& m, float value) {
  // Row-wise: cv::Mat::setTo allocates an iterator on ROIs, and the steady
  // state must not allocate.
  for (int y = 0; y < m.rows; ++y) std::fill(m[y], m[y] + m.cols, value);
}

}  // namespace

void SearchPass::configure(const MatcherParams& params, bool keep_confidence) {
  params_ = params;
  keep_confidence_ = keep_confidence;
  search_.configure(params);
  fusion_.configure(kernelsFor(params.patch_size, bestKernelIsa()), params.patch_size, params.sigma_s,
                    params.confidence_floor, search_.posteriorSettings().maxVariance());
}

void SearchPass::allocate(cv::Size size, int levels, int finest) {
  // Every create()/resize() below is a no-op when the size is unchanged, so a
  // steady stream of equal frames allocates nothing.
  finest_level_ = finest;
  initialisation_.resize(static_cast<size_t>(levels) + 1);
  for (int s = finest + 1; s <= levels; ++s) {
    initialisation_[static_cast<size_t>(s)].create(std::max(1, size.height >> s), std::max(1, size.width >> s));
  }
  fill(initialisation_[static_cast<size_t>(levels)], 0.f);
  // Level-sized buffers at the largest searched level (the finest).
  const cv::Size largest(size.width >> finest, size.height >> finest);
  finest_.disparity.create(largest);
  finest_.confidence.create(keep_confidence_ ? largest.height : 1, largest.width);
  if (params_.compute_variance) finest_.variance.create(largest);
  fusion_.allocate(fusionBandRows(params_), largest.width, largest.height, params_.compute_variance);
  search_.allocate(largest.width);
}

void SearchPass::matchCoarseLevel(const PyramidLevel& L, int s) {
  // Coarser levels only initialise the next one: they get by with fewer patches.
  search_.beginLevel(L, patchStride(params_.patch_size, params_.coarse_overlap));
  const cv::Mat1f& coarse = initialisation_[static_cast<size_t>(s) + 1];
  search_.searchBand(L, coarse, 0, search_.grid().rows());
  fusion_.fuseInitialisation(search_.grid(), search_.estimates(), coarse, initialisation_[static_cast<size_t>(s)]);
}

void SearchPass::adoptLevelsAboveFinest(const SearchPass& finer, cv::Size size, int levels, int finest) {
  allocate(size, levels, finest);
  // Level `levels` is all 0 on both sides; a copy into a buffer of the same size allocates nothing.
  finer.levelDisparity(finest + 1).copyTo(initialisation_[static_cast<size_t>(finest) + 1]);
}

void SearchPass::beginFinestLevel(const PyramidLevel& L, int s, const PyramidLevel* coarser) {
  finest_level_ = s;
  search_.beginLevel(L, patchStride(params_.patch_size, params_.overlap), coarser,
                     kCoarserLookMaxChangePx / static_cast<float>(1 << s), params_.support_grey,
                     params_.support_edge_grey);
}

void SearchPass::searchFinestBand(const PyramidLevel& L, int top, int bottom) {
  search_.searchBand(L, initialisation_[static_cast<size_t>(finest_level_) + 1], top, bottom);
}

void SearchPass::fuseFinestLevel() {
  const float spread_halving = kSpreadHalvingPx / static_cast<float>(1 << finest_level_);
  fusion_.fuseFinest(search_.grid(), search_.estimates(), finest_.disparity.cols, finest_.disparity.rows,
                     initialisation_[static_cast<size_t>(finest_level_) + 1], spread_halving, keep_confidence_,
                     params_.compute_variance, finest_);
}

}  // namespace detail
}  // namespace bdis
