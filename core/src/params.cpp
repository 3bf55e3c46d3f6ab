#include "bdis_stereo/params.hpp"

#include <cctype>
#include <cerrno>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <type_traits>

#include <opencv2/core.hpp>

namespace bdis {
namespace {

using Type = ParamField::Type;

// Converting NaN or a value beyond the int range to int is undefined
// behaviour: such values become INT_MIN or INT_MAX, which validate() rejects
// like any other out-of-range value.
template <typename T>
T toField(double v) {
  if constexpr (std::is_same<T, int>::value) {
    if (!(v >= std::numeric_limits<int>::min())) return std::numeric_limits<int>::min();  // also NaN
    if (v > std::numeric_limits<int>::max()) return std::numeric_limits<int>::max();
  }
  return static_cast<T>(v);
}

template <typename T>
ParamField field(const char* name, T MatcherParams::*member, double lo, double hi,
                 const char* description) {
  constexpr Type type = std::is_same<T, bool>::value  ? Type::Bool
                        : std::is_same<T, int>::value ? Type::Int
                                                      : Type::Float;
  return {{name, type, lo, hi, description},
          [member](const MatcherParams& p) { return static_cast<double>(p.*member); },
          [member](MatcherParams& p, double v) { p.*member = toField<T>(v); }};
}

std::string formatValue(const ParamField& f, double v) {
  std::ostringstream os;
  if (f.type == Type::Bool) {
    os << (v != 0.0 ? "true" : "false");
  } else {
    // Enough digits that the float field reads back bit-identical.
    os.precision(f.type == Type::Float ? std::numeric_limits<float>::max_digits10 : 17);
    os << (f.type == Type::Float ? static_cast<double>(static_cast<float>(v)) : v);
  }
  return os.str();
}

}  // namespace

const std::vector<ParamField>& paramFields() {
  static const std::vector<ParamField> fields = {
      field("coarsest_level", &MatcherParams::coarsest_level, 0, 10,
            "coarsest pyramid level s_first (image / 2^s); reduced for small images"),
      field("finest_level", &MatcherParams::finest_level, -1, 10,
            "finest searched level s_last, the result upsampled to full size; -1 = from the image "
            "width: 1 up to 904 px, 2 up to 1809, 3 above"),
      field("iterations", &MatcherParams::iterations, 1, 200,
            "Gauss-Newton steps per patch at most (fewer once a step is below 0.01 px)"),
      field("patch_size", &MatcherParams::patch_size, 4, 32,
            "patch side p, px at each level; smaller where finest_level -1 rounds the level up (6 at 1920 px)"),
      field("overlap", &MatcherParams::overlap, 0.0, 0.95,
            "patch overlap on the finest level; stride = max(1, round(p * (1 - overlap)))"),
      field("coarse_overlap", &MatcherParams::coarse_overlap, 0.0, 0.95,
            "patch overlap on the coarser levels, which only initialise the next finer one"),
      field("mean_normalization", &MatcherParams::mean_normalization, 0, 1,
            "subtract patch means so a brightness offset between cameras cancels"),
      field("propagation", &MatcherParams::propagation, 0, 1,
            "start each patch from a neighbour's disparity when that fits better (DIS)"),
      field("search_band_rows", &MatcherParams::search_band_rows, 0, 10000,
            "finest level searched in bands of this many patch rows (in cache); 0 = the whole level (DIS)"),
      field("gain_compensation", &MatcherParams::gain_compensation, 0, 1,
            "divide out the views' contrast gain, estimated from the coarser levels"),
      field("coarser_look", &MatcherParams::coarser_look, 0, 1,
            "finest level: a patch without evidence searches again one level coarser, on twice its footprint"),
      field("two_scales", &MatcherParams::two_scales, 0, 1,
            "also match one level coarser; keep, per pixel, the more confident estimate (dark, flat, block-coded tissue)"),
      field("support_grey", &MatcherParams::support_grey, 0.0, 255.0,
            "finest level: a pixel g grey levels from its patch centre weighs 1 / (1 + (g / h)^2), h this "
            "(scaled below a centre of 64), so patches beside an edge match their centre; 0 = off"),
      field("support_edge_grey", &MatcherParams::support_edge_grey, 0.0, 255.0,
            "support weights only in patches with a pixel this many grey levels (scaled as support_grey) from the "
            "centre's (an edge); 0 = every patch"),
      field("min_valid_share", &MatcherParams::min_valid_share, 0.0, 1.0,
            "gamma: minimum share of valid (non-black) pixels in a patch"),
      field("saturation_grey", &MatcherParams::saturation_grey, 1, 256,
            "pixels this bright in either view (specular highlights) are left out like black ones; 256 = none"),
      field("dark_floor_grey", &MatcherParams::dark_floor_grey, 0, 255,
            "pixels darker than this in either view (near-black surfaces) are left out like black ones; 0 = none"),
      field("window_half_width", &MatcherParams::window_half_width, 1, 10,
            "n: the posterior window has 2n+1 disparity samples"),
      field("window_step", &MatcherParams::window_step, 0.05, 4.0,
            "delta: spacing of the posterior window samples, px at the level"),
      field("sigma_r", &MatcherParams::sigma_r, 0.1, 255.0,
            "brightness noise of the likelihood, grey levels"),
      field("contrast_share", &MatcherParams::contrast_share, 0.0, 100.0,
            "share of the optimum's own residual added to sigma_r^2 (0 = paper's posterior)"),
      field("sigma_s", &MatcherParams::sigma_s, 0.1, 100.0,
            "spatial Gaussian inside a patch, px at the level"),
      field("confidence_floor", &MatcherParams::confidence_floor, 0.0, 1.0,
            "pixels whose covering patches' mean evidence is lower get no disparity"),
      field("lr_check_tolerance", &MatcherParams::lr_check_tolerance, 0.0, 100.0,
            "drop estimates the search from the right image does not confirm within this "
            "(full-resolution px); 0 = off"),
      field("lr_check_overlap", &MatcherParams::lr_check_overlap, 0.0, 0.95,
            "patch overlap of the left-right check's search from the right image (finest level)"),
      field("compute_variance", &MatcherParams::compute_variance, 0, 1,
            "also compute the per-pixel disparity variance (px^2), published as variance"),
      field("calibrated_confidence", &MatcherParams::calibrated_confidence, 0, 1,
            "publish the confidence as the probability of being within 2 px (fitted on generated scenes); "
            "false = the cues' raw product"),
      field("min_confidence", &MatcherParams::min_confidence, 0.0, 1.0,
            "estimates with a lower confidence are dropped (disparity, depth, points); 0 = none"),
      field("refinement_iterations", &MatcherParams::refinement_iterations, 0, 20,
            "variational refinement of the finest level's estimates (DIS's last stage, along x): "
            "fixed-point steps; 0 = off"),
      field("refinement_smoothness", &MatcherParams::refinement_smoothness, 0.0, 1000.0,
            "alpha: weight of the variational refinement's smoothness term against its data term"),
  };
  return fields;
}

const ParamField* findParamField(const std::string& name) {
  for (const ParamField& f : paramFields()) {
    if (name == f.name) return &f;
  }
  return nullptr;
}

void MatcherParams::validate() const {
  for (const ParamField& f : paramFields()) {
    const double v = f.get(*this);
    if (!std::isfinite(v) || v < f.min_value || v > f.max_value) {
      std::ostringstream os;
      os << "parameter " << f.name << " = " << v << " is out of range [" << f.min_value << ", "
         << f.max_value << "]: " << f.description;
      throw std::invalid_argument(os.str());
    }
  }
  if (finest_level >= 0 && finest_level > coarsest_level) {
    throw std::invalid_argument("parameter finest_level = " + std::to_string(finest_level) +
                                " is coarser than coarsest_level = " +
                                std::to_string(coarsest_level) +
                                ": finest_level must be <= coarsest_level");
  }
}

namespace {

// One source for the names, their order and what each trades (the cfg and
// the docs take the descriptions from here or are checked against them).
// Time ratios: measured, single core, 640x480.
struct PresetEntry {
  const char* name;
  const char* description;
};
const PresetEntry kPresets[] = {
    {"fast", "stride 5 on the finest level too, no support weights: about 0.75 of the time of balanced"},
    {"balanced", "the default settings"},
    {"accurate",
     "stride 2, the left-right check as dense with tolerance 2, two variational refinement steps and "
     "support weights in every patch: about 3 times the time of balanced"},
};

std::string presetList() {
  std::string names;
  for (const PresetEntry& p : kPresets) names += std::string(names.empty() ? "" : ", ") + p.name;
  return names;
}

}  // namespace

int MatcherParams::finestLevelFor(int width) const {
  const int level = finest_level >= 0
                        ? finest_level
                        : std::max(1, static_cast<int>(std::lround(std::log2(std::max(1, width) / 320.0))));
  return std::min(level, coarsest_level);
}

float MatcherParams::checkToleranceFor(int width) const {
  return finest_level < 0 && finestLevelFor(width) > 1 ? 2.f * lr_check_tolerance : lr_check_tolerance;
}

int MatcherParams::patchSizeFor(int width) const {
  const int level = finestLevelFor(width);
  if (finest_level >= 0 || level <= 1) return patch_size;
  const double scene_share = static_cast<double>(std::max(1, width)) / (320.0 * static_cast<double>(1 << level));
  return std::clamp(static_cast<int>(std::lround(patch_size * scene_share)), 4, patch_size);
}

std::vector<std::string> MatcherParams::presetNames() {
  std::vector<std::string> names;
  for (const PresetEntry& p : kPresets) names.push_back(p.name);
  return names;
}

const char* presetDescription(const std::string& name) {
  for (const PresetEntry& p : kPresets) {
    if (name == p.name) return p.description;
  }
  throw std::invalid_argument("unknown preset '" + name + "': expected one of " + presetList());
}

const ParamSpec& presetSpec() {
  static const ParamSpec spec{
      "preset", ParamSpec::Type::String, 0.0, 0.0,
      "named matcher settings (fast, balanced, accurate), applied before the fields given one by one"};
  return spec;
}

MatcherParams MatcherParams::preset(const std::string& name) {
  MatcherParams p;  // balanced: the defaults (stride 3 at patch 8, 5 above and in the check)
  if (name == "balanced") return p;
  if (name == "fast") {
    // Stride 5 on the finest level too: a little less density and a larger
    // median error (presetDescription: the time). No support weights: their
    // few per cent of time.
    p.overlap = 0.4f;
    p.support_grey = 0.f;
    return p;
  }
  if (name == "accurate") {
    // Stride 2, and the left-right check searches as densely, with the
    // tighter tolerance: more estimates at the same error. Then the
    // variational refinement: fewer wrong ones (docs/method.md).
    p.overlap = 0.7f;
    p.lr_check_overlap = 0.7f;
    p.lr_check_tolerance = 2.f;
    p.refinement_iterations = 2;
    // Two Gauss-Newton steps and the higher floor: with the denser search
    // and two refinement steps they keep bad2 lowest (docs/method.md).
    p.iterations = 2;
    p.confidence_floor = 0.02f;
    // More estimates on dark and flat tissue for a few per cent of its time.
    p.coarser_look = true;
    // Dark, flat and block-coded tissue from the coarser scale where it is
    // the more confident.
    p.two_scales = true;
    // The support weights in every patch, not only those with an edge.
    p.support_edge_grey = 0.f;
    return p;
  }
  throw std::invalid_argument("unknown preset '" + name + "': expected one of " + presetList());
}

// ---- Binding values ---------------------------------------------------------

namespace {

// The shortest decimal that reads back as `v` (2.5, not 2.5000000000000000).
std::string shortestNumber(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  for (int precision = 6; precision <= 17; ++precision) {
    std::ostringstream os;
    os.precision(precision);
    os << v;
    if (std::stod(os.str()) == v) return os.str();
  }
  return std::to_string(v);
}

const char* expectedKind(ParamSpec::Type type) {
  switch (type) {
    case ParamSpec::Type::Bool:
      return "true or false";
    case ParamSpec::Type::Int:
      return "a whole number";
    case ParamSpec::Type::Float:
      return "a number";
    case ParamSpec::Type::String:
      return "a string";
  }
  return "?";
}

// "parameter NAME = VALUE PROBLEM: DESCRIPTION" under `source`.
[[noreturn]] void refuse(const ParamSpec& spec, const ParamValue& value, const std::string& problem,
                         const std::string& source) {
  throw ParamError(source, std::string("parameter ") + spec.name + " = " + value.str() + " " + problem +
                               ": " + spec.description);
}

}  // namespace

ParamValue ParamValue::ofBool(bool v) {
  ParamValue p;
  p.kind = Kind::Bool;
  p.boolean = v;
  return p;
}

ParamValue ParamValue::ofInteger(long long v) {
  ParamValue p;
  p.kind = Kind::Integer;
  p.integer = v;
  return p;
}

ParamValue ParamValue::ofReal(double v) {
  ParamValue p;
  p.kind = Kind::Real;
  p.real = v;
  return p;
}

ParamValue ParamValue::ofString(std::string v) {
  ParamValue p;
  p.kind = Kind::String;
  p.text = std::move(v);
  return p;
}

ParamValue ParamValue::ofOther(std::string what) {
  ParamValue p;
  p.kind = Kind::Other;
  p.text = std::move(what);
  return p;
}

bool ParamValue::isBoolWord(const std::string& text, bool& value) {
  static const char* const kTrue[] = {"true", "True", "TRUE", "yes", "Yes", "YES", "on", "On", "ON"};
  static const char* const kFalse[] = {"false", "False", "FALSE", "no", "No", "NO", "off", "Off", "OFF"};
  for (const char* word : kTrue) {
    if (text == word) {
      value = true;
      return true;
    }
  }
  for (const char* word : kFalse) {
    if (text == word) {
      value = false;
      return true;
    }
  }
  return false;
}

ParamValue ParamValue::fromText(const std::string& text) {
  bool b = false;
  if (isBoolWord(text, b)) return ofBool(b);
  const bool looks_integer =
      !text.empty() &&
      text.find_first_not_of("0123456789", text[0] == '-' || text[0] == '+') == std::string::npos &&
      text.find_first_of("0123456789") != std::string::npos;
  if (looks_integer) {
    errno = 0;
    const long long v = std::strtoll(text.c_str(), nullptr, 10);
    if (errno == 0) return ofInteger(v);  // beyond long long: read as a real below
  }
  // YAML spells the non-finite values .nan, .inf, -.inf (any case of the word).
  std::string number = text;
  for (const char* word : {".nan", ".NaN", ".NAN", ".inf", ".Inf", ".INF"}) {
    for (const char* sign : {"", "+", "-"}) {
      if (text == std::string(sign) + word) number = std::string(sign) + (word + 1);
    }
  }
  if (!number.empty() && !std::isspace(static_cast<unsigned char>(number[0]))) {
    char* end = nullptr;
    const double v = std::strtod(number.c_str(), &end);
    if (end == number.c_str() + number.size()) return ofReal(v);
  }
  return ofString(text);
}

std::string ParamValue::str() const {
  switch (kind) {
    case Kind::Bool:
      return boolean ? "true" : "false";
    case Kind::Integer:
      return std::to_string(integer);
    case Kind::Real: {
      // A real stays recognisable as one: 3.0, not 3.
      const std::string s = shortestNumber(real);
      return std::isfinite(real) && s.find_first_of(".e") == std::string::npos ? s + ".0" : s;
    }
    case Kind::String:
      return "'" + text + "'";
    case Kind::Other:
      return "(" + text + ")";
  }
  return "?";
}

ParamError::ParamError(const std::string& source, const std::string& detail)
    : std::invalid_argument(source + ": " + detail), source_(source), detail_(detail) {}

ParamValue checkParam(const ParamSpec& spec, const ParamValue& value, const std::string& source) {
  using Kind = ParamValue::Kind;
  switch (spec.type) {
    case ParamSpec::Type::Bool:
      if (value.kind != Kind::Bool) refuse(spec, value, "must be true or false", source);
      return value;
    case ParamSpec::Type::String:
      if (value.kind != Kind::String) refuse(spec, value, "must be a string", source);
      return value;
    case ParamSpec::Type::Int:
    case ParamSpec::Type::Float:
      break;
  }
  if (value.kind != Kind::Integer && value.kind != Kind::Real) {
    refuse(spec, value, std::string("must be ") + expectedKind(spec.type), source);
  }
  const double v = value.kind == Kind::Integer ? static_cast<double>(value.integer) : value.real;
  if (!std::isfinite(v)) refuse(spec, value, "is not a finite number", source);
  if (spec.type == ParamSpec::Type::Int && v != std::floor(v)) {
    refuse(spec, value, "must be a whole number", source);
  }
  if (v < spec.min_value || v > spec.max_value) {
    refuse(spec, value,
           "is out of range [" + shortestNumber(spec.min_value) + ", " + shortestNumber(spec.max_value) + "]",
           source);
  }
  return spec.type == ParamSpec::Type::Int ? ParamValue::ofInteger(static_cast<long long>(v))
                                           : ParamValue::ofReal(v);
}

void bindParam(MatcherParams& params, const ParamField& field, const ParamValue& value,
               const std::string& source) {
  const ParamValue checked = checkParam(field, value, source);
  switch (checked.kind) {
    case ParamValue::Kind::Bool:
      field.set(params, checked.boolean ? 1.0 : 0.0);
      break;
    case ParamValue::Kind::Integer:
      field.set(params, static_cast<double>(checked.integer));
      break;
    default:
      field.set(params, checked.real);
      break;
  }
}

void bindParam(MatcherParams& params, const std::string& name, const ParamValue& value,
               const std::string& source) {
  const ParamField* field = findParamField(name);
  if (!field) throw ParamError(source, "unknown parameter '" + name + "'");
  bindParam(params, *field, value, source);
}

MatcherParams bindPreset(const ParamValue& value, const std::string& source) {
  const std::string name = checkParam(presetSpec(), value, source).text;
  for (const PresetEntry& p : kPresets) {
    if (name == p.name) return MatcherParams::preset(name);
  }
  throw ParamError(source,
                   "parameter preset = " + value.str() + " is unknown: expected one of " + presetList());
}

// ---- Parameter files -----------------------------------------------------------

namespace {

// True when the text holds no YAML content: only blank lines, comments,
// directives ("%YAML") and document markers.
bool holdsNoContent(const std::string& content) {
  std::istringstream lines(content);
  std::string line;
  while (std::getline(lines, line)) {
    const size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos) continue;
    const char c = line[first];
    if (c == '#' || c == '%') continue;
    if (line.compare(first, 3, "---") == 0 && line.find_first_not_of(" \t\r", first + 3) == std::string::npos)
      continue;
    return false;
  }
  return true;
}

// OpenCV's JSON reader turns true and false into the integers 1 and 0, which
// the binder refuses for booleans (and would take for numbers): quote them
// outside strings, so that they arrive as the words YAML files give.
std::string quoteJsonBooleans(const std::string& json) {
  std::string out;
  out.reserve(json.size() + 16);
  bool in_string = false;
  for (size_t i = 0; i < json.size(); ++i) {
    const char c = json[i];
    if (in_string) {
      out += c;
      if (c == '\\' && i + 1 < json.size()) {
        out += json[++i];
      } else if (c == '"') {
        in_string = false;
      }
      continue;
    }
    if (c == '"') in_string = true;
    bool replaced = false;
    for (const char* word : {"true", "false"}) {
      const size_t n = std::char_traits<char>::length(word);
      const bool starts_token = i == 0 || !std::isalnum(static_cast<unsigned char>(json[i - 1]));
      const bool ends_token = i + n >= json.size() || !std::isalnum(static_cast<unsigned char>(json[i + n]));
      if (starts_token && ends_token && json.compare(i, n, word) == 0) {
        out += '"' + std::string(word) + '"';
        i += n - 1;
        replaced = true;
        break;
      }
    }
    if (!replaced) out += c;
  }
  return out;
}

// A YAML node as its source gave it. OpenCV has no boolean type: true and
// false arrive as strings and are read as the YAML words.
ParamValue valueOf(const cv::FileNode& node) {
  if (node.isInt()) return ParamValue::ofInteger(static_cast<int>(node));
  if (node.isReal()) return ParamValue::ofReal(static_cast<double>(node));
  if (node.isString()) {
    const std::string text = static_cast<std::string>(node);
    bool b = false;
    return ParamValue::isBoolWord(text, b) ? ParamValue::ofBool(b) : ParamValue::ofString(text);
  }
  if (node.isSeq()) return ParamValue::ofOther("a list");
  if (node.isMap()) return ParamValue::ofOther("a map");
  return ParamValue::ofOther("no value");
}

}  // namespace

MatcherParams loadParams(const std::string& path, const MatcherParams& base) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument("cannot open parameter file " + path);
  std::stringstream text;
  text << in.rdbuf();
  std::string content = text.str();
  if (holdsNoContent(content)) {
    throw std::invalid_argument("parameter file " + path +
                                " is empty: expected name: value pairs (e.g. preset: balanced)");
  }
  // OpenCV's YAML reader wants its own "%YAML:1.0" header; ordinary ROS-style
  // YAML files have none, so add it (JSON files start with '{').
  const size_t first = content.find_first_not_of(" \t\r\n");
  if (content[first] == '{') {
    content = quoteJsonBooleans(content);
  } else if (content.compare(0, 5, "%YAML") != 0) {
    content = "%YAML:1.0\n" + content;
  }
  cv::FileStorage fs;
  try {
    fs.open(content, cv::FileStorage::READ | cv::FileStorage::MEMORY);
  } catch (const cv::Exception& e) {
    throw std::invalid_argument("cannot parse parameter file " + path + ": " + e.msg);
  }
  if (!fs.isOpened()) throw std::invalid_argument("cannot parse parameter file " + path);
  const cv::FileNode root = fs.root();
  if (!root.isMap()) {
    throw std::invalid_argument("parameter file " + path + " is not a map of name: value pairs");
  }
  const std::string source = "parameter file " + path;
  MatcherParams p = base;
  const cv::FileNode preset_node = root["preset"];
  if (!preset_node.empty()) p = bindPreset(valueOf(preset_node), source);
  for (const cv::FileNode& node : root) {
    if (node.name() != "preset") bindParam(p, node.name(), valueOf(node), source);
  }
  try {
    p.validate();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(source + ": " + e.what());
  }
  return p;
}

std::string toYaml(const MatcherParams& params) {
  std::ostringstream os;
  for (const ParamField& f : paramFields()) {
    os << f.name << ": " << formatValue(f, f.get(params)) << "\n";
  }
  return os.str();
}

}  // namespace bdis
