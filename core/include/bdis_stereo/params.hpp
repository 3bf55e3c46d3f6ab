// Parameters of the BDIS matcher: one struct, named presets, validation and a
// table describing every field so that YAML files, ROS parameters and
// dynamic_reconfigure all speak the same names.
#pragma once

#include <functional>
#include <stdexcept>
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
  /// s_last; results are upsampled to full size. -1: from the image width
  /// (finestLevelFor): the presets were tuned on 640 px wide frames searched
  /// at level 1 (320 px), and a patch of patch_size px should see about as
  /// much of the scene on an HD frame.
  int finest_level = -1;
  // Patch search (inverse-compositional, 1-D).
  /// Gauss-Newton steps per patch at most. One: on flat or dark tissue each
  /// further step on a flat cost carries the patch further from the coarser
  /// level's start; the variational refinement does the fine alignment.
  int iterations = 1;
  int patch_size = 8;       ///< side p of the square patches, px at each level
  float overlap = 0.6f;     ///< stride = max(1, round(p * (1 - overlap))) on the finest level
  float coarse_overlap = 0.4f;  ///< the same on the coarser levels (they only initialise the next)
  bool mean_normalization = true;  ///< subtract patch means (brightness offset cancels)
  bool propagation = true;  ///< try the neighbouring patches' disparities as starts (as DIS does)
  /// Finest level: forward and backward pass per band of this many patch
  /// rows, which stays in cache; 0 = over the whole level at once, as DIS.
  int search_band_rows = 8;
  /// Divides the views' contrast gain out of the right view, estimated from
  /// the coarser levels' matches: mean normalisation cancels an offset only,
  /// and on a brightness slope a gain biases weak-texture patches. Off by
  /// default: on views without a gain the estimate strays by 2-8 % in deep
  /// scenes, which costs as much as it mends (docs/method.md, "Gain
  /// compensation").
  bool gain_compensation = false;
  /// At the finest level, a patch whose posterior barely tells its
  /// disparities apart searches again one level coarser, on twice its
  /// footprint: more estimates on dark and flat tissue at the same bad2, for
  /// 5-7 % of balanced's time (docs/method.md); on in accurate.
  bool coarser_look = false;
  /// Also matches with the finest level one coarser (twice the footprint per
  /// patch) and publishes, per pixel estimated by both and away from depth
  /// edges, the estimate with the higher calibrated confidence: dark, flat
  /// and block-coded tissue gain, for 1.3 times balanced's time
  /// (docs/method.md, "Two scales"). Needs calibrated_confidence (without
  /// it, or when the finest level is the coarsest that fits, ignored); on in
  /// accurate.
  bool two_scales = false;
  /// At the finest level, each patch pixel weighs 1 / (1 + ((g - c) /
  /// support_grey)^2) in the search's costs and Gauss-Newton steps, g its
  /// grey level and c the patch centre's: a patch straddling an instrument's
  /// outline or a fold's rim matches the surface its centre sees, not the
  /// stronger edge. Grey levels at a centre of 64 and brighter; darker
  /// centres scale it (and support_edge_grey) with their grey level, down to
  /// a quarter: the same contrast spans fewer grey levels in the dark.
  /// 0 = off (fast). A third fewer wrong estimates beside instruments, a
  /// quarter of the confidently wrong ones (docs/method.md, "Support weights").
  float support_grey = 8.f;
  /// Only patches with a pixel more than this many grey levels from their
  /// centre's (an edge) take the support weights; the others keep the plain
  /// search and cost nothing more. 0 = every patch (accurate).
  float support_edge_grey = 24.f;
  // Bayesian patch posterior.
  float min_valid_share = 0.25f;   ///< gamma: patches with fewer valid pixels are discarded
  /// Pixels this bright or brighter in either view (grey level; a specular
  /// highlight, which sits elsewhere on the tissue in each view) are left
  /// out like black ones; 256 = none.
  int saturation_grey = 255;
  /// Pixels darker than this in either view (grey level) are left out like
  /// black ones: on near-black surfaces without texture of their own (a dark
  /// instrument shaft, a dark corner) a patch only matches the texture of
  /// its lighter neighbours, at their depth. 0 = none.
  int dark_floor_grey = 10;
  int window_half_width = 2;       ///< n: posterior window has 2n+1 samples
  /// delta: spacing of the window samples, px at the level. 2, not the
  /// paper's 1: the local-minimum test and the posterior then see the
  /// alternatives 2-4 px away, where most wrong estimates lie.
  float window_step = 2.0f;
  float sigma_r = 0.5f;            ///< brightness noise, grey levels
  float contrast_share = 0.3f;     ///< see above; 0 = paper's fixed-noise posterior
  float sigma_s = 4.0f;            ///< spatial Gaussian inside a patch, px at the level
  /// Pixels whose patches' mean evidence is lower get no disparity. Low,
  /// because the refinement mends most low-evidence estimates.
  float confidence_floor = 0.0175f;
  float lr_check_tolerance = 3.f;  ///< left-right check, full-resolution px; 0 = off
  float lr_check_overlap = 0.4f;   ///< patch overlap of the check's search from the right image
  bool compute_variance = false;   ///< also output per-pixel disparity variance (px^2)
  /// The published confidence as the probability that the estimate is
  /// within 2 px (the cues' product through a table fitted on generated
  /// scenes); false: the product itself, which spans many decades.
  bool calibrated_confidence = true;
  /// Estimates whose published confidence is lower are dropped from the
  /// disparity (and so from depth and points); 0 = none. The confidence is
  /// then computed even when it is not asked for. With the calibrated
  /// confidence, 0.9 keeps the estimates each at least 90 % likely to be
  /// within 2 px; the README's table maps a threshold to the density and
  /// bad2 to expect.
  float min_confidence = 0.f;
  // Variational refinement of the finest level (DIS's last stage, along x):
  // per pixel, the disparity its own grey levels and its neighbours agree on.
  int refinement_iterations = 1;       ///< fixed-point steps; 0 = off (accurate: 2)
  float refinement_smoothness = 20.f;  ///< alpha: weight of the smoothness term

  /// Throws std::invalid_argument naming the first bad field and its range.
  void validate() const;

  /// The finest searched level for frames `width` px wide: finest_level when
  /// set, else round(log2(width / 320)), at least 1 (1 up to 904 px, 2 up to
  /// 1809, 3 above); never coarser than coarsest_level.
  int finestLevelFor(int width) const;
  /// lr_check_tolerance in full-resolution px for frames `width` px wide:
  /// as set, doubled where finest_level is -1 and the frame is searched at a
  /// coarser level than 1, which would otherwise make the check stricter in
  /// the scene the larger the frame.
  float checkToleranceFor(int width) const;
  /// patch_size for frames `width` px wide: as set, except where
  /// finest_level is -1 and finestLevelFor rounded the level up past 1 (a
  /// 1920 px frame is searched at level 3, log2(1920 / 320) = 2.58): there
  /// the patch shrinks by the rounding, round(patch_size * width / (320 *
  /// 2^level)), never grows, so that it sees as much of the scene as on a
  /// 640 px frame at level 1 (6 px at 1920, 8 at 1280). The matcher keeps
  /// the finest level's stride of patch_size, so the patches stay as many.
  int patchSizeFor(int width) const;

  /// Named settings; throws std::invalid_argument for an unknown name.
  static MatcherParams preset(const std::string& name);
  /// "fast", "balanced", "accurate" (balanced is the default).
  static std::vector<std::string> presetNames();
};

/// What one parameter accepts: its name, type, range and description. The
/// matcher's fields (ParamField) and the ROS node's own parameters are both
/// described this way, so that one set of rules (checkParam) binds them all.
struct ParamSpec {
  enum class Type { Int, Float, Bool, String };
  const char* name;
  Type type;
  double min_value;  ///< numeric types only
  double max_value;
  const char* description;
};

/// Describes one field of MatcherParams for generic loaders (YAML, `--set`,
/// ROS params, dynamic_reconfigure). Numeric fields of every kind are exposed
/// as double. `set` converts without checking: bind values with bindParam.
struct ParamField : ParamSpec {
  std::function<double(const MatcherParams&)> get;
  std::function<void(MatcherParams&, double)> set;
};

/// Every field of MatcherParams, in declaration order.
const std::vector<ParamField>& paramFields();

/// Returns the field with that name or nullptr.
const ParamField* findParamField(const std::string& name);

/// The `preset` parameter (a String, one of MatcherParams::presetNames()).
const ParamSpec& presetSpec();

/// What a preset trades, one line (for dynamic_reconfigure and the docs);
/// throws std::invalid_argument for an unknown name.
const char* presetDescription(const std::string& name);

/// A parameter value as its source gave it: a YAML scalar, a `--set` text, a
/// ROS parameter server value, a dynamic_reconfigure field.
struct ParamValue {
  enum class Kind { Bool, Integer, Real, String, Other };
  Kind kind = Kind::Other;
  bool boolean = false;
  long long integer = 0;
  double real = 0.0;
  std::string text;  ///< String: the text; Other: what the value is ("a list")

  static ParamValue ofBool(bool v);
  static ParamValue ofInteger(long long v);
  static ParamValue ofReal(double v);
  static ParamValue ofString(std::string v);
  static ParamValue ofOther(std::string what);
  /// An untyped text (the command line) read as a YAML scalar would be:
  /// a boolean word (isBoolWord), else an integer, else a real number
  /// (including nan, inf, .nan, .inf), else a string.
  static ParamValue fromText(const std::string& text);
  /// The YAML 1.1 boolean words, which the ROS parameter server (PyYAML) reads
  /// as booleans: true/false, yes/no, on/off, each lower, Capitalised or UPPER.
  /// Sets `value` and returns true when `text` is one.
  static bool isBoolWord(const std::string& text, bool& value);

  /// As in messages: true, 2, 2.5, 3.0, nan, 'text', (a list).
  std::string str() const;
};

/// A value a source gave that a parameter does not accept. what() is
/// "SOURCE: DETAIL"; detail() alone reads "parameter NAME = VALUE ...".
class ParamError : public std::invalid_argument {
 public:
  ParamError(const std::string& source, const std::string& detail);
  const std::string& source() const { return source_; }
  const std::string& detail() const { return detail_; }

 private:
  std::string source_, detail_;
};

/// The one set of rules for every source (YAML files, `--set`, the ROS
/// parameter server, dynamic_reconfigure): returns `value` as `spec`'s type
/// holds it (Bool, Integer, Real or String kind) or throws ParamError naming
/// `source`, the parameter, the value and its description.
///  - Bool takes a boolean only. Numbers are refused everywhere: the ROS
///    parameter server types a YAML 0 or 1 as an integer, so a file that said
///    `compute_variance: 1` would load in one place and not in another.
///  - Int takes an integer, or a real number without a fraction (3.0);
///    2.5 is an error ("must be a whole number").
///  - Float takes an integer or a real number.
///  - NaN and infinity are refused ("is not a finite number"), then the range
///    [min_value, max_value] is checked ("is out of range [lo, hi]").
///  - String takes a string only.
ParamValue checkParam(const ParamSpec& spec, const ParamValue& value, const std::string& source);

/// checkParam, then the value stored in `field` of `params`.
void bindParam(MatcherParams& params, const ParamField& field, const ParamValue& value,
               const std::string& source);
/// The same by name; an unknown name is a ParamError ("unknown parameter 'x'").
void bindParam(MatcherParams& params, const std::string& name, const ParamValue& value,
               const std::string& source);

/// The named preset's parameters for a `preset` value; ParamError (naming
/// `source` and the valid names) for an unknown name or a value that is no string.
MatcherParams bindPreset(const ParamValue& value, const std::string& source);

/// Reads a YAML (or JSON) file of `name: value` pairs on top of `base`.
/// A `preset: NAME` key, if present, is applied first. Every value is bound
/// with bindParam (source "parameter file PATH"); unknown keys, bad values and
/// an empty file throw std::invalid_argument naming the file (ParamError for
/// a value); the result is validated.
MatcherParams loadParams(const std::string& path, const MatcherParams& base = MatcherParams{});

/// One line per field, `name: value`, loadable by loadParams.
std::string toYaml(const MatcherParams& params);

}  // namespace bdis
