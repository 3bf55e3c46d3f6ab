// The patch search of one pyramid level (docs/method.md, "Patch search" and
// "Patch posterior"): DIS's inverse-compositional Gauss-Newton along x for
// every patch of the grid, with spatial propagation in a forward and a
// backward pass, then each patch's posterior from a window of costs.
// At the finest level, a patch whose posterior barely tells its disparities
// apart looks again one level coarser, on twice its footprint ("A second look
// one level coarser").
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

#include <opencv2/core.hpp>

#include "bdis_stereo/params.hpp"
#include "patch_cost.hpp"
#include "patch_grid.hpp"
#include "posterior.hpp"
#include "pyramid.hpp"

namespace bdis {
namespace detail {

/// The second look one level coarser only where the coarser level's disparity
/// changes by less than this across the doubled footprint (full-resolution
/// px: the outlier threshold), so that it does not flatten slanted tissue or
/// reach across a depth edge.
constexpr float kCoarserLookMaxChangePx = 2.f;
/// Patches whose evidence is below this get the second look: a window that
/// barely tells its disparities apart (0.02-0.1 gave about the same results;
/// a setting apart from the floor, which decides what fusion publishes).
constexpr float kCoarserLookBelowEvidence = 0.05f;

class PatchSearch {
 public:
  /// What depends only on the parameters: kernels, posterior settings.
  void configure(const MatcherParams& params);
  /// Scratch for levels up to `max_width` wide.
  void allocate(int max_width) {
    cost_.allocate(max_width);
    coarser_cost_.allocate(max_width);
  }

  /// Lays the patch grid over L with the given stride; the level's patch
  /// rows are then searched by searchBand, in bands from the top. With
  /// `coarser` (the next coarser level of the same pyramid, whole), a patch
  /// whose evidence stays below kCoarserLookBelowEvidence is searched again there, where
  /// the disparity changes by less than `max_change` level px across twice
  /// its footprint. `support_grey` > 0: the search's costs weigh each pixel
  /// by its grey level's likeness to the patch centre's, in the patches with
  /// a pixel more than `support_edge_grey` from it (PatchCost::useSupportWeights).
  void beginLevel(const PyramidLevel& L, int stride, const PyramidLevel* coarser = nullptr,
                  float max_change = 0.f, float support_grey = 0.f, float support_edge_grey = 0.f);
  /// Forward and backward pass over patch rows [top, bottom) of the level
  /// begun last, each patch starting from `coarse` (the coarser level's
  /// dense disparity, at half this level's scale) or a neighbour's result.
  /// L must hold the level rows those patch rows read. The backward pass
  /// takes no lower neighbour across the band's bottom edge; the next
  /// band's forward pass starts from the final results of its upper
  /// neighbours.
  void searchBand(const PyramidLevel& L, const cv::Mat1f& coarse, int top, int bottom);

  const PatchGrid& grid() const { return grid_; }
  /// One estimate per patch of the grid, row by row (valid for the searched bands).
  const std::vector<PatchEstimate>& estimates() const { return estimates_; }
  const PosteriorSettings& posteriorSettings() const { return posterior_; }

 private:
  /// What the backward pass cannot re-derive cheaply from a patch's
  /// position: 16 bytes a patch, not the whole patch state, so that at
  /// 1920x1080 the records of a pass take 0.9 MB beside the level in cache.
  struct LoadedPatch {
    TemplateSums constants;
    bool loaded = false;  ///< enough valid pixels to be searched
    bool left_all_valid = false;
    SupportWeighting support = SupportWeighting::Unknown;  ///< as the forward pass decided it
  };

  void forwardPass(const PyramidLevel& L, const cv::Mat1f& coarse, int top, int bottom);
  void backwardPass(const PyramidLevel& L, const cv::Mat1f& coarse, int top, int bottom);
  /// Gauss-Newton along x from u_start, d >= 0; back to u_start when the
  /// patch wanders more than a patch size (outlier guard).
  float refinePatch(float u_start) { return refinePatch(cost_, u_start); }
  float refinePatch(PatchCost& cost, float u_start);
  /// Spatial propagation (DIS): in order, each of the n <= 2 candidates (the
  /// neighbours' disparities) replaces u when its cost is lower. True when u changed.
  bool propagate(float& u, const float* candidates, int n);
  /// The coarser level's cell under the centre of the patch at (x0, y0).
  static cv::Point coarseCell(int x0, int y0, int p, const cv::Mat1f& coarse) {
    const float half = 0.5f * static_cast<float>(p - 1);
    const float cx = (static_cast<float>(x0) + half + 0.5f) * 0.5f - 0.5f;
    const float cy = (static_cast<float>(y0) + half + 0.5f) * 0.5f - 0.5f;
    // cx, cy > 0: adding 0.5 and truncating rounds them (lround is a libm call).
    return {std::min(static_cast<int>(cx + 0.5f), coarse.cols - 1),
            std::min(static_cast<int>(cy + 0.5f), coarse.rows - 1)};
  }
  /// Whether the coarser level's disparity changes by less than
  /// coarser_max_change_ across twice the footprint of the patch at (x0, y0).
  bool flatAtCoarserScale(int x0, int y0, const cv::Mat1f& coarse) const;
  /// The second look: patch k, at (x0, y0) and disparity u, searched again
  /// one level coarser on its doubled footprint (origin (xc, yc) there);
  /// kept when its evidence is higher.
  void lookCoarser(size_t k, int xc, int yc, float u);
  /// The propagation candidates of patch k: the disparities of its loaded
  /// neighbours k + row_offset (in the same patch row, if `in_row`) and
  /// k + column_offset (in the same column, if `in_column`), in that order.
  int neighbourCandidates(size_t k, bool in_row, std::ptrdiff_t row_offset, bool in_column,
                          std::ptrdiff_t column_offset, float* out) const {
    int n = 0;
    auto add = [&](bool present, std::ptrdiff_t offset) {
      const size_t neighbour = static_cast<size_t>(static_cast<std::ptrdiff_t>(k) + offset);
      if (present && loaded_[neighbour].loaded) out[n++] = estimates_[neighbour].disparity;
    };
    add(in_row, row_offset);
    add(in_column, column_offset);
    return n;
  }

  int p_ = 8;
  int iterations_ = 2;
  bool propagation_ = true;
  bool mean_normalization_ = true;
  float min_valid_share_ = 0.25f;
  PosteriorSettings posterior_;
  PatchCost cost_;
  /// The second look's: the same patch side one level coarser, the posterior
  /// window's samples as far apart in this level's px as the level's own.
  PatchCost coarser_cost_;
  PosteriorSettings coarser_posterior_;
  const PyramidLevel* coarser_ = nullptr;  ///< null: no second look on this level
  float coarser_max_change_ = 0.f;         ///< level px
  PatchGrid grid_;
  std::vector<PatchEstimate> estimates_;
  std::vector<LoadedPatch> loaded_;  ///< as the forward pass loaded them, for the backward one
};

}  // namespace detail
}  // namespace bdis
