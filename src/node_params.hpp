// The nodelet's start-up parameters: its own (node level, one table here)
// and the matcher's (bdis::paramFields()), read from the parameter server
// through the core's binder (bdis::checkParam), so a value means the same as
// in a parameter file, on bdis_match's command line or in dynamic_reconfigure.
// Needs no master: the server is reached through two functions, which tests
// replace by a map.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <xmlrpcpp/XmlRpcValue.h>

#include "bdis_stereo/params.hpp"
#include "ros_frame.hpp"

namespace bdis_stereo {

/// The nodelet's own parameters, fixed at start-up. The initialisers are the
/// defaults (nodeParamTable() reads them from here).
struct NodeParams {
  std::string preset = "balanced";
  bool approximate_sync = false;
  int queue_size = 5;
  std::string image_transport = "raw";
  bool rectify = false;
  bool organized_cloud = true;
  int cloud_stride = 0;
  std::string target_frame;
  double tf_timeout = 0.01;
  int max_image_pixels = static_cast<int>(kDefaultMaxImagePixels);
  double sync_warn_timeout = 3.0;
  double diagnostic_period = 1.0;

  /// points2's stride for frames `width` px wide: cloud_stride when set,
  /// else round(width / 640), at least 1: an HD frame's cloud stays about
  /// 640 points wide (its disparity is searched at a level as coarse).
  int cloudStrideFor(int width) const;
};

/// One node parameter: what it accepts (name, type, range, description) and
/// where it lives in NodeParams.
struct NodeParam {
  bdis::ParamSpec spec;
  /// The value in `params`, as the parameter server holds it.
  std::function<bdis::ParamValue(const NodeParams& params)> get;
  /// Checks `value` (bdis::checkParam; preset: a known name) and stores it;
  /// throws bdis::ParamError naming `source` and leaves `params` as it was.
  std::function<void(NodeParams& params, const bdis::ParamValue& value, const std::string& source)> bind;
};

/// Every node parameter, in the order the README lists them. Ones read by a
/// library (image_transport: TransportHints, diagnostic_period:
/// diagnostic_updater) are checked here and written back for it.
const std::vector<NodeParam>& nodeParamTable();

/// README and error messages: "bool", "int", "double", "string".
const char* nodeParamTypeName(bdis::ParamSpec::Type type);

/// A parameter server value as the binder takes it (int, double, bool,
/// string; anything else, e.g. a list, as ParamValue::Kind::Other).
bdis::ParamValue paramValueOf(const XmlRpc::XmlRpcValue& value);
/// The reverse, for writing effective values back.
XmlRpc::XmlRpcValue xmlRpcValueOf(const bdis::ParamValue& value);

/// A float field's value as a double that prints as the float does (0.6,
/// not 0.60000002), for the parameter server and dynamic_reconfigure.
double displayedFloat(double value);

/// The matcher field's value in `params` as the parameter server holds it.
bdis::ParamValue matcherValueOf(const bdis::ParamField& field, const bdis::MatcherParams& params);

struct StartupParams {
  NodeParams node;
  bdis::MatcherParams matcher;
};

/// Reads a parameter by name: false when it is not set.
using ParamLookup = std::function<bool(const std::string& name, XmlRpc::XmlRpcValue& value)>;
/// Receives one message per bad value.
using ParamReport = std::function<void(const std::string& message)>;

/// Reads the node parameters, then the preset, then every matcher field that
/// is set, from `lookup`. A bad value is reported (the binder's message,
/// naming `source`, then "; using X") and the default (node parameter) or the
/// preset's value (matcher field) is kept; matcher levels that pass one by one
/// but not together (finest_level > coarsest_level) fall back to the preset's.
StartupParams readStartupParams(const ParamLookup& lookup, const std::string& source,
                                const ParamReport& report);

/// Every effective value, node parameters then matcher fields, as the
/// parameter server should show them (so `rosparam get` and
/// dynamic_reconfigure see what is used).
std::vector<std::pair<std::string, XmlRpc::XmlRpcValue>> effectiveParams(const StartupParams& params);

}  // namespace bdis_stereo
