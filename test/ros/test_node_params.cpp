// The nodelet's start-up parameters without a master: the parameter server is
// a map. Bad values are reported with the binder's rules and replaced; the
// effective values are what goes back to the server.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "../../src/node_params.hpp"
#include "bdis_stereo/params.hpp"

namespace {

using bdis_stereo::NodeParams;
using bdis_stereo::readStartupParams;
using bdis_stereo::StartupParams;
using XmlRpc::XmlRpcValue;

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

struct FakeServer {
  std::map<std::string, XmlRpcValue> values;
  std::vector<std::string> reports;

  StartupParams read() {
    return readStartupParams(
        [this](const std::string& name, XmlRpcValue& v) {
          auto it = values.find(name);
          if (it == values.end()) return false;
          v = it->second;
          return true;
        },
        "parameter server /ns/bdis", [this](const std::string& m) { reports.push_back(m); });
  }

  // The one report that mentions `what`.
  std::string reportAbout(const std::string& what) const {
    std::string found;
    for (const std::string& r : reports) {
      if (contains(r, what)) {
        EXPECT_TRUE(found.empty()) << "two reports about " << what;
        found = r;
      }
    }
    EXPECT_FALSE(found.empty()) << "no report about " << what;
    return found;
  }
};

const bdis_stereo::NodeParam& nodeParam(const std::string& name) {
  for (const auto& p : bdis_stereo::nodeParamTable()) {
    if (name == p.spec.name) return p;
  }
  throw std::runtime_error("no node parameter " + name);
}

TEST(NodeParams, TableDescribesEveryParameterOnceWithItsDefault) {
  std::set<std::string> names;
  const NodeParams defaults;
  for (const auto& p : bdis_stereo::nodeParamTable()) {
    SCOPED_TRACE(p.spec.name);
    EXPECT_TRUE(names.insert(p.spec.name).second) << "duplicate";
    EXPECT_EQ(bdis::findParamField(p.spec.name), nullptr) << "also a matcher field";
    EXPECT_GT(std::string(p.spec.description).size(), 10u);
    // The default passes its own rules.
    NodeParams params;
    EXPECT_NO_THROW(p.bind(params, p.get(defaults), "test"));
  }
  for (const char* name :
       {"preset", "approximate_sync", "queue_size", "image_transport", "organized_cloud", "cloud_stride",
        "target_frame", "tf_timeout", "max_image_pixels", "sync_warn_timeout", "diagnostic_period"}) {
    EXPECT_EQ(names.count(name), 1u) << name;
  }
  EXPECT_EQ(nodeParam("queue_size").get(defaults).integer, 5);
  EXPECT_EQ(nodeParam("max_image_pixels").get(defaults).integer,
            static_cast<long long>(bdis_stereo::kDefaultMaxImagePixels));
  EXPECT_EQ(nodeParam("preset").get(defaults).text, "balanced");
}

TEST(NodeParams, CloudStrideFollowsTheWidthUnlessSet) {
  NodeParams p;  // cloud_stride 0
  EXPECT_EQ(p.cloudStrideFor(320), 1);
  EXPECT_EQ(p.cloudStrideFor(640), 1);
  EXPECT_EQ(p.cloudStrideFor(959), 1);
  EXPECT_EQ(p.cloudStrideFor(960), 2);
  EXPECT_EQ(p.cloudStrideFor(1280), 2);
  EXPECT_EQ(p.cloudStrideFor(1920), 3);
  EXPECT_EQ(p.cloudStrideFor(3840), 6);
  p.cloud_stride = 1;  // set: honoured at any width
  EXPECT_EQ(p.cloudStrideFor(1920), 1);
  p.cloud_stride = 4;
  EXPECT_EQ(p.cloudStrideFor(640), 4);
}

TEST(NodeParams, NothingSetGivesTheDefaultsAndTheBalancedPreset) {
  FakeServer server;
  const StartupParams p = server.read();
  EXPECT_TRUE(server.reports.empty());
  for (const auto& entry : bdis_stereo::nodeParamTable()) {
    EXPECT_EQ(entry.get(p.node).str(), entry.get(NodeParams{}).str()) << entry.spec.name;
  }
  for (const bdis::ParamField& f : bdis::paramFields()) {
    EXPECT_EQ(f.get(p.matcher), f.get(bdis::MatcherParams::preset("balanced"))) << f.name;
  }
}

TEST(NodeParams, GoodValuesAreTaken) {
  FakeServer server;
  server.values = {{"approximate_sync", XmlRpcValue(true)},
                   {"queue_size", XmlRpcValue(12)},
                   {"tf_timeout", XmlRpcValue(0.5)},
                   {"target_frame", XmlRpcValue(std::string("world"))},
                   {"preset", XmlRpcValue(std::string("fast"))},
                   {"iterations", XmlRpcValue(4.0)},
                   {"sigma_r", XmlRpcValue(2)},
                   {"compute_variance", XmlRpcValue(true)}};
  const StartupParams p = server.read();
  EXPECT_TRUE(server.reports.empty()) << server.reports.front();
  EXPECT_TRUE(p.node.approximate_sync);
  EXPECT_EQ(p.node.queue_size, 12);
  EXPECT_EQ(p.node.tf_timeout, 0.5);
  EXPECT_EQ(p.node.target_frame, "world");
  EXPECT_EQ(p.node.preset, "fast");
  EXPECT_EQ(p.matcher.overlap, bdis::MatcherParams::preset("fast").overlap);  // the preset applied first
  EXPECT_EQ(p.matcher.iterations, 4);  // a whole real for an int, as everywhere
  EXPECT_EQ(p.matcher.sigma_r, 2.f);
  EXPECT_TRUE(p.matcher.compute_variance);
}

// Each bad value alone is reported, naming the source, the parameter, the
// value and the rule, and replaced by the default or the preset's value.
TEST(NodeParams, BadValuesAreReportedOneByOneAndReplaced) {
  FakeServer server;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  server.values = {
      {"preset", XmlRpcValue(std::string("turbo"))},
      {"patch_size", XmlRpcValue(1000)},
      {"overlap", XmlRpcValue(std::string("lots"))},
      {"iterations", XmlRpcValue(2.5)},
      {"sigma_r", XmlRpcValue(nan)},
      {"compute_variance", XmlRpcValue(1)},
      {"queue_size", XmlRpcValue(0)},
      {"max_image_pixels", XmlRpcValue(10)},
      {"tf_timeout", XmlRpcValue(-1.0)},
      {"approximate_sync", XmlRpcValue(std::string("yes"))},
      {"target_frame", XmlRpcValue(3)},
      {"sync_warn_timeout", XmlRpcValue(0.0)},
  };
  const StartupParams p = server.read();
  const std::string src = "parameter server /ns/bdis: ";
  EXPECT_EQ(server.reportAbout("preset"), src +
                                              "parameter preset = 'turbo' is unknown: expected one of fast, "
                                              "balanced, accurate; using 'balanced'");
  EXPECT_EQ(server.reportAbout("patch_size"), src + "parameter patch_size = 1000 is out of range [4, 32]: " +
                                                  bdis::findParamField("patch_size")->description +
                                                  "; using 8");
  EXPECT_TRUE(contains(server.reportAbout("overlap"), "parameter overlap = 'lots' must be a number"));
  EXPECT_TRUE(
      contains(server.reportAbout("iterations"), "parameter iterations = 2.5 must be a whole number"));
  EXPECT_TRUE(contains(server.reportAbout("sigma_r"), "parameter sigma_r = nan is not a finite number"));
  EXPECT_TRUE(contains(server.reportAbout("compute_variance"), "compute_variance = 1 must be true or false"));
  EXPECT_TRUE(contains(server.reportAbout("queue_size"), "queue_size = 0 is out of range [1, 1000]"));
  EXPECT_TRUE(
      contains(server.reportAbout("max_image_pixels"), "max_image_pixels = 10 is out of range [1024, "));
  EXPECT_TRUE(contains(server.reportAbout("tf_timeout"), "tf_timeout = -1.0 is out of range [0, 1]"));
  EXPECT_TRUE(
      contains(server.reportAbout("approximate_sync"), "approximate_sync = 'yes' must be true or false"));
  EXPECT_TRUE(contains(server.reportAbout("target_frame"), "target_frame = 3 must be a string"));
  EXPECT_TRUE(contains(server.reportAbout("sync_warn_timeout"), "; using 3.0"));
  EXPECT_EQ(server.reports.size(), 12u);
  for (const std::string& r : server.reports) EXPECT_EQ(r.rfind(src, 0), 0u) << r;
  // Replaced: defaults for the node, the (balanced) preset's values for the matcher.
  const NodeParams defaults;
  EXPECT_EQ(p.node.preset, "balanced");
  EXPECT_EQ(p.node.queue_size, defaults.queue_size);
  EXPECT_EQ(p.node.max_image_pixels, defaults.max_image_pixels);
  EXPECT_EQ(p.node.tf_timeout, defaults.tf_timeout);
  EXPECT_EQ(p.node.target_frame, "");
  const bdis::MatcherParams balanced;
  for (const bdis::ParamField& f : bdis::paramFields())
    EXPECT_EQ(f.get(p.matcher), f.get(balanced)) << f.name;
}

TEST(NodeParams, InconsistentLevelsFallBackToThePresets) {
  FakeServer server;
  server.values = {{"preset", XmlRpcValue(std::string("accurate"))},
                   {"coarsest_level", XmlRpcValue(1)},
                   {"finest_level", XmlRpcValue(3)},
                   {"patch_size", XmlRpcValue(10)}};
  const StartupParams p = server.read();
  ASSERT_EQ(server.reports.size(), 1u);
  EXPECT_TRUE(contains(server.reports[0], "coarser than coarsest_level")) << server.reports[0];
  EXPECT_TRUE(contains(server.reports[0], "using the accurate preset's pyramid levels")) << server.reports[0];
  const bdis::MatcherParams accurate = bdis::MatcherParams::preset("accurate");
  EXPECT_EQ(p.matcher.coarsest_level, accurate.coarsest_level);
  EXPECT_EQ(p.matcher.finest_level, accurate.finest_level);
  EXPECT_EQ(p.matcher.patch_size, 10);  // the rest stays
  EXPECT_NO_THROW(p.matcher.validate());
}

TEST(NodeParams, EffectiveValuesGoBackTypedAndReadable) {
  FakeServer server;
  server.values = {{"queue_size", XmlRpcValue(0)}, {"iterations", XmlRpcValue(3)}};
  const StartupParams p = server.read();
  std::map<std::string, XmlRpcValue> back;
  for (const auto& [name, value] : bdis_stereo::effectiveParams(p)) back[name] = value;
  EXPECT_EQ(back.size(), bdis_stereo::nodeParamTable().size() + bdis::paramFields().size());
  EXPECT_EQ(static_cast<int>(back["queue_size"]), 5);
  EXPECT_EQ(static_cast<int>(back["iterations"]), 3);
  EXPECT_EQ(static_cast<std::string>(back["preset"]), "balanced");
  EXPECT_EQ(back["mean_normalization"].getType(), XmlRpcValue::TypeBoolean);
  EXPECT_EQ(back["overlap"].getType(), XmlRpcValue::TypeDouble);
  EXPECT_EQ(static_cast<double>(back["overlap"]), 0.6);  // as the float prints, not 0.60000002
  EXPECT_EQ(static_cast<double>(back["confidence_floor"]), 0.0175);
  EXPECT_EQ(back["target_frame"].getType(), XmlRpcValue::TypeString);
  // What goes back reads back as the same parameters, without a report.
  FakeServer again;
  again.values = back;
  const StartupParams q = again.read();
  EXPECT_TRUE(again.reports.empty());
  for (const bdis::ParamField& f : bdis::paramFields())
    EXPECT_EQ(f.get(q.matcher), f.get(p.matcher)) << f.name;
}

TEST(NodeParams, ServerValuesKeepTheirKind) {
  using Kind = bdis::ParamValue::Kind;
  EXPECT_EQ(bdis_stereo::paramValueOf(XmlRpcValue(true)).kind, Kind::Bool);
  EXPECT_EQ(bdis_stereo::paramValueOf(XmlRpcValue(3)).kind, Kind::Integer);
  EXPECT_EQ(bdis_stereo::paramValueOf(XmlRpcValue(3.0)).kind, Kind::Real);
  EXPECT_EQ(bdis_stereo::paramValueOf(XmlRpcValue(std::string("3"))).kind, Kind::String);
  XmlRpcValue list;
  list[0] = 1;
  list[1] = 2;
  const bdis::ParamValue v = bdis_stereo::paramValueOf(list);
  EXPECT_EQ(v.kind, Kind::Other);
  EXPECT_EQ(v.str(), "(a list)");
}

}  // namespace
