// Runs the built bdis_synth executable: a small sequence, same seed same
// bytes across runs, and command-line errors that exit non-zero with a message.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "bdis_stereo/evaluation.hpp"
#include "bdis_stereo/synthetic_scene.hpp"
#include "test_images.hpp"
#include "tool_runner.hpp"

namespace {

namespace fs = std::filesystem;
using bdis_test::contains;

using bdis_test::readFile;
using bdis_test::RunResult;

class BdisSynthTool : public bdis_test::ToolTest {
 protected:
  BdisSynthTool() : ToolTest("bdis_synth") {}
};

const std::vector<std::string> kSmall = {"--width", "160", "--height", "120", "--frames", "2", "--quiet"};

std::vector<std::string> withSmall(std::vector<std::string> args) {
  args.insert(args.end(), kSmall.begin(), kSmall.end());
  return args;
}

TEST_F(BdisSynthTool, WritesTheSequenceAndItsCalibration) {
  const RunResult r = run(withSmall({"--out", path("seq"), "--scene", "tube", "--lighting", "diffuse", "--focal",
                                     "130", "--baseline", "0.004", "--noise", "1.5", "--seed", "7",
                                     "--jpeg-quality", "80", "--right-gain", "1.25"}));
  ASSERT_EQ(r.code(), 0) << r.all();
  EXPECT_TRUE(contains(r.out, "wrote 2 frames 160x120")) << r.out;
  const bdis::StereoSequence seq = bdis::StereoSequence::open(path("seq"));
  EXPECT_EQ(seq.names.size(), 2u);
  EXPECT_TRUE(seq.has_ground_truth);
  EXPECT_EQ(seq.left(0).size(), cv::Size(160, 120));
  const std::string yaml = readFile(path("seq/camera.yaml"));
  for (const char* line : {"image_width: 160\n", "image_height: 120\n", "fx: 130.0\n", "fy: 130.0\n", "cx: 80.0\n",
                           "cy: 60.0\n", "baseline: 0.004\n", "# synth_scene: tube\n", "# synth_lighting: diffuse\n",
                           "# synth_seed: 7\n", "# synth_noise: 1.5\n", "# synth_frames: 2\n",
                           "# synth_jpeg_quality: 80\n", "# synth_right_gain: 1.25\n"}) {
    EXPECT_TRUE(contains(yaml, line)) << line << " missing in\n" << yaml;
  }
  // The same as rendering in-process with the same settings.
  bdis::synth::SceneConfig cfg;
  cfg.scene = bdis::synth::SceneType::Tube;
  cfg.lighting = bdis::synth::Lighting::Diffuse;
  cfg.width = 160;
  cfg.height = 120;
  cfg.focal = 130;
  cfg.baseline = 0.004;
  cfg.noise = 1.5;
  cfg.seed = 7;
  cfg.jpeg_quality = 80;
  cfg.right_gain = 1.25;
  const bdis::synth::SyntheticFrame frame = bdis::synth::SyntheticRenderer(cfg).render(1);
  EXPECT_TRUE(bdis_test::identical(seq.right(1), frame.right));
  ASSERT_TRUE(seq.has_surfaces);
  EXPECT_TRUE(bdis_test::identical(seq.surfaces(1), frame.label));
}

TEST_F(BdisSynthTool, SameSeedSameBytes) {
  ASSERT_EQ(run(withSmall({"--out", path("a")})).code(), 0);
  ASSERT_EQ(run(withSmall({"--out", path("b")})).code(), 0);
  for (const char* f : {"left/000001.png", "right/000001.png", "gt_disparity/000001.png", "labels/000001.png", "camera.yaml"}) {
    const std::string a = readFile(fs::path(path("a")) / f), b = readFile(fs::path(path("b")) / f);
    EXPECT_FALSE(a.empty()) << f;
    EXPECT_EQ(a, b) << f;
  }
}

TEST_F(BdisSynthTool, VariantThenOverrides) {
  const RunResult r = run(withSmall({"--noise", "0", "--out", path("v"), "--variant", "textureless"}));
  ASSERT_EQ(r.code(), 0) << r.all();
  const std::string yaml = readFile(path("v/camera.yaml"));
  EXPECT_TRUE(contains(yaml, "# synth_textureless_patch: true")) << yaml;
  EXPECT_TRUE(contains(yaml, "# synth_lighting: diffuse")) << yaml;
  EXPECT_TRUE(contains(yaml, "# synth_noise: 0.0")) << yaml;  // the override wins over the variant
}

TEST_F(BdisSynthTool, HelpExitsZero) {
  const RunResult r = run({"--help"});
  EXPECT_EQ(r.code(), 0);
  EXPECT_TRUE(contains(r.out, "usage: bdis_synth --out DIR"));
}

TEST_F(BdisSynthTool, ListsEveryVariant) {
  const RunResult r = run({"--list-variants"});
  EXPECT_EQ(r.code(), 0);
  std::string expected;
  for (const std::string& name : bdis::synth::SceneConfig::variantNames()) expected += name + "\n";
  EXPECT_EQ(r.out, expected);
  EXPECT_TRUE(contains(run({"--help"}).out, "--list-variants"));
}

TEST_F(BdisSynthTool, CommandLineErrorsExitNonZeroWithAMessage) {
  struct Case {
    std::vector<std::string> args;
    const char* message;
  };
  const std::string out = path("x");
  const std::vector<Case> cases = {
      {{}, "--out DIR is required"},
      {{"--out"}, "--out needs a value"},
      {{"--out", out, "--width", "abc"}, "--width needs an integer, got 'abc'"},
      {{"--out", out, "--width", "12"}, "width = 12 is out of range"},
      {{"--out", out, "--height", "1e9"}, "--height needs an integer"},
      {{"--out", out, "--frames", "0"}, "frames = 0 is out of range"},
      {{"--out", out, "--baseline", "-0.1"}, "baseline"},
      {{"--out", out, "--noise", "x1"}, "--noise needs a number, got 'x1'"},
      {{"--out", out, "--seed", "-3"}, "--seed must be >= 0"},
      {{"--out", out, "--jpeg-quality", "101"}, "jpeg_quality = 101 is out of range"},
      {{"--out", out, "--scene", "cave"}, "unknown scene 'cave'"},
      {{"--out", out, "--lighting", "neon"}, "unknown lighting 'neon'"},
      {{"--out", out, "--variant", "nope"}, "unknown scene variant 'nope'"},
      {{"--out", out, "--frobnicate"}, "unknown option --frobnicate"},
      {{"--out", out, "stray"}, "unexpected argument 'stray'"},
      {{"--out", out, "--scene", "tube", "--textureless-patch"}, "textureless_patch needs the tissue scene"},
  };
  for (const Case& c : cases) {
    const RunResult r = run(c.args);
    std::string joined;
    for (const std::string& a : c.args) joined += a + " ";
    EXPECT_EQ(r.code(), 2) << joined << "\n" << r.all();
    EXPECT_TRUE(contains(r.err, c.message)) << joined << ": expected '" << c.message << "' in\n" << r.err;
    EXPECT_TRUE(contains(r.err, "bdis_synth --help")) << r.err;
  }
  EXPECT_FALSE(fs::exists(out)) << "nothing is written on a usage error";
}

TEST_F(BdisSynthTool, RuntimeErrorsExitOneWithAMessage) {
  ASSERT_EQ(run(withSmall({"--out", path("s")})).code(), 0);
  const RunResult again = run(withSmall({"--out", path("s")}));
  EXPECT_EQ(again.code(), 1) << again.all();
  EXPECT_TRUE(contains(again.err, "already holds a sequence")) << again.err;
  EXPECT_EQ(run(withSmall({"--out", path("s"), "--overwrite"})).code(), 0);

  std::ofstream(path("file")) << "x";
  const RunResult file = run(withSmall({"--out", path("file")}));
  EXPECT_EQ(file.code(), 1) << file.all();
  EXPECT_TRUE(contains(file.err, "bdis_synth: error:")) << file.err;
}

}  // namespace
