// The shipped files that describe the parameters must stay in step with the
// code's tables (bdis::paramFields(), the node's nodeParamTable()):
// config/default.yaml (values, keys, comments), the README's two parameter
// tables (names, types, defaults, ranges, descriptions) and the defaults of
// the launch files' arguments. Found through the package path at run time.
#include <gtest/gtest.h>

#include <fstream>
#include <limits>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <ros/package.h>

#include "../../src/node_params.hpp"
#include "bdis_stereo/params.hpp"

namespace {

using Type = bdis::ParamSpec::Type;

std::string packageFile(const std::string& relative) {
  const std::string package = ros::package::getPath("bdis_stereo");
  EXPECT_FALSE(package.empty()) << "the bdis_stereo package is not on ROS_PACKAGE_PATH";
  return package + "/" + relative;
}

std::vector<std::string> lines(const std::string& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << "cannot read " << path;
  std::vector<std::string> out;
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

std::string joined(const std::vector<std::string>& v) {
  std::string out;
  for (const std::string& s : v) out += s + "\n";
  return out;
}

// The shortest decimal that reads back as `v`; with `as_float`, as the float.
std::string shortest(double v, bool as_float = false) {
  for (int precision = 6; precision <= 17; ++precision) {
    std::ostringstream os;
    os.precision(precision);
    os << (as_float ? static_cast<double>(static_cast<float>(v)) : v);
    if (as_float ? std::stof(os.str()) == static_cast<float>(v) : std::stod(os.str()) == v) return os.str();
  }
  return std::to_string(v);
}

// A real shown as one: 1.0, not 1.
std::string withPoint(std::string s) { return s.find_first_of(".en") == std::string::npos ? s + ".0" : s; }

std::string range(const bdis::ParamSpec& spec) {
  if (spec.type == Type::Bool || spec.type == Type::String) return "";
  return shortest(spec.min_value) + ".." + shortest(spec.max_value);
}

std::string row(const std::vector<std::string>& cells) {
  std::string out = "|";
  for (const std::string& c : cells) out += " " + c + " |";
  return out;
}

const char* kTableHeader[] = {"| parameter | type | default | range | meaning |", "|---|---|---|---|---|"};

// The matcher table as the README must show it.
std::vector<std::string> expectedMatcherTable() {
  std::vector<std::string> out(std::begin(kTableHeader), std::end(kTableHeader));
  const bdis::MatcherParams balanced;
  for (const bdis::ParamField& f : bdis::paramFields()) {
    const double v = f.get(balanced);
    std::string type, value;
    switch (f.type) {
      case Type::Bool:
        type = "bool", value = v != 0.0 ? "true" : "false";
        break;
      case Type::Int:
        type = "int", value = std::to_string(static_cast<long long>(v));
        break;
      default:
        type = "float", value = withPoint(shortest(v, true));
        break;
    }
    out.push_back(row({f.name, type, value, range(f), f.description}));
  }
  return out;
}

// A node parameter's default as the README shows it.
std::string readmeDefault(const bdis::ParamValue& v) {
  switch (v.kind) {
    case bdis::ParamValue::Kind::Real:
      return withPoint(shortest(v.real));
    case bdis::ParamValue::Kind::String:
      return "`" + (v.text.empty() ? std::string("\"\"") : v.text) + "`";
    default:
      return v.str();
  }
}

std::vector<std::string> expectedNodeTable() {
  std::vector<std::string> out(std::begin(kTableHeader), std::end(kTableHeader));
  const bdis_stereo::NodeParams defaults;
  for (const bdis_stereo::NodeParam& p : bdis_stereo::nodeParamTable()) {
    out.push_back(row({"`" + std::string(p.spec.name) + "`", bdis_stereo::nodeParamTypeName(p.spec.type),
                       readmeDefault(p.get(defaults)), range(p.spec), p.spec.description}));
  }
  return out;
}

// The lines between <!-- NAME:begin --> and <!-- NAME:end -->.
std::vector<std::string> between(const std::vector<std::string>& text, const std::string& name) {
  const std::string begin = "<!-- " + name + ":begin -->", end = "<!-- " + name + ":end -->";
  std::vector<std::string> out;
  bool inside = false, found = false;
  for (const std::string& line : text) {
    if (line == begin) {
      EXPECT_FALSE(found) << "two " << begin;
      inside = found = true;
    } else if (line == end) {
      inside = false;
    } else if (inside) {
      out.push_back(line);
    }
  }
  EXPECT_TRUE(found) << "README.md lacks " << begin;
  EXPECT_FALSE(inside) << "README.md lacks " << end;
  return out;
}

std::vector<std::string> tableLines(const std::vector<std::string>& block) {
  std::vector<std::string> out;
  for (const std::string& line : block) {
    if (line.rfind("|", 0) == 0) out.push_back(line);
  }
  return out;
}

}  // namespace

TEST(ShippedConfig, DefaultYamlEqualsBalancedPresetFieldByField) {
  const bdis::MatcherParams balanced = bdis::MatcherParams::preset("balanced");
  // Load on top of a deliberately different base so every field must come from the file.
  bdis::MatcherParams other = bdis::MatcherParams::preset("fast");
  other.iterations = 3;
  const bdis::MatcherParams loaded = bdis::loadParams(packageFile("config/default.yaml"), other);
  for (const bdis::ParamField& f : bdis::paramFields()) {
    EXPECT_EQ(f.get(loaded), f.get(balanced)) << "config/default.yaml differs in " << f.name;
  }
}

// After the header (up to the first blank line): per parameter, its
// description as comment lines (wrapped as it fits), then `name: value`;
// preset first, then every matcher field in the table's order.
TEST(ShippedConfig, DefaultYamlListsEveryKeyInOrderUnderItsDescription) {
  const std::vector<std::string> text = lines(packageFile("config/default.yaml"));
  std::vector<std::pair<std::string, std::string>> found;  // key, comment above it
  std::string comment;
  bool header = true;
  for (const std::string& line : text) {
    if (header) {
      header = !line.empty();
      continue;
    }
    if (line.rfind("# ", 0) == 0) {
      comment += (comment.empty() ? "" : " ") + line.substr(2);
    } else {
      ASSERT_NE(line.find(": "), std::string::npos) << "not a key: " << line;
      found.emplace_back(line.substr(0, line.find(": ")), comment);
      comment.clear();
    }
  }
  std::vector<std::pair<std::string, std::string>> expected = {{"preset", bdis::presetSpec().description}};
  for (const bdis::ParamField& f : bdis::paramFields()) expected.emplace_back(f.name, f.description);
  ASSERT_EQ(found.size(), expected.size());
  for (size_t i = 0; i < expected.size(); ++i) {
    EXPECT_EQ(found[i].first, expected[i].first) << "key " << i;
    EXPECT_EQ(found[i].second, expected[i].second) << "comment above " << found[i].first;
  }
}

TEST(ShippedConfig, ReadmeMatcherTableIsTheFieldTable) {
  const std::vector<std::string> block = between(lines(packageFile("README.md")), "matcher-params");
  const std::vector<std::string> expected = expectedMatcherTable();
  EXPECT_EQ(block, expected) << "README.md's matcher table should read:\n" << joined(expected);
}

TEST(ShippedConfig, ReadmeNodeTableIsTheNodeParameterTable) {
  const std::vector<std::string> table = tableLines(between(lines(packageFile("README.md")), "node-params"));
  const std::vector<std::string> expected = expectedNodeTable();
  EXPECT_EQ(table, expected) << "README.md's node parameter table should read:\n" << joined(expected);
}

// The README is for users; development material belongs in docs/.
TEST(ShippedConfig, ReadmeStaysUnder20KB) {
  std::size_t bytes = 0;
  for (const std::string& line : lines(packageFile("README.md"))) bytes += line.size() + 1;
  EXPECT_GT(bytes, 1000u);
  EXPECT_LT(bytes, 20000u) << "README.md has " << bytes << " bytes: move development material to docs/";
}

// Launch arguments that set a node parameter default to the node's default.
TEST(ShippedConfig, LaunchArgumentsDefaultToTheNodesDefaults) {
  const bdis_stereo::NodeParams defaults;
  int checked = 0;
  for (const char* launch : {"launch/bdis_stereo.launch", "launch/demo.launch"}) {
    const std::string text = joined(lines(packageFile(launch)));
    const std::regex arg(R"re(<arg\s+name="(\w+)"\s+default="([^"]*)")re");
    for (auto it = std::sregex_iterator(text.begin(), text.end(), arg); it != std::sregex_iterator(); ++it) {
      for (const bdis_stereo::NodeParam& p : bdis_stereo::nodeParamTable()) {
        if ((*it)[1] != p.spec.name) continue;
        const bdis::ParamValue v = p.get(defaults);
        const std::string expected = v.kind == bdis::ParamValue::Kind::String ? v.text
                                     : v.kind == bdis::ParamValue::Kind::Real ? shortest(v.real)
                                                                              : v.str();
        EXPECT_EQ((*it)[2], expected) << launch << ": default of " << p.spec.name;
        ++checked;
      }
    }
  }
  EXPECT_GE(checked, 6);  // target_frame, approximate_sync (twice), queue_size, organized_cloud, ...
}
