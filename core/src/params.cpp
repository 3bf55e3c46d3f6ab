#include "bdis_stereo/params.hpp"

#include <cmath>
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
  return {name,
          type,
          lo,
          hi,
          description,
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
      field("finest_level", &MatcherParams::finest_level, 0, 10,
            "finest searched level s_last; the result is upsampled to full size"),
      field("iterations", &MatcherParams::iterations, 1, 200,
            "Gauss-Newton iterations per patch"),
      field("patch_size", &MatcherParams::patch_size, 4, 32, "patch side p, px at each level"),
      field("overlap", &MatcherParams::overlap, 0.0, 0.95,
            "patch overlap on the finest level; stride = max(1, round(p * (1 - overlap)))"),
      field("coarse_overlap", &MatcherParams::coarse_overlap, 0.0, 0.95,
            "patch overlap on the coarser levels, which only initialise the next finer one"),
      field("mean_normalization", &MatcherParams::mean_normalization, 0, 1,
            "subtract patch means so a brightness offset between cameras cancels"),
      field("propagation", &MatcherParams::propagation, 0, 1,
            "start each patch from its neighbour's disparity when that fits better (DIS's spatial propagation)"),
      field("search_band_rows", &MatcherParams::search_band_rows, 0, 10000,
            "finest level: forward and backward pass per band of this many patch rows, which "
            "stays in cache; 0 = the whole level at once (DIS)"),
      field("min_valid_share", &MatcherParams::min_valid_share, 0.0, 1.0,
            "gamma: minimum share of valid (non-black) pixels in a patch"),
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
            "pixels with lower confidence get no disparity"),
      field("lr_check_tolerance", &MatcherParams::lr_check_tolerance, 0.0, 100.0,
            "drop pixels whose match, searched back from the right image, lands farther than this "
            "(full-resolution px); 0 = off"),
      field("lr_check_overlap", &MatcherParams::lr_check_overlap, 0.0, 0.95,
            "patch overlap of the left-right check's search from the right image (finest level)"),
      field("compute_variance", &MatcherParams::compute_variance, 0, 1,
            "also compute the per-pixel disparity variance (px^2)"),
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
  if (finest_level > coarsest_level) {
    throw std::invalid_argument("parameter finest_level = " + std::to_string(finest_level) +
                                " is coarser than coarsest_level = " +
                                std::to_string(coarsest_level) +
                                ": finest_level must be <= coarsest_level");
  }
}

std::vector<std::string> MatcherParams::presetNames() { return {"fast", "balanced", "accurate"}; }

MatcherParams MatcherParams::preset(const std::string& name) {
  MatcherParams p;  // balanced: the defaults (stride 3 at patch 8, 5 above and in the check)
  if (name == "balanced") return p;
  if (name == "fast") {
    // Stride 5 on the finest level too: about 0.7 of the time of balanced,
    // a little less density and a larger median error.
    p.overlap = 0.4f;
    return p;
  }
  if (name == "accurate") {
    // Stride 2, and the left-right check searches as densely, with the
    // tighter tolerance: about 2.5 times the time of balanced for more
    // estimates at the same error.
    p.overlap = 0.7f;
    p.lr_check_overlap = 0.7f;
    p.lr_check_tolerance = 2.f;
    return p;
  }
  throw std::invalid_argument("unknown preset '" + name +
                              "': expected one of fast, balanced, accurate");
}

MatcherParams loadParams(const std::string& path, const MatcherParams& base) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument("cannot open parameter file " + path);
  std::stringstream text;
  text << in.rdbuf();
  std::string content = text.str();
  // OpenCV's YAML reader wants its own "%YAML:1.0" header; ordinary ROS-style
  // YAML files have none, so add it (JSON files start with '{').
  const size_t first = content.find_first_not_of(" \t\r\n");
  if (first != std::string::npos && content[first] != '{' && content.compare(0, 5, "%YAML") != 0) {
    content = "%YAML:1.0\n" + content;
  }
  cv::FileStorage fs;
  try {
    fs.open(content, cv::FileStorage::READ | cv::FileStorage::MEMORY);
  } catch (const cv::Exception& e) {
    throw std::invalid_argument("cannot parse parameter file " + path + ": " + e.msg);
  }
  if (!fs.isOpened()) throw std::invalid_argument("cannot parse parameter file " + path);
  MatcherParams p = base;
  const cv::FileNode root = fs.root();
  if (!root.isMap()) {
    throw std::invalid_argument("parameter file " + path + " is not a map of name: value pairs");
  }
  const cv::FileNode preset_node = root["preset"];
  if (!preset_node.empty()) {
    if (!preset_node.isString()) {
      throw std::invalid_argument("parameter file " + path + ": preset must be a name");
    }
    p = MatcherParams::preset(static_cast<std::string>(preset_node));
  }
  for (const cv::FileNode& node : root) {
    const std::string key = node.name();
    if (key == "preset") continue;
    const ParamField* f = findParamField(key);
    if (!f) {
      throw std::invalid_argument("parameter file " + path + ": unknown parameter '" + key + "'");
    }
    double v = 0.0;
    if (node.isInt() || node.isReal()) {
      v = static_cast<double>(node);
    } else if (node.isString() && f->type == Type::Bool) {
      const std::string s = static_cast<std::string>(node);
      if (s == "true" || s == "True") {
        v = 1.0;
      } else if (s == "false" || s == "False") {
        v = 0.0;
      } else {
        throw std::invalid_argument("parameter file " + path + ": " + key +
                                    " must be true or false, not '" + s + "'");
      }
    } else {
      throw std::invalid_argument("parameter file " + path + ": " + key + " must be a number");
    }
    if (f->type != Type::Float && v != std::floor(v)) {
      throw std::invalid_argument("parameter file " + path + ": " + key +
                                  " must be a whole number, not " + formatValue(*f, v));
    }
    if (v < f->min_value || v > f->max_value) {
      throw std::invalid_argument("parameter file " + path + ": " + key + " = " +
                                  formatValue(*f, v) + " is out of range [" +
                                  formatValue(*f, f->min_value) + ", " +
                                  formatValue(*f, f->max_value) + "]");
    }
    f->set(p, v);
  }
  p.validate();
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
