// Densification (docs/method.md, "Fusion"): every pixel takes the mean of the
// disparities of the patches covering it, weighted by each patch's posterior
// times a spatial Gaussian centred on the patch; its confidence is the mean
// evidence of those patches. On a coarse level the result initialises the
// next finer one; on the finest level it is floored by confidence and,
// optionally, carries a variance.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "patch_grid.hpp"
#include "patch_kernels.hpp"
#include "posterior.hpp"

namespace bdis {
namespace detail {

/// Row y's disparity as the coarser level `coarse` has it, pixels 0 ..
/// width - 1 into `out`: pixel x gets twice the value at (x / 2, y / 2),
/// clamped to the map. Where no patch reaches a pixel, or a stage needs a
/// dense start there, this stands in.
void coarserLevelRow(const cv::Mat1f& coarse, int y, int width, float* out);

/// The finest level's per-pixel results (level resolution).
struct LevelMaps {
  cv::Mat1f disparity;   ///< kNoDisparity where there is no estimate
  cv::Mat1f confidence;  ///< 0 where there is no estimate
  cv::Mat1f variance;    ///< px^2 at the level, NaN where there is no estimate; only with variance
};

class Fusion {
 public:
  /// What depends only on the parameters: the spatial Gaussian of a p x p
  /// patch (sigma_s px), the confidence floor of the finest level and the
  /// variance of a pixel whose squared weights underflow.
  void configure(const KernelSet& kernels, int patch_size, float sigma_s, float confidence_floor,
                 float max_variance);
  /// Accumulators for a band of `band_rows` rows of levels up to max_width x
  /// max_height; with_variance adds the variance's.
  void allocate(int band_rows, int max_width, int max_height, bool with_variance);

  /// A coarse level's dense disparity into `init` (width x height): the fused
  /// value where a patch survived, else 2x the coarser level's `coarse`.
  void fuseInitialisation(const PatchGrid& grid, const std::vector<PatchEstimate>& estimates,
                          const cv::Mat1f& coarse, cv::Mat1f& init);
  /// The finest level into `out` (rows 0..height-1 of each map; only row 0
  /// of out.confidence when !keep_confidence; out.variance only when
  /// `with_variance`): the fused value where a patch survived and the
  /// confidence reaches the floor. The confidence is the covering patches'
  /// mean evidence times agreement() of their disparities' spread, with
  /// `spread_halving` in level px.
  void fuseFinest(const PatchGrid& grid, const std::vector<PatchEstimate>& estimates, int width,
                  int height, const cv::Mat1f& coarse, float spread_halving, bool keep_confidence,
                  bool with_variance, LevelMaps& out);

 private:
  struct NoVariance;
  class VarianceSums;
  template <class Variance, class FinishRows>
  void accumulate(const PatchGrid& grid, const std::vector<PatchEstimate>& estimates, int width,
                  int height, Variance& variance, FinishRows&& finish);
  /// Row y of the level, band row `by`: the fused disparity where a patch
  /// survived, else twice the coarser level's; into `out`.
  void fusedRowOrCoarse(int width, int by, int y, const cv::Mat1f& coarse, float* out);

  const KernelSet* kernels_ = nullptr;
  int p_ = 0;
  float confidence_floor_ = 0.f;
  float max_variance_ = 0.f;
  std::vector<float> spatial_;           ///< p x p Gaussian, row-major
  /// The band's sums: weighted disparity, weight, evidence, weighted squared disparity.
  cv::Mat1f num_, den_, conf_, sq_;
  cv::Mat1f var_num_, var_den_;          ///< with variance: squared-weight sums
  std::vector<float> inv_cover_x_, inv_cover_y_;  ///< 1 / patches covering each column / row of the level
  std::vector<float> fused_row_;         ///< the finest level's fused row before the floor
  std::vector<float> coarser_row_;       ///< coarserLevelRow of the row being fused
  std::vector<float> spread_sq_row_;     ///< its squared spread
};

}  // namespace detail
}  // namespace bdis
