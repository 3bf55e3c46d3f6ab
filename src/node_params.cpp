#include "node_params.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <type_traits>

#include "bdis_stereo/matcher.hpp"  // kMinImageSide

namespace bdis_stereo {
namespace {

using Type = bdis::ParamSpec::Type;
using bdis::ParamValue;

template <typename T>
ParamValue valueOf(const T& v) {
  if constexpr (std::is_same<T, bool>::value)
    return ParamValue::ofBool(v);
  else if constexpr (std::is_same<T, int>::value)
    return ParamValue::ofInteger(v);
  else if constexpr (std::is_same<T, double>::value)
    return ParamValue::ofReal(v);
  else
    return ParamValue::ofString(v);
}

template <typename T>
NodeParam entry(const char* name, T NodeParams::*member, double lo, double hi, const char* description) {
  constexpr Type type = std::is_same<T, bool>::value     ? Type::Bool
                        : std::is_same<T, int>::value    ? Type::Int
                        : std::is_same<T, double>::value ? Type::Float
                                                         : Type::String;
  NodeParam p;
  p.spec = {name, type, lo, hi, description};
  p.get = [member](const NodeParams& params) { return valueOf(params.*member); };
  p.bind = [spec = p.spec, member](NodeParams& params, const ParamValue& value, const std::string& source) {
    const ParamValue v = bdis::checkParam(spec, value, source);
    if constexpr (std::is_same<T, bool>::value)
      params.*member = v.boolean;
    else if constexpr (std::is_same<T, int>::value)
      params.*member = static_cast<int>(v.integer);
    else if constexpr (std::is_same<T, double>::value)
      params.*member = v.real;
    else
      params.*member = v.text;
  };
  return p;
}

NodeParam presetEntry() {
  NodeParam p = entry("preset", &NodeParams::preset, 0, 0, bdis::presetSpec().description);
  p.bind = [](NodeParams& params, const ParamValue& value, const std::string& source) {
    bdis::bindPreset(value, source);  // throws for an unknown name
    params.preset = value.text;
  };
  return p;
}

}  // namespace

int NodeParams::cloudStrideFor(int width) const {
  if (cloud_stride > 0) return cloud_stride;
  return std::max(1, static_cast<int>(std::lround(width / 640.0)));
}

const std::vector<NodeParam>& nodeParamTable() {
  static const std::vector<NodeParam> table = {
      presetEntry(),
      entry("approximate_sync", &NodeParams::approximate_sync, 0, 1,
            "pair the inputs by nearest stamps (ApproximateTime) instead of equal ones"),
      entry("queue_size", &NodeParams::queue_size, 1, 1000,
            "queue length of the input subscribers and the synchroniser"),
      entry("image_transport", &NodeParams::image_transport, 0, 0,
            "transport of the input images (raw, compressed, ...)"),
      entry("rectify", &NodeParams::rectify, 0, 1,
            "raw inputs (image_raw, calibrated camera_info), rectified by image_proc/rectify "
            "(bdis_stereo.launch rectify:=true)"),
      entry("organized_cloud", &NodeParams::organized_cloud, 0, 1,
            "points2 on the image grid, NaN where there is no estimate; false: only the valid points"),
      entry("cloud_stride", &NodeParams::cloud_stride, 0, 64,
            "points2 keeps every n-th pixel of every n-th row; 0: round(width / 640), i.e. 1 below 960 px, "
            "2 at 1280, 3 at 1920"),
      entry("target_frame", &NodeParams::target_frame, 0, 0,
            "transform points2 into this frame (tf2, at the image stamp); empty: the camera frame"),
      entry("tf_timeout", &NodeParams::tf_timeout, 0.0, 1.0,
            "s to wait for the transform; without it points2 stays in the camera frame (throttled warning)"),
      entry("max_image_pixels", &NodeParams::max_image_pixels,
            static_cast<double>(bdis::kMinImageSide) * bdis::kMinImageSide, std::numeric_limits<int>::max(),
            "frames with more pixels are refused (bounded memory and time)"),
      entry("sync_warn_timeout", &NodeParams::sync_warn_timeout, 0.1, 3600.0,
            "s without a synchronised pair, while inputs arrive, before a warning"),
      entry("diagnostic_period", &NodeParams::diagnostic_period, 0.01, 3600.0,
            "s between two diagnostics updates (read by diagnostic_updater)"),
  };
  return table;
}

const char* nodeParamTypeName(bdis::ParamSpec::Type type) {
  switch (type) {
    case Type::Bool:
      return "bool";
    case Type::Int:
      return "int";
    case Type::Float:
      return "double";
    case Type::String:
      return "string";
  }
  return "?";
}

bdis::ParamValue paramValueOf(const XmlRpc::XmlRpcValue& value) {
  XmlRpc::XmlRpcValue v = value;  // the conversion operators are not const
  switch (v.getType()) {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      return ParamValue::ofBool(static_cast<bool>(v));
    case XmlRpc::XmlRpcValue::TypeInt:
      return ParamValue::ofInteger(static_cast<int>(v));
    case XmlRpc::XmlRpcValue::TypeDouble:
      return ParamValue::ofReal(static_cast<double>(v));
    case XmlRpc::XmlRpcValue::TypeString:
      return ParamValue::ofString(static_cast<std::string>(v));
    case XmlRpc::XmlRpcValue::TypeArray:
      return ParamValue::ofOther("a list");
    case XmlRpc::XmlRpcValue::TypeStruct:
      return ParamValue::ofOther("a map");
    default:
      return ParamValue::ofOther("neither a number, a boolean nor a string");
  }
}

XmlRpc::XmlRpcValue xmlRpcValueOf(const bdis::ParamValue& value) {
  switch (value.kind) {
    case ParamValue::Kind::Bool:
      return XmlRpc::XmlRpcValue(value.boolean);
    case ParamValue::Kind::Integer:
      return XmlRpc::XmlRpcValue(static_cast<int>(value.integer));
    case ParamValue::Kind::Real:
      return XmlRpc::XmlRpcValue(value.real);
    default:
      return XmlRpc::XmlRpcValue(value.text);
  }
}

double displayedFloat(double value) {
  const float f = static_cast<float>(value);
  for (int precision = 6; precision <= std::numeric_limits<float>::max_digits10; ++precision) {
    std::ostringstream os;
    os.precision(precision);
    os << f;
    if (std::stof(os.str()) == f) return std::stod(os.str());
  }
  return f;
}

bdis::ParamValue matcherValueOf(const bdis::ParamField& field, const bdis::MatcherParams& params) {
  const double v = field.get(params);
  switch (field.type) {
    case Type::Bool:
      return ParamValue::ofBool(v != 0.0);
    case Type::Int:
      return ParamValue::ofInteger(static_cast<long long>(v));
    default:
      return ParamValue::ofReal(displayedFloat(v));
  }
}

StartupParams readStartupParams(const ParamLookup& lookup, const std::string& source,
                                const ParamReport& report) {
  StartupParams out;
  for (const NodeParam& p : nodeParamTable()) {
    XmlRpc::XmlRpcValue v;
    if (!lookup(p.spec.name, v)) continue;
    try {
      p.bind(out.node, paramValueOf(v), source);
    } catch (const bdis::ParamError& e) {
      report(std::string(e.what()) + "; using " + p.get(out.node).str());
    }
  }
  // Matcher: the preset first, then every field given explicitly.
  out.matcher = bdis::MatcherParams::preset(out.node.preset);
  const bdis::MatcherParams base = out.matcher;
  for (const bdis::ParamField& f : bdis::paramFields()) {
    XmlRpc::XmlRpcValue v;
    if (!lookup(f.name, v)) continue;
    try {
      bdis::bindParam(out.matcher, f, paramValueOf(v), source);
    } catch (const bdis::ParamError& e) {
      report(std::string(e.what()) + "; using " + matcherValueOf(f, base).str());
    }
  }
  try {
    out.matcher.validate();
  } catch (const std::invalid_argument& e) {
    report(source + ": " + e.what() + "; using the " + out.node.preset + " preset's pyramid levels");
    out.matcher.coarsest_level = base.coarsest_level;
    out.matcher.finest_level = base.finest_level;
  }
  return out;
}

std::vector<std::pair<std::string, XmlRpc::XmlRpcValue>> effectiveParams(const StartupParams& params) {
  std::vector<std::pair<std::string, XmlRpc::XmlRpcValue>> out;
  for (const NodeParam& p : nodeParamTable())
    out.emplace_back(p.spec.name, xmlRpcValueOf(p.get(params.node)));
  for (const bdis::ParamField& f : bdis::paramFields()) {
    out.emplace_back(f.name, xmlRpcValueOf(matcherValueOf(f, params.matcher)));
  }
  return out;
}

}  // namespace bdis_stereo
