// Synthetic surgical stereo with exact per-pixel ground truth: a deterministic
// (seeded) ray-casting renderer of endoscopic scenes for the tests, the
// benchmarks and the demo's embedded sample. ROS-free; OpenCV core and, for
// the optional JPEG round trip, imgcodecs.
//
// Geometry: a curved, gently breathing tissue surface seen from a few cm, or a
// colon-like tube with the camera moving along it; optionally a surgical
// instrument (a capsule) in front. Appearance: procedural tissue texture with
// vessels and smooth, nearly textureless regions, defined on the surface (the
// same point has the same albedo in both views); a point light at the scope
// tip with inverse-square falloff; an optional Blinn-Phong specular term that
// puts the highlights at different surface points in the two views; Gaussian
// sensor noise; optional black borders as rectification leaves them; optionally
// each view stored as a JPEG, as recorded and streamed endoscope video often is.
//
// Cameras: rectified, parallel pinhole pair, left at the origin of its optical
// frame (x right, y down, z forward), right at +baseline along x, same K.
// Scene unit: metres.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "bdis_stereo/geometry.hpp"

namespace bdis {
namespace synth {

enum class SceneType { Tissue, Tube };
enum class Lighting { Diffuse, Specular };

/// Everything that determines a rendered sequence. Same config, same bytes.
struct SceneConfig {
  SceneType scene = SceneType::Tissue;
  Lighting lighting = Lighting::Specular;
  int width = 640;             ///< px, 64..4096
  int height = 480;            ///< px, 48..4096
  double focal = 0.0;          ///< fx = fy in px; 0 = 0.8125 * width (520 px at 640, as the shared data)
  double baseline = 0.005;     ///< m (5 mm, a stereo laparoscope)
  int frames = 30;             ///< frames written by writeSequence (render() accepts any index >= 0)
  double noise = 2.0;          ///< sensor noise std, grey levels (0 = noise-free)
  uint64_t seed = 1;           ///< scene layout, texture and noise
  bool instrument = true;      ///< a surgical instrument in front of the tissue
  bool black_borders = true;   ///< black (0) wedges as rectification leaves them
  bool textureless_patch = false;  ///< a large albedo-flat disk on the tissue (tissue scene only)
  double light_spot = 2.0;     ///< beam falloff exponent k of the scope light, cos^k (0 = isotropic)
  double exposure = 1.0;       ///< multiplies the light power (< 1: darker, noisier periphery)
  double right_gain = 1.0;     ///< the right view's grey levels times this: the cameras' gain differs (0.5..2)
  double motion = 1.0;         ///< scales camera, breathing and instrument motion per frame (0 = static)
  int supersampling = 3;       ///< n: n x n samples on edges and highlight borders (1 = off)
  int jpeg_quality = 0;        ///< each view encoded and decoded as JPEG at this quality, 1..100 (0 = not)

  /// fx = fy in px (resolves focal = 0).
  double focalPx() const;
  /// The rectified pair: cx = width / 2, cy = height / 2, same for both cameras.
  StereoCamera camera() const;
  /// Throws std::invalid_argument naming the first bad field and its range.
  void validate() const;

  /// Named configurations used by the tests, the benchmarks and the demo:
  /// "sample" (the defaults: the demo's embedded sample), "diffuse", "specular",
  /// "dark_periphery", "textureless", "instrument", "tube", "dark_tube",
  /// "compressed_dark" (dark_periphery as JPEG at quality 75). Throws
  /// std::invalid_argument for an unknown name.
  static SceneConfig variant(const std::string& name);
  static std::vector<std::string> variantNames();
};

const char* toString(SceneType scene);
const char* toString(Lighting lighting);
/// Parse "tissue" / "tube" and "diffuse" / "specular"; throw std::invalid_argument.
SceneType parseSceneType(const std::string& text);
Lighting parseLighting(const std::string& text);

/// Labels of SyntheticFrame::label.
enum Label : uint8_t { kLabelNone = 0, kLabelTissue = 1, kLabelInstrument = 2 };

/// One rendered stereo frame and what is known about it.
struct SyntheticFrame {
  /// CV_8UC3 BGR; black (0) outside the rectified view, >= 1 inside (also after
  /// JPEG: the codec's ringing into the border is cleared)
  cv::Mat left;
  cv::Mat right;         ///< CV_8UC3 BGR
  /// CV_32FC1 left disparity fx * B / Z at each pixel centre, px; 0 = unknown:
  /// black border (either view), match outside the right image, occluded in the
  /// right view, or a pixel footprint straddling a depth discontinuity.
  cv::Mat gt;
  cv::Mat depth;         ///< CV_32FC1 Z (m) of the left pixel centre's surface point, NaN if none
  cv::Mat label;         ///< CV_8UC1 Label of the left pixel centre (kLabelNone in the border)
  cv::Mat specular_left;   ///< CV_32FC1 specular share of the radiance in [0, 1], left view
  cv::Mat specular_right;  ///< CV_32FC1 the same for the right view
  cv::Mat textureless;   ///< CV_8UC1 255 where the left pixel sees the textureless patch
};

/// A ray's first surface hit, in the left camera's optical frame.
struct RayHit {
  bool hit = false;
  double t = 0.0;        ///< point = origin + t * direction
  cv::Vec3d point;
  int label = kLabelNone;
};

/// Renders frames of one configuration. Construction builds the scene (a few
/// ms); render() is const, single-threaded and deterministic.
class SyntheticRenderer {
 public:
  /// Throws std::invalid_argument when the config is invalid.
  explicit SyntheticRenderer(const SceneConfig& config);
  ~SyntheticRenderer();
  SyntheticRenderer(SyntheticRenderer&&) noexcept;
  SyntheticRenderer& operator=(SyntheticRenderer&&) noexcept;

  const SceneConfig& config() const;
  StereoCamera camera() const { return config().camera(); }

  /// Renders frame `index` (>= 0; time = index / 30 s) into `out`,
  /// reallocating its images only when the size changes.
  void render(int index, SyntheticFrame& out) const;
  SyntheticFrame render(int index) const;

  /// First hit of the ray origin + t * direction (t > 0) at frame `index`, both
  /// in the left camera's optical frame; the same ray caster the images and
  /// the ground truth come from (for tests).
  RayHit castRay(int index, const cv::Vec3d& origin, const cv::Vec3d& direction) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// camera.yaml in the layout of the shared data (image_width, image_height,
/// fx, fy, cx, cy, baseline, left_P, right_P), the generator settings as
/// comments.
std::string cameraYaml(const SceneConfig& config);

/// Writes config.frames frames to `dir` in the shared data layout: left/,
/// right/ (8-bit BGR PNG), gt_disparity/ (16-bit PNG, round(d * 256), 0 =
/// unknown), camera.yaml. Creates `dir` if needed. A folder that already holds
/// frames is refused (std::runtime_error) unless `overwrite`, which first
/// removes the NNNNNN.png files of those three subfolders. `progress` is
/// called after each frame with the number done.
void writeSequence(const SceneConfig& config, const std::string& dir, bool overwrite = false,
                   const std::function<void(int)>& progress = {});

}  // namespace synth
}  // namespace bdis
