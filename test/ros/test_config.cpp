// The shipped parameter file must stay in step with the code's default preset.
#include <gtest/gtest.h>

#include <ros/package.h>

#include "bdis_stereo/params.hpp"

TEST(ShippedConfig, DefaultYamlEqualsBalancedPresetFieldByField) {
  const std::string package = ros::package::getPath("bdis_stereo");
  ASSERT_FALSE(package.empty()) << "the bdis_stereo package is not on ROS_PACKAGE_PATH";
  const bdis::MatcherParams balanced = bdis::MatcherParams::preset("balanced");
  // Load on top of a deliberately different base so every field must come from the file.
  bdis::MatcherParams other = bdis::MatcherParams::preset("fast");
  other.iterations = 3;
  const bdis::MatcherParams loaded = bdis::loadParams(package + "/config/default.yaml", other);
  for (const bdis::ParamField& f : bdis::paramFields()) {
    EXPECT_EQ(f.get(loaded), f.get(balanced)) << "config/default.yaml differs in " << f.name;
  }
}
