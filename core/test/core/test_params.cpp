// MatcherParams: presets, the field table, validation, loadParams and toYaml.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "bdis_stereo/matcher.hpp"
#include "bdis_stereo/params.hpp"
#include "test_images.hpp"

namespace {

using bdis::findParamField;
using bdis::loadParams;
using bdis::MatcherParams;
using bdis::ParamField;
using bdis::paramFields;
using bdis::toYaml;
using bdis_test::contains;
using bdis_test::invalidArgumentMessage;
using bdis_test::TempPath;

// OpenCV's own YAML directive. Files with it must keep loading; files without
// it are covered by LoadParamsReadsPlainYaml and ToYamlOutputLoadsAsIs.
const std::string kYamlDirective = "%YAML:1.0\n";

void expectSameParams(const MatcherParams& a, const MatcherParams& b) {
  for (const ParamField& f : paramFields()) {
    EXPECT_EQ(f.get(a), f.get(b)) << "field " << f.name;
  }
}

bool sameParams(const MatcherParams& a, const MatcherParams& b) {
  for (const ParamField& f : paramFields()) {
    if (f.get(a) != f.get(b)) return false;
  }
  return true;
}

/// Parameters whose coarsest/finest levels leave room to set either level to
/// any value of its range alone.
MatcherParams levelsWide() {
  MatcherParams p;
  p.coarsest_level = static_cast<int>(findParamField("coarsest_level")->max_value);
  p.finest_level = static_cast<int>(findParamField("finest_level")->min_value);
  return p;
}

// ---------------------------------------------------------------------------
// Presets
// ---------------------------------------------------------------------------

TEST(ParamsPresets, NamesAreFastBalancedAccurate) {
  const std::vector<std::string> names = MatcherParams::presetNames();
  const std::set<std::string> unique(names.begin(), names.end());
  EXPECT_EQ(unique.size(), names.size()) << "duplicate preset names";
  for (const char* expected : {"fast", "balanced", "accurate"}) {
    EXPECT_EQ(unique.count(expected), 1u) << expected;
  }
}

TEST(ParamsPresets, EveryPresetValidatesAndBuildsAMatcher) {
  for (const std::string& name : MatcherParams::presetNames()) {
    SCOPED_TRACE(name);
    const MatcherParams p = MatcherParams::preset(name);
    EXPECT_NO_THROW(p.validate());
    EXPECT_NO_THROW(bdis::Matcher{p});
  }
}

TEST(ParamsPresets, BalancedEqualsDefault) {
  expectSameParams(MatcherParams::preset("balanced"), MatcherParams{});
}

TEST(ParamsPresets, PresetsDifferFromEachOther) {
  const std::vector<std::string> names = MatcherParams::presetNames();
  for (size_t i = 0; i < names.size(); ++i) {
    for (size_t j = i + 1; j < names.size(); ++j) {
      EXPECT_FALSE(sameParams(MatcherParams::preset(names[i]), MatcherParams::preset(names[j])))
          << names[i] << " and " << names[j] << " are the same settings";
    }
  }
}

TEST(ParamsPresets, UnknownPresetThrowsNamingIt) {
  for (const std::string bad : {"turbo", "", "balanced "}) {
    const std::string msg = invalidArgumentMessage([&] { MatcherParams::preset(bad); });
    EXPECT_TRUE(contains(msg, "'" + bad + "'")) << msg;
    EXPECT_TRUE(contains(msg, "fast")) << "should list the valid names: " << msg;
  }
}

// ---------------------------------------------------------------------------
// Field table
// ---------------------------------------------------------------------------

TEST(ParamsFields, DescribeEveryFieldOnceWithWorkingAccessors) {
  const std::vector<ParamField>& fields = paramFields();
  ASSERT_FALSE(fields.empty());
  std::set<std::string> names;
  const MatcherParams defaults;
  for (const ParamField& f : fields) {
    SCOPED_TRACE(f.name);
    EXPECT_TRUE(names.insert(f.name).second) << "duplicate field";
    EXPECT_EQ(findParamField(f.name), &f);
    EXPECT_LT(f.min_value, f.max_value);
    ASSERT_NE(f.description, nullptr);
    EXPECT_GT(std::string(f.description).size(), 5u);
    // The default lies inside the range.
    EXPECT_GE(f.get(defaults), f.min_value);
    EXPECT_LE(f.get(defaults), f.max_value);
    // set() then get() returns the value, and touches no other field.
    MatcherParams p;
    const double v = f.type == ParamField::Type::Bool ? (f.get(p) != 0 ? 0.0 : 1.0)
                     : f.type == ParamField::Type::Int
                         ? std::floor(0.5 * (f.min_value + f.max_value))
                         : 0.5 * (f.min_value + f.max_value);
    f.set(p, v);
    EXPECT_FLOAT_EQ(f.get(p), v);
    for (const ParamField& other : fields) {
      if (&other != &f) {
        EXPECT_EQ(other.get(p), other.get(defaults)) << "set touched " << other.name;
      }
    }
    if (f.type == ParamField::Type::Bool) {
      EXPECT_EQ(f.min_value, 0.0);
      EXPECT_EQ(f.max_value, 1.0);
    }
  }
  EXPECT_EQ(findParamField("no_such_field"), nullptr);
  EXPECT_EQ(findParamField(""), nullptr);
  // A few fields the rest of the project relies on by name.
  for (const char* name : {"coarsest_level", "finest_level", "patch_size", "overlap",
                           "mean_normalization", "confidence_floor", "compute_variance"}) {
    EXPECT_NE(findParamField(name), nullptr) << name;
  }
}

// ---------------------------------------------------------------------------
// Validation
// ---------------------------------------------------------------------------

TEST(ParamsValidation, DefaultsValidate) { EXPECT_NO_THROW(MatcherParams{}.validate()); }

TEST(ParamsValidation, RangeLimitsThemselvesAreAccepted) {
  // Also catches a limit that cannot be represented once cast to the field's
  // type (e.g. a float min of 0.7 stored as 0.69999999).
  for (const ParamField& f : paramFields()) {
    for (double v : {f.min_value, f.max_value}) {
      SCOPED_TRACE(std::string(f.name) + " = " + std::to_string(v));
      MatcherParams p = levelsWide();
      f.set(p, v);
      EXPECT_NO_THROW(p.validate());
    }
  }
}

TEST(ParamsValidation, EveryFieldRejectsOutOfRangeValuesNamingTheField) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  int checked_fields = 0;
  for (const ParamField& f : paramFields()) {
    // A bool cannot hold an out-of-range value: set() converts any number.
    if (f.type == ParamField::Type::Bool) continue;
    ++checked_fields;
    // Non-finite and beyond the int range too: set() must not convert them to
    // int (undefined behaviour) but store a value validate() rejects.
    std::vector<double> bad = {f.min_value - 1, f.max_value + 1, nan, inf, -inf, 1e300, -1e300};
    if (f.type == ParamField::Type::Float) {
      bad.insert(bad.end(), {f.min_value - 1e-3, f.max_value + 1e-3});  // just outside
    }
    for (double v : bad) {
      SCOPED_TRACE(std::string(f.name) + " = " + std::to_string(v));
      MatcherParams p = levelsWide();
      f.set(p, v);
      const std::string msg = invalidArgumentMessage([&] { p.validate(); });
      EXPECT_TRUE(contains(msg, std::string("parameter ") + f.name + " ")) << msg;
      // The constructor and setParams validate alike.
      EXPECT_TRUE(contains(invalidArgumentMessage([&] { bdis::Matcher m(p); }), f.name));
      bdis::Matcher m;
      EXPECT_TRUE(contains(invalidArgumentMessage([&] { m.setParams(p); }), f.name));
    }
  }
  EXPECT_GE(checked_fields, 10);
}

TEST(ParamsLevels, FinestLevelFollowsTheWidthUnlessSet) {
  MatcherParams p;  // finest_level -1
  EXPECT_EQ(p.finestLevelFor(320), 1);
  EXPECT_EQ(p.finestLevelFor(640), 1);
  EXPECT_EQ(p.finestLevelFor(720), 1);
  EXPECT_EQ(p.finestLevelFor(904), 1);
  EXPECT_EQ(p.finestLevelFor(906), 2);
  EXPECT_EQ(p.finestLevelFor(1280), 2);
  EXPECT_EQ(p.finestLevelFor(1920), 3);
  EXPECT_EQ(p.finestLevelFor(3840), 4);
  // The check's tolerance doubles where the width raised the level, not otherwise.
  EXPECT_EQ(p.checkToleranceFor(640), p.lr_check_tolerance);
  EXPECT_EQ(p.checkToleranceFor(1280), 2.f * p.lr_check_tolerance);
  EXPECT_EQ(p.checkToleranceFor(1920), 2.f * p.lr_check_tolerance);
  // Never coarser than coarsest_level.
  p.coarsest_level = 2;
  EXPECT_EQ(p.finestLevelFor(3840), 2);
  // An explicit level is honoured at any width, and so is the tolerance.
  p.coarsest_level = 5;
  p.finest_level = 1;
  EXPECT_EQ(p.finestLevelFor(1920), 1);
  EXPECT_EQ(p.checkToleranceFor(1920), p.lr_check_tolerance);
  p.finest_level = 0;
  EXPECT_EQ(p.finestLevelFor(320), 0);
}

TEST(ParamsLevels, PatchShrinksWhereTheWidthRoundedTheLevelUp) {
  MatcherParams p;  // finest_level -1, patch_size 8
  // Level 1 (up to 904 px, including where the level is clamped to 1) and
  // an exact power of two keep the patch as set.
  for (const int width : {160, 320, 640, 800, 904, 1280, 2560}) {
    SCOPED_TRACE(width);
    EXPECT_EQ(p.patchSizeFor(width), 8);
  }
  // Rounded up: 8 * 1920 / (320 * 8) = 6, 8 * 960 / (320 * 4) = 6.
  EXPECT_EQ(p.patchSizeFor(1920), 6);
  EXPECT_EQ(p.patchSizeFor(960), 6);
  EXPECT_EQ(p.patchSizeFor(2200), 7);
  // Rounded down (1600 px at level 2 would need 10): never grows.
  EXPECT_EQ(p.patchSizeFor(1600), 8);
  // Scaled from the size as set, and not below the smallest valid patch.
  p.patch_size = 12;
  EXPECT_EQ(p.patchSizeFor(1920), 9);
  p.patch_size = 4;
  EXPECT_EQ(p.patchSizeFor(1920), 4);
  // An explicit level keeps the patch as set.
  p.patch_size = 8;
  p.finest_level = 3;
  EXPECT_EQ(p.patchSizeFor(1920), 8);
}

TEST(ParamsValidation, FinestLevelCoarserThanCoarsestIsRejected) {
  MatcherParams p;
  p.coarsest_level = 2;
  p.finest_level = 3;
  const std::string msg = invalidArgumentMessage([&] { p.validate(); });
  EXPECT_TRUE(contains(msg, "finest_level")) << msg;
  EXPECT_TRUE(contains(msg, "coarsest_level")) << msg;
  p.finest_level = 2;  // equal is fine: a single level
  EXPECT_NO_THROW(p.validate());
}

TEST(ParamsValidation, SetParamsRejectsInvalidAndKeepsThePreviousParams) {
  MatcherParams good = MatcherParams::preset("accurate");
  bdis::Matcher m(good);
  MatcherParams bad = good;
  bad.patch_size = 0;
  EXPECT_THROW(m.setParams(bad), std::invalid_argument);
  expectSameParams(m.params(), good);
}

// ---------------------------------------------------------------------------
// loadParams
// ---------------------------------------------------------------------------

TEST(ParamsLoad, ReadsPresetAndOverrides) {
  MatcherParams expected = MatcherParams::preset("fast");
  expected.iterations = 20;
  expected.mean_normalization = false;
  expected.compute_variance = true;
  expected.sigma_r = 2.5f;
  for (const std::string& header : {std::string(), kYamlDirective}) {
    SCOPED_TRACE(header.empty() ? "plain YAML" : "with OpenCV's YAML directive");
    TempPath file(".yaml");
    file.write(header +
               "# a comment line\n"
               "preset: fast\n"
               "iterations: 20\n"
               "mean_normalization: false\n"
               "compute_variance: true\n"
               "sigma_r: 2.5  # grey levels\n");
    expectSameParams(loadParams(file.str()), expected);
  }
}

TEST(ParamsLoad, PresetAppliesFirstWhereverItIsInTheFile) {
  TempPath file(".yaml");
  file.write(kYamlDirective + "iterations: 20\npreset: accurate\n");
  MatcherParams expected = MatcherParams::preset("accurate");
  expected.iterations = 20;
  expectSameParams(loadParams(file.str()), expected);
}

TEST(ParamsLoad, KeysNotInTheFileKeepTheBase) {
  MatcherParams base;
  base.patch_size = 12;
  base.sigma_s = 3.f;
  TempPath file(".yaml");
  file.write(kYamlDirective + "overlap: 0.5\n");
  MatcherParams expected = base;
  expected.overlap = 0.5f;
  expectSameParams(loadParams(file.str(), base), expected);
}

TEST(ParamsLoad, ReadsJson) {
  TempPath file(".json");
  file.write(R"({"preset": "accurate", "iterations": 3, "mean_normalization": false, "overlap": 0.5})");
  MatcherParams expected = MatcherParams::preset("accurate");
  expected.iterations = 3;
  expected.mean_normalization = false;
  expected.overlap = 0.5f;
  expectSameParams(loadParams(file.str()), expected);
}

TEST(ParamsLoad, RejectsUnknownKeyNamingKeyAndFile) {
  TempPath file(".yaml");
  file.write(kYamlDirective + "iterations: 5\nnot_a_param: 3\n");
  const std::string msg = invalidArgumentMessage([&] { loadParams(file.str()); });
  EXPECT_TRUE(contains(msg, "not_a_param")) << msg;
  EXPECT_TRUE(contains(msg, file.str())) << msg;
}

TEST(ParamsLoad, RejectsOutOfRangeValuesNamingTheKey) {
  for (const ParamField& f : paramFields()) {
    std::vector<std::string> values;
    std::ostringstream lo, hi;
    lo << f.min_value - 1;
    hi << f.max_value + 1;
    values = {lo.str(), hi.str()};
    if (f.type == ParamField::Type::Float) values.push_back(".nan");
    for (const std::string& v : values) {
      SCOPED_TRACE(std::string(f.name) + ": " + v);
      TempPath file(".yaml");
      file.write(kYamlDirective + f.name + ": " + v + "\n");
      const std::string msg = invalidArgumentMessage([&] { loadParams(file.str()); });
      EXPECT_TRUE(contains(msg, f.name)) << msg;
    }
  }
}

TEST(ParamsLoad, RejectsWrongTypesAndBadFilesSayingWhy) {
  struct Case {
    std::string body;
    std::vector<std::string> expected;
  };
  const std::vector<Case> cases = {
      {"iterations: 2.5\n", {"iterations", "whole number"}},
      {"iterations: abc\n", {"iterations", "number"}},
      {"iterations: [1, 2]\n", {"iterations", "number"}},
      {"mean_normalization: maybe\n", {"mean_normalization", "maybe"}},
      {"preset: turbo\n", {"turbo"}},
      {"preset: 3\n", {"preset"}},
      {"finest_level: 4\ncoarsest_level: 3\n", {"finest_level", "coarsest_level"}},
      {"- 1\n- 2\n", {"map"}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.body);
    TempPath file(".yaml");
    file.write(kYamlDirective + c.body);
    const std::string msg = invalidArgumentMessage([&] { loadParams(file.str()); });
    for (const std::string& s : c.expected) EXPECT_TRUE(contains(msg, s)) << msg;
  }
  TempPath missing(".yaml");
  const std::string msg = invalidArgumentMessage([&] { loadParams(missing.str()); });
  EXPECT_TRUE(contains(msg, missing.str())) << msg;
}

TEST(ParamsLoad, AcceptsBooleansAsWordsOnly) {
  TempPath file(".yaml");
  file.write(kYamlDirective + "mean_normalization: False\ncompute_variance: yes\n");
  const MatcherParams p = loadParams(file.str());
  EXPECT_FALSE(p.mean_normalization);
  EXPECT_TRUE(p.compute_variance);
  // Numbers are no booleans, as on the ROS parameter server.
  for (const std::string number : {"0", "1", "2", "1.0"}) {
    SCOPED_TRACE(number);
    file.write(kYamlDirective + "compute_variance: " + number + "\n");
    const std::string msg = invalidArgumentMessage([&] { loadParams(file.str()); });
    EXPECT_TRUE(contains(msg, "parameter file " + file.str() + ": parameter compute_variance = " + number +
                                  " must be true or false"))
        << msg;
  }
}

TEST(ParamsLoad, JsonBooleansAreBooleansAndJsonNumbersAreNot) {
  TempPath file(".json");
  file.write(R"({"compute_variance": true, "propagation":false, "preset": "fast"})");
  const MatcherParams p = loadParams(file.str());
  EXPECT_TRUE(p.compute_variance);
  EXPECT_FALSE(p.propagation);
  EXPECT_EQ(p.overlap, MatcherParams::preset("fast").overlap);
  file.write(R"({"compute_variance": 1})");
  EXPECT_TRUE(contains(invalidArgumentMessage([&] { loadParams(file.str()); }),
                       "parameter compute_variance = 1 must be true or false"));
  // Inside a string the word stays text.
  file.write(R"({"preset": "true \" false"})");
  EXPECT_TRUE(
      contains(invalidArgumentMessage([&] { loadParams(file.str()); }), "'true \" false' is unknown"));
}

TEST(ParamsLoad, RejectsNonFiniteNumbersSayingSo) {
  for (const std::string body : {"iterations: .nan\n", "sigma_r: .inf\n", "overlap: -.inf\n"}) {
    SCOPED_TRACE(body);
    TempPath file(".yaml");
    file.write(body);
    const std::string msg = invalidArgumentMessage([&] { loadParams(file.str()); });
    EXPECT_TRUE(contains(msg, "is not a finite number")) << msg;
    EXPECT_TRUE(contains(msg, body.substr(0, body.find(':')))) << msg;
    EXPECT_FALSE(contains(msg, "-nan")) << msg;
  }
}

TEST(ParamsLoad, EmptyFileIsRejectedSayingItIsEmpty) {
  for (const std::string body : {"", "\n  \n", "# only a comment\n", "%YAML:1.0\n", "%YAML:1.0\n---\n"}) {
    SCOPED_TRACE("'" + body + "'");
    TempPath file(".yaml");
    file.write(body);
    const std::string msg = invalidArgumentMessage([&] { loadParams(file.str()); });
    EXPECT_TRUE(contains(msg, "parameter file " + file.str() + " is empty")) << msg;
    EXPECT_FALSE(contains(msg, "Assertion")) << msg;
  }
  // An empty map is a valid file that changes nothing.
  TempPath json(".json");
  json.write("{}");
  expectSameParams(loadParams(json.str(), MatcherParams::preset("fast")), MatcherParams::preset("fast"));
}

TEST(ParamsLoad, ErrorsNameTheFileTheFieldAndItsDescription) {
  TempPath file(".yaml");
  file.write("patch_size: 1000\n");
  const std::string msg = invalidArgumentMessage([&] { loadParams(file.str()); });
  EXPECT_EQ(msg, "parameter file " + file.str() + ": parameter patch_size = 1000 is out of range [4, 32]: " +
                     findParamField("patch_size")->description);
  file.write("preset: turbo\n");
  EXPECT_EQ(invalidArgumentMessage([&] { loadParams(file.str()); }),
            "parameter file " + file.str() +
                ": parameter preset = 'turbo' is unknown: expected one of fast, balanced, accurate");
}

// ---------------------------------------------------------------------------
// The binder: one set of rules for every source
// ---------------------------------------------------------------------------

using bdis::bindParam;
using bdis::checkParam;
using bdis::ParamError;
using bdis::ParamSpec;
using bdis::ParamValue;

TEST(ParamValueFromText, ReadsTheTextAsAYamlScalar) {
  struct Case {
    std::string text;
    ParamValue::Kind kind;
    std::string shown;
  };
  const std::vector<Case> cases = {
      {"true", ParamValue::Kind::Bool, "true"},
      {"False", ParamValue::Kind::Bool, "false"},
      {"yes", ParamValue::Kind::Bool, "true"},
      {"OFF", ParamValue::Kind::Bool, "false"},
      {"2", ParamValue::Kind::Integer, "2"},
      {"-17", ParamValue::Kind::Integer, "-17"},
      {"+3", ParamValue::Kind::Integer, "3"},
      {"2.5", ParamValue::Kind::Real, "2.5"},
      {"3.0", ParamValue::Kind::Real, "3.0"},
      {"1e3", ParamValue::Kind::Real, "1000.0"},
      {"0.1", ParamValue::Kind::Real, "0.1"},
      {"nan", ParamValue::Kind::Real, "nan"},
      {".nan", ParamValue::Kind::Real, "nan"},
      {"-.inf", ParamValue::Kind::Real, "-inf"},
      {"inf", ParamValue::Kind::Real, "inf"},
      {"abc", ParamValue::Kind::String, "'abc'"},
      {"", ParamValue::Kind::String, "''"},
      {"2.5x", ParamValue::Kind::String, "'2.5x'"},
      {" 2", ParamValue::Kind::String, "' 2'"},
      {"-", ParamValue::Kind::String, "'-'"},
      {"99999999999999999999", ParamValue::Kind::Real, "1e+20"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE("'" + c.text + "'");
    const ParamValue v = ParamValue::fromText(c.text);
    EXPECT_EQ(v.kind, c.kind);
    EXPECT_EQ(v.str(), c.shown);
  }
}

// Each kind of value against each type of parameter, as every source hands
// them over: accepted (with the value bound) or refused with the reason.
TEST(ParamsBinder, OneRuleSetForEveryTypeAndKind) {
  const ParamSpec int_spec{"count", ParamSpec::Type::Int, 1, 10, "how many"};
  const ParamSpec float_spec{"share", ParamSpec::Type::Float, 0, 1, "a share"};
  const ParamSpec bool_spec{"enabled", ParamSpec::Type::Bool, 0, 1, "on or off"};
  const ParamSpec string_spec{"frame", ParamSpec::Type::String, 0, 0, "a frame name"};
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  struct Case {
    const ParamSpec* spec;
    ParamValue value;
    std::string refusal;  // "" = accepted
  };
  const std::vector<Case> cases = {
      {&int_spec, ParamValue::ofInteger(3), ""},
      {&int_spec, ParamValue::ofReal(3.0), ""},
      {&int_spec, ParamValue::ofReal(2.5), "parameter count = 2.5 must be a whole number: how many"},
      {&int_spec, ParamValue::ofReal(nan), "parameter count = nan is not a finite number: how many"},
      {&int_spec, ParamValue::ofReal(-nan), "parameter count = nan is not a finite number: how many"},
      {&int_spec, ParamValue::ofReal(inf), "parameter count = inf is not a finite number: how many"},
      {&int_spec, ParamValue::ofInteger(11), "parameter count = 11 is out of range [1, 10]: how many"},
      {&int_spec, ParamValue::ofReal(0.0), "parameter count = 0.0 is out of range [1, 10]: how many"},
      {&int_spec, ParamValue::ofBool(true), "parameter count = true must be a whole number: how many"},
      {&int_spec, ParamValue::ofString("3"), "parameter count = '3' must be a whole number: how many"},
      {&int_spec, ParamValue::ofOther("a list"),
       "parameter count = (a list) must be a whole number: how many"},
      {&float_spec, ParamValue::ofReal(0.25), ""},
      {&float_spec, ParamValue::ofInteger(1), ""},
      {&float_spec, ParamValue::ofReal(-inf), "parameter share = -inf is not a finite number: a share"},
      {&float_spec, ParamValue::ofReal(1.5), "parameter share = 1.5 is out of range [0, 1]: a share"},
      {&float_spec, ParamValue::ofString("lots"), "parameter share = 'lots' must be a number: a share"},
      {&float_spec, ParamValue::ofBool(false), "parameter share = false must be a number: a share"},
      {&bool_spec, ParamValue::ofBool(false), ""},
      {&bool_spec, ParamValue::ofInteger(1), "parameter enabled = 1 must be true or false: on or off"},
      {&bool_spec, ParamValue::ofReal(0.0), "parameter enabled = 0.0 must be true or false: on or off"},
      {&bool_spec, ParamValue::ofString("maybe"),
       "parameter enabled = 'maybe' must be true or false: on or off"},
      {&string_spec, ParamValue::ofString("world"), ""},
      {&string_spec, ParamValue::ofInteger(5), "parameter frame = 5 must be a string: a frame name"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(std::string(c.spec->name) + " = " + c.value.str());
    try {
      const ParamValue bound = checkParam(*c.spec, c.value, "somewhere");
      EXPECT_EQ(c.refusal, "") << "accepted";
      switch (c.spec->type) {
        case ParamSpec::Type::Int:
          EXPECT_EQ(bound.kind, ParamValue::Kind::Integer);
          break;
        case ParamSpec::Type::Float:
          EXPECT_EQ(bound.kind, ParamValue::Kind::Real);
          break;
        default:
          EXPECT_EQ(bound.kind, c.value.kind);
      }
    } catch (const ParamError& e) {
      EXPECT_EQ(e.detail(), c.refusal);
      EXPECT_EQ(e.source(), "somewhere");
      EXPECT_EQ(std::string(e.what()), "somewhere: " + c.refusal);
    }
  }
}

TEST(ParamsBinder, BindsIntoMatcherParamsOnlyWhatPasses) {
  MatcherParams p;
  bindParam(p, "iterations", ParamValue::ofReal(7.0), "--set");
  EXPECT_EQ(p.iterations, 7);
  bindParam(p, "sigma_r", ParamValue::ofInteger(3), "--set");
  EXPECT_EQ(p.sigma_r, 3.f);
  bindParam(p, "compute_variance", ParamValue::ofBool(true), "--set");
  EXPECT_TRUE(p.compute_variance);
  const MatcherParams before = p;
  EXPECT_EQ(invalidArgumentMessage([&] { bindParam(p, "iterations", ParamValue::fromText("2.5"), "--set"); }),
            std::string("--set: parameter iterations = 2.5 must be a whole number: ") +
                findParamField("iterations")->description);
  EXPECT_EQ(invalidArgumentMessage([&] { bindParam(p, "no_such", ParamValue::ofInteger(1), "--set"); }),
            "--set: unknown parameter 'no_such'");
  expectSameParams(p, before);  // a refused value changes nothing
}

TEST(ParamsBinder, EveryFieldTakesItsRangeEndsAndRefusesBeyond) {
  for (const ParamField& f : paramFields()) {
    SCOPED_TRACE(f.name);
    MatcherParams p = levelsWide();
    if (f.type == ParamField::Type::Bool) {
      EXPECT_NO_THROW(bindParam(p, f, ParamValue::ofBool(false), "test"));
      EXPECT_EQ(f.get(p), 0.0);
      continue;
    }
    for (double v : {f.min_value, f.max_value}) {
      bindParam(p, f, ParamValue::ofReal(v), "test");
      EXPECT_FLOAT_EQ(f.get(p), v);
    }
    for (double v : {f.min_value - 1, f.max_value + 1}) {
      const std::string msg = invalidArgumentMessage([&] { bindParam(p, f, ParamValue::ofReal(v), "test"); });
      EXPECT_TRUE(contains(msg, "is out of range [")) << msg;
      EXPECT_TRUE(contains(msg, f.description)) << msg;
    }
  }
}

TEST(ParamsBinder, PresetByNameOnly) {
  expectSameParams(bdis::bindPreset(ParamValue::ofString("accurate"), "x"),
                   MatcherParams::preset("accurate"));
  EXPECT_EQ(invalidArgumentMessage([] { bdis::bindPreset(ParamValue::ofString("turbo"), "--preset"); }),
            "--preset: parameter preset = 'turbo' is unknown: expected one of fast, balanced, accurate");
  EXPECT_TRUE(contains(invalidArgumentMessage([] { bdis::bindPreset(ParamValue::ofInteger(3), "src"); }),
                       "src: parameter preset = 3 must be a string"));
}

TEST(ParamsPresets, EveryPresetHasADescription) {
  for (const std::string& name : MatcherParams::presetNames()) {
    EXPECT_GT(std::string(bdis::presetDescription(name)).size(), 10u) << name;
  }
  // The time ratio measured for accurate (about 3 times balanced) is stated once, here.
  EXPECT_TRUE(contains(bdis::presetDescription("accurate"), "3 times"));
  EXPECT_TRUE(contains(invalidArgumentMessage([] { bdis::presetDescription("turbo"); }), "turbo"));
}

// ---------------------------------------------------------------------------
// toYaml
// ---------------------------------------------------------------------------

TEST(ParamsToYaml, OneNameValueLinePerFieldInOrder) {
  MatcherParams p;
  p.mean_normalization = false;
  p.compute_variance = true;
  p.iterations = 17;
  std::istringstream in(toYaml(p));
  std::string line;
  size_t i = 0;
  const std::vector<ParamField>& fields = paramFields();
  while (std::getline(in, line)) {
    ASSERT_LT(i, fields.size()) << "extra line: " << line;
    const ParamField& f = fields[i++];
    const std::string prefix = std::string(f.name) + ": ";
    ASSERT_EQ(line.rfind(prefix, 0), 0u) << line;
    const std::string value = line.substr(prefix.size());
    if (f.type == ParamField::Type::Bool) {
      EXPECT_EQ(value, f.get(p) != 0 ? "true" : "false");
    } else {
      EXPECT_FLOAT_EQ(std::stod(value), f.get(p)) << line;
    }
  }
  EXPECT_EQ(i, fields.size());
}

TEST(ParamsToYaml, RoundTripsThroughLoadParamsWithYamlDirective) {
  std::vector<MatcherParams> sets;
  for (const std::string& name : MatcherParams::presetNames()) sets.push_back(MatcherParams::preset(name));
  MatcherParams custom;
  custom.coarsest_level = 4;
  custom.finest_level = 0;
  custom.iterations = 20;
  custom.patch_size = 10;
  custom.overlap = 0.55f;
  custom.mean_normalization = false;
  custom.min_valid_share = 0.5f;
  custom.window_half_width = 3;
  custom.window_step = 0.5f;
  custom.sigma_r = 2.5f;
  custom.contrast_share = 1.5f;
  custom.sigma_s = 3.f;
  custom.confidence_floor = 0.1f;
  custom.compute_variance = true;
  sets.push_back(custom);
  for (const MatcherParams& p : sets) {
    TempPath file(".yaml");
    file.write(kYamlDirective + toYaml(p));
    SCOPED_TRACE(toYaml(p));
    // A different base: every value must come from the file.
    expectSameParams(loadParams(file.str(), MatcherParams::preset("fast")), p);
  }
}

// Regression tests for a bug found while writing these tests: loadParams
// opened the file with cv::FileStorage FORMAT_AUTO, which in OpenCV 4.6 decides
// the format from the first bytes, not the extension; a file not starting with
// "%YAML" (or '{' / '<') was parsed as XML and failed with "Input file is
// invalid". So toYaml()'s own output (no directive line) and any ordinary
// (ROS-style) YAML file could not be loaded. Fixed in params.cpp loadParams,
// which now prepends the directive; these tests were DISABLED_ until then.
TEST(ParamsToYaml, ToYamlOutputLoadsAsIs) {
  const MatcherParams p = MatcherParams::preset("accurate");
  TempPath file(".yaml");
  file.write(toYaml(p));
  MatcherParams loaded;
  ASSERT_NO_THROW(loaded = loadParams(file.str()));
  expectSameParams(loaded, p);
}

TEST(ParamsLoad, LoadParamsReadsPlainYaml) {
  TempPath file(".yaml");
  file.write("preset: fast\niterations: 20\n");
  MatcherParams loaded;
  ASSERT_NO_THROW(loaded = loadParams(file.str()));
  EXPECT_EQ(loaded.iterations, 20);
  EXPECT_EQ(loaded.overlap, MatcherParams::preset("fast").overlap);
}

// Regression test for a bug found while writing these tests: formatValue
// (src/core/params.cpp) wrote numbers with the stream's default precision of
// 6 significant digits, so toYaml lost float values that need more, e.g.
// sigma_r = 4.1234567f was written as 4.12346 and read back as a different
// float. Fixed (max_digits10 for float fields); DISABLED_ until then.
TEST(ParamsToYaml, ToYamlKeepsFullFloatPrecision) {
  MatcherParams p;
  p.sigma_r = 4.1234567f;
  p.window_step = 1.f / 3.f;
  p.overlap = 0.123456789f;
  TempPath file(".yaml");
  file.write(kYamlDirective + toYaml(p));
  expectSameParams(loadParams(file.str()), p);
}

}  // namespace
