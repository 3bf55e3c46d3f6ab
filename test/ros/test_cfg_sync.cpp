// cfg/BdisStereo.cfg must describe exactly the core's parameters: same names,
// ranges, (balanced preset) defaults and descriptions, and the preset choices
// of the core with the core's descriptions.
#include <gtest/gtest.h>

#include <map>
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
    case bdis::ParamField::Type::String:
      return "str";
  }
  return "?";
}

// name -> description of every parameter of the cfg.
std::map<std::string, std::string> descriptions() {
  std::map<std::string, std::string> out;
  for (const auto& group : bdis_stereo::BdisStereoConfig::__getDescriptionMessage__().groups) {
    for (const auto& p : group.parameters) out[p.name] = p.description;
  }
  return out;
}

// The preset enum's edit_method (a Python dict literal) as name -> description.
std::map<std::string, std::string> presetChoices() {
  std::string edit_method;
  for (const auto& group : bdis_stereo::BdisStereoConfig::__getDescriptionMessage__().groups) {
    for (const auto& p : group.parameters) {
      if (p.name == "preset") edit_method = p.edit_method;
    }
  }
  std::map<std::string, std::string> out;
  const std::string name_key = "{'name': '", description_key = "'description': ";
  for (size_t at = edit_method.find(name_key); at != std::string::npos;
       at = edit_method.find(name_key, at + 1)) {
    const size_t name_start = at + name_key.size();
    const std::string name = edit_method.substr(name_start, edit_method.find('\'', name_start) - name_start);
    // Python quotes with ' unless the text holds one, then with ".
    const size_t d = edit_method.find(description_key, name_start) + description_key.size();
    const char quote = edit_method[d];
    out[name] = edit_method.substr(d + 1, edit_method.find(quote, d + 1) - d - 1);
  }
  return out;
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

TEST(CfgSync, DescriptionsAreTheCoresWordForWord) {
  const auto cfg = descriptions();
  for (const bdis::ParamField& f : bdis::paramFields()) {
    ASSERT_TRUE(cfg.count(f.name)) << f.name;
    EXPECT_EQ(cfg.at(f.name), f.description) << "description of " << f.name;
  }
  EXPECT_EQ(cfg.at("preset"), bdis::presetSpec().description);
}

TEST(CfgSync, PresetChoicesCarryTheCoresDescriptions) {
  const auto choices = presetChoices();
  EXPECT_EQ(choices.size(), bdis::MatcherParams::presetNames().size());
  for (const std::string& name : bdis::MatcherParams::presetNames()) {
    ASSERT_TRUE(choices.count(name)) << "preset enum lacks " << name;
    EXPECT_EQ(choices.at(name), bdis::presetDescription(name)) << "description of preset " << name;
  }
}
