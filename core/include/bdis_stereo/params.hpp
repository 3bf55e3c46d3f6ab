// Parameters of the BDIS matcher: one struct, named presets, validation and a
// table describing every field so that YAML files, ROS parameters and
// dynamic_reconfigure all speak the same names.
#pragma once

#include <functional>
#include <string>
#include <vector>

namespace bdis {

/// How the photometric cost of a window sample becomes a likelihood.
///   exp(-E_k / (2 * (sigma_r^2 + contrast_share * E_0)))
/// where E_k is the mean squared (mean-normalised) residual of window sample k
/// and E_0 that of the optimum. contrast_share = 0 is the paper's fixed
/// brightness noise; a large value approaches the authors' releases, which
/// divide by the optimum's own residual (contrast invariant, but over-confident
/// on dark flat tissue).
struct MatcherParams {
  // Pyramid: level s is the input downsampled by 2^s.
  int coarsest_level = 5;   ///< s_first; reduced automatically for small images
  int finest_level = 1;     ///< s_last; results are upsampled to full size
  // Patch search (inverse-compositional, 1-D).
  int iterations = 2;       ///< Gauss-Newton steps per patch at most (3 or 12 score the same)
  int patch_size = 8;       ///< side p of the square patches, px at each level
  float overlap = 0.6f;     ///< stride = max(1, round(p * (1 - overlap))) on the finest level
  float coarse_overlap = 0.4f;  ///< the same on the coarser levels (they only initialise the next)
  bool mean_normalization = true;  ///< subtract patch means (brightness offset cancels)
  bool propagation = true;  ///< try the neighbouring patches' disparities as starts (as DIS does)
  /// Finest level: forward and backward pass per band of this many patch
  /// rows, which stays in cache; 0 = over the whole level at once, as DIS.
  int search_band_rows = 8;
  // Bayesian patch posterior.
  float min_valid_share = 0.25f;   ///< gamma: patches with fewer valid pixels are discarded
  int window_half_width = 2;       ///< n: posterior window has 2n+1 samples
  float window_step = 1.0f;        ///< delta: spacing of window samples, px at the level
  float sigma_r = 0.5f;            ///< brightness noise, grey levels
  float contrast_share = 0.3f;     ///< see above; 0 = paper's fixed-noise posterior
  float sigma_s = 4.0f;            ///< spatial Gaussian inside a patch, px at the level
  float confidence_floor = 0.015f;  ///< pixels whose confidence is lower get no disparity
  float lr_check_tolerance = 3.f;  ///< left-right check, full-resolution px; 0 = off
  float lr_check_overlap = 0.4f;   ///< patch overlap of the check's search from the right image
  bool compute_variance = false;   ///< also output per-pixel disparity variance (px^2)

  /// Throws std::invalid_argument naming the first bad field and its range.
  void validate() const;

  /// Named settings; throws std::invalid_argument for an unknown name.
  static MatcherParams preset(const std::string& name);
  /// "fast", "balanced", "accurate" (balanced is the default).
  static std::vector<std::string> presetNames();
};

/// Describes one field of MatcherParams for generic loaders (YAML, ROS params,
/// dynamic_reconfigure). Numeric fields of every kind are exposed as double.
struct ParamField {
  enum class Type { Int, Float, Bool };
  const char* name;
  Type type;
  double min_value;
  double max_value;
  const char* description;
  std::function<double(const MatcherParams&)> get;
  std::function<void(MatcherParams&, double)> set;
};

/// Every field of MatcherParams, in declaration order.
const std::vector<ParamField>& paramFields();

/// Returns the field with that name or nullptr.
const ParamField* findParamField(const std::string& name);

/// Reads a YAML (or JSON) file of `name: value` pairs on top of `base`.
/// A `preset: NAME` key, if present, is applied first. Unknown keys and values
/// of the wrong type throw std::invalid_argument naming the key and the file;
/// the result is validated.
MatcherParams loadParams(const std::string& path, const MatcherParams& base = MatcherParams{});

/// One line per field, `name: value`, loadable by loadParams.
std::string toYaml(const MatcherParams& params);

}  // namespace bdis
