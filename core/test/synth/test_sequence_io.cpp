// Determinism (same seed, same bytes), the written folder (readable by
// bdis::StereoSequence, camera.yaml in the shared data's format) and the
// configuration's validation.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "bdis_stereo/error_analysis.hpp"
#include "bdis_stereo/evaluation.hpp"
#include "synth_test_util.hpp"
#include "test_images.hpp"

namespace {

namespace fs = std::filesystem;
using namespace synth_test;
using bdis_test::TempPath;

SceneConfig small(const std::string& name = "sample") {
  SceneConfig c = SceneConfig::variant(name);
  c.width = 192;
  c.height = 144;
  c.frames = 3;
  return c;
}

std::string readFile(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

/// Relative path -> bytes of every file under `root`.
std::map<std::string, std::string> folderBytes(const std::string& root) {
  std::map<std::string, std::string> out;
  for (const auto& e : fs::recursive_directory_iterator(root)) {
    if (e.is_regular_file()) out[fs::relative(e.path(), root).string()] = readFile(e.path());
  }
  return out;
}

/// The `key: value` lines of a YAML file that are not comments, in order.
std::vector<std::pair<std::string, std::string>> yamlKeys(const std::string& text) {
  std::vector<std::pair<std::string, std::string>> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    const size_t colon = line.find(':');
    if (colon == std::string::npos) continue;
    std::string value = line.substr(colon + 1);
    value.erase(0, value.find_first_not_of(' '));
    out.emplace_back(line.substr(0, colon), value);
  }
  return out;
}

TEST(Determinism, SameSeedSameBytesOnDisk) {
  const SceneConfig cfg = small();
  TempPath a, b, c;
  bdis::synth::writeSequence(cfg, a.str());
  bdis::synth::writeSequence(cfg, b.str());
  SceneConfig other = cfg;
  other.seed = 2;
  bdis::synth::writeSequence(other, c.str());
  const auto fa = folderBytes(a.str()), fb = folderBytes(b.str()), fc = folderBytes(c.str());
  EXPECT_EQ(fa.size(), 4u * 3u + 1u);  // left, right, gt_disparity, labels x 3 frames + camera.yaml
  EXPECT_TRUE(fa == fb) << "two runs with the same settings wrote different bytes";
  int differing = 0;
  for (const auto& [name, bytes] : fa) {
    if (name.find("left/") == 0 && fc.at(name) != bytes) ++differing;
  }
  EXPECT_EQ(differing, 3) << "another seed must give other images";
}

TEST(Determinism, AFrameDoesNotDependOnWhatWasRenderedBefore) {
  const SceneConfig cfg = small("tube");
  const SyntheticRenderer r1(cfg), r2(cfg);
  r1.render(0);
  const SyntheticFrame direct = r2.render(4), after = r1.render(4);
  EXPECT_TRUE(bdis_test::identical(direct.left, after.left));
  EXPECT_TRUE(bdis_test::identical(direct.right, after.right));
  EXPECT_TRUE(bdis_test::identical(direct.gt, after.gt));
  // Consecutive frames differ (the scene moves) ...
  EXPECT_FALSE(bdis_test::identical(r1.render(5).gt, after.gt));
  // ... unless the motion is off; the noise still changes.
  SceneConfig still = cfg;
  still.motion = 0;
  const SyntheticRenderer r3(still);
  const SyntheticFrame s0 = r3.render(0), s1 = r3.render(1);
  EXPECT_TRUE(bdis_test::identical(s0.gt, s1.gt));
  EXPECT_FALSE(bdis_test::identical(s0.left, s1.left));
}

TEST(SequenceIo, StereoSequenceReadsTheWrittenFolder) {
  SceneConfig cfg = small();
  cfg.focal = 150.0;
  cfg.baseline = 0.004;
  TempPath dir;
  int calls = 0;
  bdis::synth::writeSequence(cfg, dir.str(), false, [&](int done) { EXPECT_EQ(done, ++calls); });
  EXPECT_EQ(calls, cfg.frames);
  const bdis::StereoSequence seq = bdis::StereoSequence::open(dir.str());
  ASSERT_EQ(seq.names, (std::vector<std::string>{"000000.png", "000001.png", "000002.png"}));
  ASSERT_TRUE(seq.has_ground_truth);
  const SyntheticRenderer renderer(cfg);
  for (size_t i = 0; i < seq.names.size(); ++i) {
    const SyntheticFrame f = renderer.render(static_cast<int>(i));
    EXPECT_TRUE(bdis_test::identical(seq.left(i), f.left)) << i;
    EXPECT_TRUE(bdis_test::identical(seq.right(i), f.right)) << i;
    const cv::Mat gt = seq.groundTruth(i);
    ASSERT_EQ(gt.type(), CV_32FC1);
    EXPECT_LE(cv::norm(gt, f.gt, cv::NORM_INF), 0.5 / 256 + 1e-6) << i;  // 16-bit d * 256
    EXPECT_EQ(cv::countNonZero(gt > 0), cv::countNonZero(f.gt > 0)) << i;
    // The surface each left pixel sees; the sample has the instrument in view.
    ASSERT_TRUE(seq.has_surfaces);
    const cv::Mat surfaces = seq.surfaces(i);
    EXPECT_TRUE(bdis_test::identical(surfaces, f.label)) << i;
    EXPECT_GT(cv::countNonZero(surfaces == bdis::kInstrumentSurface), 0) << i;
  }
}

TEST(SequenceIo, CameraYamlHasTheSharedDataKeysAndTheRequestedValues) {
  SceneConfig cfg = small();
  cfg.width = 320;
  cfg.height = 240;
  cfg.focal = 300.0;
  cfg.baseline = 0.0045;
  const auto keys = yamlKeys(bdis::synth::cameraYaml(cfg));
  const std::vector<std::string> expected = {"image_width", "image_height", "fx", "fy", "cx",
                                             "cy", "baseline", "left_P", "right_P"};
  std::vector<std::string> names;
  for (const auto& kv : keys) names.push_back(kv.first);
  EXPECT_EQ(names, expected);
  std::map<std::string, std::string> v(keys.begin(), keys.end());
  EXPECT_EQ(v["image_width"], "320");
  EXPECT_EQ(v["image_height"], "240");
  EXPECT_EQ(v["fx"], "300.0");
  EXPECT_EQ(v["fy"], "300.0");
  EXPECT_EQ(v["cx"], "160.0");
  EXPECT_EQ(v["cy"], "120.0");
  EXPECT_EQ(v["baseline"], "0.0045");
  EXPECT_EQ(v["left_P"], "[300.0, 0, 160.0, 0, 0, 300.0, 120.0, 0, 0, 0, 1, 0]");
  EXPECT_EQ(v["right_P"], "[300.0, 0, 160.0, -1.35, 0, 300.0, 120.0, 0, 0, 0, 1, 0]");  // Tx = -fx B

  // The shared data's camera.yaml, when present, has exactly these keys in
  // this order, and the default config reproduces its values but the baseline
  // (scene units there, metres here).
  const std::string data = bdis::findDataDir();
  if (data.empty()) return;
  const std::string shared = readFile(fs::path(data) / "synthetic_colon_diffuse" / "camera.yaml");
  const auto shared_keys = yamlKeys(shared);
  std::vector<std::string> shared_names;
  for (const auto& kv : shared_keys) shared_names.push_back(kv.first);
  EXPECT_EQ(shared_names, expected);
  std::map<std::string, std::string> s(shared_keys.begin(), shared_keys.end()),
      d = [] {
        const auto k = yamlKeys(bdis::synth::cameraYaml(SceneConfig{}));
        return std::map<std::string, std::string>(k.begin(), k.end());
      }();
  for (const char* key : {"image_width", "image_height", "fx", "fy", "cx", "cy"}) EXPECT_EQ(d[key], s[key]) << key;
}

TEST(SequenceIo, RefusesAFolderWithFramesUnlessOverwriting) {
  SceneConfig cfg = small();
  cfg.frames = 2;
  TempPath dir;
  bdis::synth::writeSequence(cfg, dir.str());
  const std::string message = [&] {
    try {
      bdis::synth::writeSequence(cfg, dir.str());
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("<no exception>");
  }();
  EXPECT_TRUE(bdis_test::contains(message, "already holds a sequence")) << message;
  // Overwrite with fewer frames: no stale frame survives.
  cfg.frames = 1;
  bdis::synth::writeSequence(cfg, dir.str(), true);
  EXPECT_EQ(bdis::StereoSequence::open(dir.str()).names.size(), 1u);
  EXPECT_FALSE(fs::exists(fs::path(dir.str()) / "gt_disparity" / "000001.png"));
  // A file where the folder should be.
  TempPath file(".txt");
  file.write("x");
  EXPECT_THROW(bdis::synth::writeSequence(cfg, file.str()), std::runtime_error);
}

TEST(SceneConfigTest, ValidatesEveryField) {
  using bdis_test::contains;
  using bdis_test::invalidArgumentMessage;
  auto with = [](auto change) {
    SceneConfig c;
    change(c);
    return invalidArgumentMessage([&] { c.validate(); });
  };
  EXPECT_EQ(with([](SceneConfig&) {}), "<no exception>");
  EXPECT_TRUE(contains(with([](SceneConfig& c) { c.width = 10; }), "width"));
  EXPECT_TRUE(contains(with([](SceneConfig& c) { c.height = 5000; }), "height"));
  EXPECT_TRUE(contains(with([](SceneConfig& c) { c.focal = -1; }), "focal"));
  EXPECT_TRUE(contains(with([](SceneConfig& c) { c.baseline = 0; }), "baseline"));
  EXPECT_TRUE(contains(with([](SceneConfig& c) { c.baseline = std::nan(""); }), "baseline"));
  EXPECT_TRUE(contains(with([](SceneConfig& c) { c.frames = 0; }), "frames"));
  EXPECT_TRUE(contains(with([](SceneConfig& c) { c.noise = -0.5; }), "noise"));
  EXPECT_TRUE(contains(with([](SceneConfig& c) { c.exposure = 0; }), "exposure"));
  EXPECT_TRUE(contains(with([](SceneConfig& c) { c.right_gain = 0.4; }), "right_gain"));
  EXPECT_TRUE(contains(with([](SceneConfig& c) { c.right_gain = std::nan(""); }), "right_gain"));
  EXPECT_TRUE(contains(with([](SceneConfig& c) { c.light_spot = -1; }), "light_spot"));
  EXPECT_TRUE(contains(with([](SceneConfig& c) { c.motion = -1; }), "motion"));
  EXPECT_TRUE(contains(with([](SceneConfig& c) { c.supersampling = 0; }), "supersampling"));
  EXPECT_TRUE(contains(with([](SceneConfig& c) { c.jpeg_quality = -1; }), "jpeg_quality"));
  EXPECT_TRUE(contains(with([](SceneConfig& c) { c.jpeg_quality = 101; }), "jpeg_quality"));
  EXPECT_TRUE(contains(with([](SceneConfig& c) {
                         c.scene = bdis::synth::SceneType::Tube;
                         c.textureless_patch = true;
                       }),
                       "textureless_patch"));
  EXPECT_TRUE(contains(invalidArgumentMessage([] { SyntheticRenderer r(SceneConfig{}.variant("nope")); }), "nope"));
  EXPECT_TRUE(contains(invalidArgumentMessage([] { bdis::synth::parseSceneType("cave"); }), "cave"));
  EXPECT_TRUE(contains(invalidArgumentMessage([] { bdis::synth::parseLighting("neon"); }), "neon"));
  for (const std::string& n : SceneConfig::variantNames()) {
    EXPECT_EQ(invalidArgumentMessage([&] { SceneConfig::variant(n).validate(); }), "<no exception>") << n;
  }
  EXPECT_TRUE(contains(invalidArgumentMessage([] { SyntheticRenderer(SceneConfig{}).render(-1); }), "index"));
}

TEST(SceneConfigTest, SampleDefaultsAreTheDocumentedOnes) {
  const SceneConfig c;
  EXPECT_EQ(c.scene, bdis::synth::SceneType::Tissue);
  EXPECT_EQ(c.lighting, bdis::synth::Lighting::Specular);
  EXPECT_EQ(c.width, 640);
  EXPECT_EQ(c.height, 480);
  EXPECT_EQ(c.frames, 30);
  EXPECT_TRUE(c.instrument);
  EXPECT_EQ(c.jpeg_quality, 0);
  EXPECT_DOUBLE_EQ(c.focalPx(), 520.0);
  EXPECT_DOUBLE_EQ(c.baseline, 0.005);
  const bdis::StereoCamera cam = c.camera();
  EXPECT_DOUBLE_EQ(cam.cx, 320.0);
  EXPECT_DOUBLE_EQ(cam.cy, 240.0);
  EXPECT_DOUBLE_EQ(cam.cx_right, 320.0);
}

}  // namespace
