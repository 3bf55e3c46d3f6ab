// Writing a rendered sequence in the layout of the shared data folder.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "bdis_stereo/error_analysis.hpp"
#include "bdis_stereo/evaluation.hpp"
#include "bdis_stereo/synthetic_scene.hpp"

namespace fs = std::filesystem;

namespace bdis {
namespace synth {

static_assert(kLabelInstrument == kInstrumentSurface, "labels/ marks the instrument as bdis_eval reads it");

namespace {

// Decimal text of a double with up to 15 significant digits (so a product
// such as -fx * B prints as -1.35, not -1.3499999999999999) and ".0" on
// integral values ("520.0", "0.005", "-2.6"), as the shared camera.yaml.
std::string number(double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.15g", v);
  std::string s(buf);
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";  // not for inf / nan
  return s;
}

std::string frameName(int i) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%06d.png", i);
  return buf;
}

}  // namespace

std::string cameraYaml(const SceneConfig& c) {
  const StereoCamera cam = c.camera();
  const std::string fx = number(cam.fx), fy = number(cam.fy), cx = number(cam.cx), cy = number(cam.cy);
  std::ostringstream y;
  y << "# Rectified stereo calibration of this sequence (pinhole, no distortion).\n"
    << "# Units of 'baseline' are the scene units of the ground-truth depth.\n"
    << "# Rendered by bdis_synth (bdis_stereo); scene units are metres. Settings:\n"
    << "# synth_scene: " << toString(c.scene) << "\n"
    << "# synth_lighting: " << toString(c.lighting) << "\n"
    << "# synth_frames: " << c.frames << "\n"
    << "# synth_seed: " << c.seed << "\n"
    << "# synth_noise: " << number(c.noise) << "\n"
    << "# synth_instrument: " << (c.instrument ? "true" : "false") << "\n"
    << "# synth_black_borders: " << (c.black_borders ? "true" : "false") << "\n"
    << "# synth_textureless_patch: " << (c.textureless_patch ? "true" : "false") << "\n"
    << "# synth_light_spot: " << number(c.light_spot) << "\n"
    << "# synth_exposure: " << number(c.exposure) << "\n"
    << "# synth_right_gain: " << number(c.right_gain) << "\n"
    << "# synth_motion: " << number(c.motion) << "\n"
    << "# synth_supersampling: " << c.supersampling << "\n"
    << "# synth_jpeg_quality: " << c.jpeg_quality << "\n"
    << "# synth_frame_rate: 30.0\n"
    << "image_width: " << c.width << "\n"
    << "image_height: " << c.height << "\n"
    << "fx: " << fx << "\n"
    << "fy: " << fy << "\n"
    << "cx: " << cx << "\n"
    << "cy: " << cy << "\n"
    << "baseline: " << number(cam.baseline) << "\n"
    << "# ROS CameraInfo projection matrices (P), row-major 3x4; right Tx = -fx * baseline\n"
    << "left_P:  [" << fx << ", 0, " << cx << ", 0, 0, " << fy << ", " << cy << ", 0, 0, 0, 1, 0]\n"
    << "right_P: [" << fx << ", 0, " << cx << ", " << number(-cam.fx * cam.baseline) << ", 0, " << fy << ", "
    << cy << ", 0, 0, 0, 1, 0]\n";
  return y.str();
}

void writeSequence(const SceneConfig& config, const std::string& dir, bool overwrite,
                   const std::function<void(int)>& progress) {
  config.validate();
  if (dir.empty()) throw std::runtime_error("empty output directory");
  const fs::path root(dir);
  std::error_code ec;
  if (fs::exists(root, ec) && !fs::is_directory(root, ec)) {
    throw std::runtime_error("cannot write " + dir + ": not a directory");
  }
  const std::regex frame_re("[0-9]{6}\\.png");
  for (const char* sub : {"left", "right", "gt_disparity", "labels"}) {
    const fs::path p = root / sub;
    if (!fs::is_directory(p, ec)) continue;
    std::vector<fs::path> frames;
    for (const auto& entry : fs::directory_iterator(p, ec)) {
      const std::string name = entry.path().filename().string();
      if (!overwrite) {
        throw std::runtime_error(dir + " already holds a sequence (" + (fs::path(sub) / name).string() +
                                 "); choose an empty folder or overwrite");
      }
      if (std::regex_match(name, frame_re)) frames.push_back(entry.path());
    }
    for (const fs::path& f : frames) fs::remove(f, ec);
  }
  for (const char* sub : {"left", "right", "gt_disparity", "labels"}) {
    fs::create_directories(root / sub, ec);
    if (!fs::is_directory(root / sub)) {
      throw std::runtime_error("cannot create " + (root / sub).string() + (ec ? ": " + ec.message() : ""));
    }
  }
  {
    const std::string yaml_path = (root / "camera.yaml").string();
    std::ofstream yaml(yaml_path, std::ios::binary);
    yaml << cameraYaml(config);
    if (!yaml) throw std::runtime_error("cannot write " + yaml_path);
  }
  const SyntheticRenderer renderer(config);
  SyntheticFrame frame;
  cv::Mat gt_out;
  for (int i = 0; i < config.frames; ++i) {
    renderer.render(i, frame);
    const std::string name = frameName(i);
    writeImage((root / "left" / name).string(), frame.left);
    writeImage((root / "right" / name).string(), frame.right);
    // writeDisparityPng takes negative = none; ground truth uses 0 = unknown.
    frame.gt.copyTo(gt_out);
    gt_out.setTo(-1.f, frame.gt <= 0.f);
    writeDisparityPng((root / "gt_disparity" / name).string(), gt_out);
    writeImage((root / "labels" / name).string(), frame.label);
    if (progress) progress(i + 1);
  }
}

}  // namespace synth
}  // namespace bdis
