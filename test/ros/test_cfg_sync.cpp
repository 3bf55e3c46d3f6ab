// cfg/BdisStereo.cfg must describe exactly the core's parameters: same names,
// ranges and (balanced preset) defaults, and the preset choices of the core.
#include <gtest/gtest.h>

#include <set>
#include <string>

#include <dynamic_reconfigure/Config.h>

#include "bdis_stereo/BdisStereoConfig.h"
#include "bdis_stereo/params.hpp"

namespace {

struct Entry {
  std::string type;
  double value;
};

// name -> (type, value) of one config through its message.
std::map<std::string, Entry> entries(const bdis_stereo::BdisStereoConfig& config) {
  dynamic_reconfigure::Config msg;
  config.__toMessage__(msg);
  std::map<std::string, Entry> out;
  for (const auto& v : msg.ints) out[v.name] = {"int", static_cast<double>(v.value)};
  for (const auto& v : msg.doubles) out[v.name] = {"double", v.value};
  for (const auto& v : msg.bools) out[v.name] = {"bool", v.value ? 1.0 : 0.0};
  for (const auto& v : msg.strs) out[v.name] = {"str", 0.0};
  return out;
}

const char* typeName(bdis::ParamField::Type t) {
  switch (t) {
    case bdis::ParamField::Type::Int: return "int";
    case bdis::ParamField::Type::Float: return "double";
    case bdis::ParamField::Type::Bool: return "bool";
  }
  return "?";
}

}  // namespace

TEST(CfgSync, SameNamesAndTypesAsParamFields) {
  const auto defaults = entries(bdis_stereo::BdisStereoConfig::__getDefault__());
  std::set<std::string> expected{"preset"};
  for (const bdis::ParamField& f : bdis::paramFields()) {
    expected.insert(f.name);
    auto it = defaults.find(f.name);
    ASSERT_NE(it, defaults.end()) << "cfg/BdisStereo.cfg lacks " << f.name;
    EXPECT_EQ(it->second.type, typeName(f.type)) << f.name;
  }
  for (const auto& [name, e] : defaults) {
    EXPECT_TRUE(expected.count(name)) << "cfg/BdisStereo.cfg has " << name
                                      << ", which is no core parameter";
  }
  EXPECT_EQ(bdis_stereo::BdisStereoConfig::__getDefault__().preset, "balanced");
}

TEST(CfgSync, DefaultsAreTheBalancedPreset) {
  const auto defaults = entries(bdis_stereo::BdisStereoConfig::__getDefault__());
  const bdis::MatcherParams balanced = bdis::MatcherParams::preset("balanced");
  for (const bdis::ParamField& f : bdis::paramFields()) {
    // The core stores floats; the cfg a double written as a decimal.
    EXPECT_FLOAT_EQ(static_cast<float>(defaults.at(f.name).value), static_cast<float>(f.get(balanced)))
        << "default of " << f.name;
  }
}

TEST(CfgSync, RangesEqualParamFields) {
  const auto lo = entries(bdis_stereo::BdisStereoConfig::__getMin__());
  const auto hi = entries(bdis_stereo::BdisStereoConfig::__getMax__());
  for (const bdis::ParamField& f : bdis::paramFields()) {
    if (f.type == bdis::ParamField::Type::Bool) continue;
    EXPECT_DOUBLE_EQ(lo.at(f.name).value, f.min_value) << "min of " << f.name;
    EXPECT_DOUBLE_EQ(hi.at(f.name).value, f.max_value) << "max of " << f.name;
  }
}

TEST(CfgSync, PresetChoicesArePresetNames) {
  const auto descr = bdis_stereo::BdisStereoConfig::__getDescriptionMessage__();
  std::string edit_method;
  for (const auto& group : descr.groups) {
    for (const auto& p : group.parameters) {
      if (p.name == "preset") edit_method = p.edit_method;
    }
  }
  ASSERT_FALSE(edit_method.empty()) << "preset has no enum edit_method";
  for (const std::string& name : bdis::MatcherParams::presetNames()) {
    EXPECT_NE(edit_method.find("'value': '" + name + "'"), std::string::npos)
        << "preset enum lacks " << name << ": " << edit_method;
  }
}
