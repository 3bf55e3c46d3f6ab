// SyntheticRenderer: per camera, one ray per pixel centre (cone-marched in
// tiles to a proven-free start, then sphere-traced and bracketed to
// 1e-12 m), shading with band-limited procedural textures, n x n
// supersampling where the centre samples show a geometric edge or a
// highlight border, then tone mapping, noise, black borders and optionally a
// JPEG round trip. The left
// centre rays are the ground-truth rays; occlusion in the right view is
// checked by casting the right camera's ray through each left surface point.
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>

#include "bdis_stereo/synthetic_scene.hpp"
#include "scene.hpp"

namespace bdis {
namespace synth {

using detail::Vec3;

// ---------------------------------------------------------------------------
double SceneConfig::focalPx() const { return focal > 0 ? focal : 0.8125 * width; }

StereoCamera SceneConfig::camera() const {
  const double f = focalPx();
  return StereoCamera::symmetric(f, f, 0.5 * width, 0.5 * height, baseline);
}

void SceneConfig::validate() const {
  auto bad = [](const std::string& what) { throw std::invalid_argument("scene config: " + what); };
  auto str = [](double v) {
    std::string s = std::to_string(v);
    return s;
  };
  if (width < 64 || width > 4096) bad("width = " + std::to_string(width) + " is out of range [64, 4096]");
  if (height < 48 || height > 4096) bad("height = " + std::to_string(height) + " is out of range [48, 4096]");
  if (!(focal == 0.0 || (focal >= 0.25 * width && focal <= 4.0 * width))) {
    bad("focal = " + str(focal) + " px is out of range: 0 (auto) or [0.25, 4] * width");
  }
  if (!(baseline > 0.0 && baseline <= 0.05)) bad("baseline = " + str(baseline) + " m is out of range (0, 0.05]");
  if (frames < 1 || frames > 1000000) bad("frames = " + std::to_string(frames) + " is out of range [1, 1000000]");
  if (!(noise >= 0.0 && noise <= 50.0)) bad("noise = " + str(noise) + " is out of range [0, 50] grey levels");
  if (!(light_spot >= 0.0 && light_spot <= 200.0)) bad("light_spot = " + str(light_spot) + " is out of range [0, 200]");
  if (!(exposure > 0.0 && exposure <= 100.0)) bad("exposure = " + str(exposure) + " is out of range (0, 100]");
  if (!(right_gain >= 0.5 && right_gain <= 2.0)) bad("right_gain = " + str(right_gain) + " is out of range [0.5, 2]");
  if (!(motion >= 0.0 && motion <= 100.0)) bad("motion = " + str(motion) + " is out of range [0, 100]");
  if (supersampling < 1 || supersampling > 8) {
    bad("supersampling = " + std::to_string(supersampling) + " is out of range [1, 8]");
  }
  if (textureless_patch && scene != SceneType::Tissue) bad("textureless_patch needs the tissue scene");
  if (jpeg_quality < 0 || jpeg_quality > 100) {
    bad("jpeg_quality = " + std::to_string(jpeg_quality) + " is out of range: 0 (none) or [1, 100]");
  }
}

namespace {

// A narrow beam and a low exposure: the periphery sinks to a few grey levels.
void useDarkBeam(SceneConfig& c) {
  c.light_spot = 30.0;
  c.exposure = 0.5;
}

}  // namespace

SceneConfig SceneConfig::variant(const std::string& name) {
  SceneConfig c;
  if (name == "sample") return c;
  // The test variants: no instrument or borders unless named, one
  // difficulty each.
  c.instrument = false;
  c.black_borders = false;
  if (name == "diffuse") {
    c.lighting = Lighting::Diffuse;
  } else if (name == "specular") {
    c.lighting = Lighting::Specular;
  } else if (name == "dark_periphery") {
    c.lighting = Lighting::Diffuse;
    useDarkBeam(c);
  } else if (name == "textureless") {
    c.lighting = Lighting::Diffuse;
    c.textureless_patch = true;
  } else if (name == "instrument") {
    c.lighting = Lighting::Specular;
    c.instrument = true;
  } else if (name == "tube") {
    c.scene = SceneType::Tube;
    c.lighting = Lighting::Specular;
    c.instrument = true;
  } else if (name == "dark_tube") {
    // The near wall, seen at a grazing angle, sinks into the dark, as in the
    // colon sequences' periphery.
    c = variant("tube");
    useDarkBeam(c);
  } else if (name == "compressed_dark") {
    // Quality 75, a common encoder default: in the dark most of the texture
    // falls below the codec's quantisation steps and the 8 x 8 block grid
    // remains, at the same image position in both views.
    c = variant("dark_periphery");
    c.jpeg_quality = 75;
  } else {
    std::string names;
    for (const std::string& n : variantNames()) names += (names.empty() ? "" : ", ") + n;
    throw std::invalid_argument("unknown scene variant '" + name + "' (" + names + ")");
  }
  return c;
}

std::vector<std::string> SceneConfig::variantNames() {
  return {"sample",     "diffuse", "specular",  "dark_periphery", "textureless",
          "instrument", "tube",    "dark_tube", "compressed_dark"};
}

const char* toString(SceneType s) { return s == SceneType::Tissue ? "tissue" : "tube"; }
const char* toString(Lighting l) { return l == Lighting::Diffuse ? "diffuse" : "specular"; }

SceneType parseSceneType(const std::string& t) {
  if (t == "tissue") return SceneType::Tissue;
  if (t == "tube") return SceneType::Tube;
  throw std::invalid_argument("unknown scene '" + t + "' (tissue, tube)");
}

Lighting parseLighting(const std::string& t) {
  if (t == "diffuse") return Lighting::Diffuse;
  if (t == "specular") return Lighting::Specular;
  throw std::invalid_argument("unknown lighting '" + t + "' (diffuse, specular)");
}

// ---------------------------------------------------------------------------
namespace {

constexpr double kAmbient = 0.012;       // linear radiance floor (scattered light)
constexpr double kGamma = 1.0 / 2.2;
constexpr int kGammaLut = 4096;
// Largest disparity a 16-bit d * 256 PNG can hold.
constexpr double kMaxGtDisparity = 65535.0 / 256.0 - 0.01;
// A footprint whose samples differ by more than this (px) straddles a depth
// discontinuity: its ground truth is ambiguous.
constexpr double kAmbiguousJump = 1.0;

struct CameraPass {
  int width = 0, height = 0;
  std::vector<double> t;          // centre-ray depth Z, < 0 = no hit
  std::vector<uint8_t> label;
  std::vector<float> rgb;         // linear radiance, box-filtered
  std::vector<float> spec;        // specular radiance (luminance)
  std::vector<uint8_t> ambiguous; // footprint straddles surfaces (left only)
  std::vector<uint8_t> edge;      // geometric edge next to this centre sample
  std::vector<double> tile_free;
  int ntx = 0, nty = 0, tile = 8;
  double tileFree(int x, int y) const {
    const int tx = std::clamp(x / tile, 0, ntx - 1), ty = std::clamp(y / tile, 0, nty - 1);
    return tile_free[static_cast<size_t>(ty) * ntx + tx];
  }
};

}  // namespace

struct SyntheticRenderer::Impl {
  detail::Scene scene;
  SceneConfig cfg;
  StereoCamera cam;

  std::vector<float> gamma_lut;  // sRGB-like encoding of sqrt(linear), see encode()
  int tile = 8;

  explicit Impl(const SceneConfig& c) : scene(c), cfg(c), cam(c.camera()) {
    // 255 * lin^(1/2.2) tabulated over x = sqrt(lin): x^(2/2.2) is nearly
    // linear, so linear interpolation is within 0.02 grey levels.
    gamma_lut.resize(kGammaLut + 2);
    for (int k = 0; k <= kGammaLut + 1; ++k) {
      const double x = std::min(1.0, static_cast<double>(k) / kGammaLut);
      gamma_lut[static_cast<size_t>(k)] = static_cast<float>(255.0 * std::pow(x, 2.0 * kGamma));
    }
    // The tissue's Newton root finder only needs a bracket start: coarse
    // cones suffice; the tube's sphere tracing profits from tight ones.
    tile = c.scene == SceneType::Tissue ? 8 : 4;
  }

  /// 255 * clamp(lin)^(1/2.2).
  double encode(double lin) const {
    const double x = std::sqrt(detail::clamp01(lin)) * kGammaLut;
    const int k = static_cast<int>(x);
    return gamma_lut[static_cast<size_t>(k)] + (x - k) * (gamma_lut[static_cast<size_t>(k) + 1] - gamma_lut[static_cast<size_t>(k)]);
  }

  /// Beam profile of the scope light, cos^k of the angle off the optical axis.
  double beamFactor(double c) const {
    if (cfg.light_spot <= 0) return 1.0;
    const double k = cfg.light_spot;
    return k == std::floor(k) && k <= 64 ? detail::powi(c, static_cast<int>(k)) : std::pow(c, k);
  }

  /// True when pixel (x, y) of camera `which` (0 left, 1 right) lies inside
  /// the rectified view: black wedges as a rectifying homography leaves them.
  bool insideView(int which, double x, double y) const {
    if (!cfg.black_borders) return true;
    const double W = cfg.width, H = cfg.height;
    if (which == 0) {
      return x >= W * (0.020 + 0.035 * y / H) && y <= H - 1 - H * (0.012 + 0.018 * x / W);
    }
    return x <= W - 1 - W * (0.020 + 0.035 * (1.0 - y / H)) && y >= H * (0.010 + 0.018 * (1.0 - x / W));
  }

  Vec3 rayDir(const detail::FrameState& fs, double x, double y) const {
    return fs.rig.rotate(Vec3((x - cam.cx) / cam.fx, (y - cam.cy) / cam.fy, 1.0));
  }

  /// Linear RGB radiance and the specular part (luminance) of a hit seen from `eye`.
  void shade(const Vec3& p, int label, const Vec3& eye, const detail::FrameState& fs, double depth, float rgb[3],
             float& spec) const {
    const Vec3 light = fs.rig.apply(Vec3(0.5 * cam.baseline, 0, 0));
    Vec3 n;
    const detail::Material m = scene.material(p, label, fs, depth / cam.fx, light, n);
    const Vec3 axis = fs.rig.rotate(Vec3(0, 0, 1));
    const Vec3 to_light = light - p;
    const double r2 = dot(to_light, to_light);
    const Vec3 l = to_light * (1.0 / std::sqrt(r2));
    const double beam = std::max(0.0, -dot(l, axis));
    double E = scene.lightPower() * cfg.exposure * beamFactor(beam) / r2;
    if (E > 0 && label == kLabelTissue && scene.shadowed(p, light, fs)) E = 0;
    const double ndl = std::max(0.0, dot(n, l));
    const double diffuse = E * ndl + kAmbient * cfg.exposure;
    double s = 0;
    if (E > 0 && ndl > 0 && (m.ks_sharp > 0 || m.ks_broad > 0)) {
      const Vec3 v = detail::normalized(eye - p);
      const double ndh = std::max(0.0, dot(n, detail::normalized(l + v)));
      s = E * (m.ks_sharp * detail::powi(ndh, m.m_sharp) + m.ks_broad * detail::powi(ndh, m.m_broad));
    }
    rgb[0] = static_cast<float>(m.albedo.x * diffuse + s);
    rgb[1] = static_cast<float>(m.albedo.y * diffuse + s);
    rgb[2] = static_cast<float>(m.albedo.z * diffuse + s);
    spec = static_cast<float>(s);
  }

  void renderCamera(int which, const detail::FrameState& fs, CameraPass& P) const {
    const int W = cfg.width, H = cfg.height;
    const size_t N = static_cast<size_t>(W) * H;
    P.width = W;
    P.height = H;
    P.t.assign(N, -1.0);
    P.label.assign(N, kLabelNone);
    P.rgb.assign(3 * N, 0.f);
    P.spec.assign(N, 0.f);
    P.ambiguous.assign(N, 0);
    const Vec3 eye = fs.rig.apply(Vec3(which == 0 ? 0.0 : cam.baseline, 0, 0));
    const double tmax = scene.maxDepth();

    // Tiles: a cone per tile (expanded by a pixel) marched to a depth
    // no ray of the tile can meet the surface before.
    const int kTile = tile;
    P.tile = tile;
    P.ntx = (W + kTile - 1) / kTile;
    P.nty = (H + kTile - 1) / kTile;
    P.tile_free.assign(static_cast<size_t>(P.ntx) * P.nty, 0.0);
    for (int ty = 0; ty < P.nty; ++ty) {
      for (int tx = 0; tx < P.ntx; ++tx) {
        const double x0 = tx * kTile - 1.5, x1 = std::min(W, (tx + 1) * kTile) + 0.5;
        const double y0 = ty * kTile - 1.5, y1 = std::min(H, (ty + 1) * kTile) + 0.5;
        const Vec3 dc = rayDir(fs, 0.5 * (x0 + x1), 0.5 * (y0 + y1));
        const double r = std::hypot(0.5 * (x1 - x0) / cam.fx, 0.5 * (y1 - y0) / cam.fy);
        P.tile_free[static_cast<size_t>(ty) * P.ntx + tx] = scene.coneFreeT(eye, dc, r, fs, tmax);
      }
    }

    // Centre samples.
    for (int y = 0; y < H; ++y) {
      for (int x = 0; x < W; ++x) {
        const size_t i = static_cast<size_t>(y) * W + x;
        const Vec3 d = rayDir(fs, x, y);
        const double hint = x > 0 ? P.t[i - 1] : (y > 0 ? P.t[i - W] : -1.0);
        const detail::Scene::Hit h = scene.intersect(eye, d, fs, P.tileFree(x, y), tmax, hint);
        if (h.t <= 0) continue;
        P.t[i] = h.t;
        P.label[i] = static_cast<uint8_t>(h.label);
        shade(eye + d * h.t, h.label, eye, fs, h.t, &P.rgb[3 * i], P.spec[i]);
      }
    }

    // Edges (label change, depth discontinuity) and highlight borders get
    // n x n samples, box-filtered; for the left view the same samples tell
    // whether the footprint straddles two surfaces.
    const int n = cfg.supersampling;
    const double fb = cam.fx * cam.baseline;
    auto disp = [&](size_t i) { return P.t[i] > 0 ? fb / P.t[i] : 0.0; };
    std::vector<uint8_t> edge(N, 0);
    std::vector<uint8_t>& geometric = P.edge;
    geometric.assign(N, 0);
    for (int y = 0; y < H; ++y) {
      for (int x = 0; x < W; ++x) {
        const size_t i = static_cast<size_t>(y) * W + x;
        bool geo = false, hl = false;
        const int nb[4][2] = {{-1, 0}, {1, 0}, {0, -1}, {0, 1}};
        for (const auto& o : nb) {
          const int xx = x + o[0], yy = y + o[1];
          if (xx < 0 || yy < 0 || xx >= W || yy >= H) continue;
          const size_t j = static_cast<size_t>(yy) * W + xx;
          if (P.label[j] != P.label[i]) geo = true;
          if (std::fabs(P.spec[j] - P.spec[i]) > 0.08f) hl = true;
        }
        if (!geo && P.t[i] > 0) {
          // Second differences of disparity: a jump shows on both sides.
          if (x > 0 && x + 1 < W && P.t[i - 1] > 0 && P.t[i + 1] > 0 &&
              std::fabs(disp(i - 1) - 2 * disp(i) + disp(i + 1)) > 0.5) {
            geo = true;
          }
          if (y > 0 && y + 1 < H && P.t[i - W] > 0 && P.t[i + W] > 0 &&
              std::fabs(disp(i - W) - 2 * disp(i) + disp(i + W)) > 0.5) {
            geo = true;
          }
        }
        geometric[i] = geo;
        edge[i] = geo || hl;
      }
    }
    if (n <= 1) {
      if (which == 0) P.ambiguous = geometric;
      return;
    }
    for (int y = 0; y < H; ++y) {
      for (int x = 0; x < W; ++x) {
        const size_t i = static_cast<size_t>(y) * W + x;
        if (!edge[i]) continue;
        const double t_free = std::min({P.tileFree(x, y), P.tileFree(x - 1, y - 1), P.tileFree(x + 1, y + 1),
                                        P.tileFree(x - 1, y + 1), P.tileFree(x + 1, y - 1)});
        double acc[3] = {0, 0, 0}, acc_s = 0;
        bool straddles = false;
        const double d0 = disp(i);
        // Highlight borders alone get min(n, 2)^2 samples: no geometry to resolve.
        const int m = geometric[i] ? n : std::min(n, 2);
        for (int sy = 0; sy < m; ++sy) {
          for (int sx = 0; sx < m; ++sx) {
            const double ox = (sx + 0.5) / m - 0.5, oy = (sy + 0.5) / m - 0.5;
            float rgb[3] = {0, 0, 0}, s = 0;
            int label = kLabelNone;
            double t = -1;
            if (ox == 0.0 && oy == 0.0) {
              for (int c = 0; c < 3; ++c) rgb[c] = P.rgb[3 * i + c];
              s = P.spec[i];
              label = P.label[i];
              t = P.t[i];
            } else {
              const Vec3 d = rayDir(fs, x + ox, y + oy);
              const detail::Scene::Hit h = scene.intersect(eye, d, fs, t_free, tmax, P.t[i]);
              if (h.t > 0) {
                shade(eye + d * h.t, h.label, eye, fs, h.t, rgb, s);
                label = h.label;
                t = h.t;
              }
            }
            for (int c = 0; c < 3; ++c) acc[c] += rgb[c];
            acc_s += s;
            if (label != P.label[i] || (t > 0 && d0 > 0 && std::fabs(fb / t - d0) > kAmbiguousJump)) {
              straddles = true;
            }
          }
        }
        const double k = 1.0 / (m * m);
        for (int c = 0; c < 3; ++c) P.rgb[3 * i + c] = static_cast<float>(acc[c] * k);
        P.spec[i] = static_cast<float>(acc_s * k);
        // Only geometric edges can make the ground truth ambiguous (so it
        // does not depend on the lighting).
        if (which == 0) P.ambiguous[i] = geometric[i] && straddles;
      }
    }
  }

  /// Tone mapping (gamma 2.2, clipped), Gaussian noise in grey levels, black
  /// outside the view, >= 1 inside so no real pixel reads as "outside".
  void toImage(int which, int index, const CameraPass& P, cv::Mat& out) const {
    const int W = cfg.width, H = cfg.height;
    out.create(H, W, CV_8UC3);
    // A gain after the tone curve: what the views' grey-level ratio shows on
    // real rigs (a sensor's gain or white balance, not the light).
    const double gain = which == 1 ? cfg.right_gain : 1.0;
    detail::GaussianRng rng(detail::mix64(cfg.seed * 0x9e3779b97f4a7c15ull + static_cast<uint64_t>(index) * 2 +
                                          static_cast<uint64_t>(which) + 0x5eed));
    for (int y = 0; y < H; ++y) {
      cv::Vec3b* row = out.ptr<cv::Vec3b>(y);
      for (int x = 0; x < W; ++x) {
        if (!insideView(which, x, y)) {
          row[x] = cv::Vec3b(0, 0, 0);
          continue;
        }
        const float* lin = &P.rgb[3 * (static_cast<size_t>(y) * W + x)];
        for (int c = 0; c < 3; ++c) {
          double v = encode(lin[c]);
          if (gain != 1.0) v *= gain;
          if (cfg.noise > 0) v += cfg.noise * rng();
          const long q = std::lround(v);
          row[x][2 - c] = static_cast<uchar>(std::clamp(q, 1L, 255L));  // RGB -> BGR
        }
      }
    }
  }

  /// The view through a JPEG encoder and decoder at cfg.jpeg_quality. The
  /// border is restored to exactly 0 and a view pixel decoded as pure black
  /// to 1, so that black still means "outside the view" and nothing else.
  void compress(int which, cv::Mat& image) const {
    std::vector<uchar> encoded;
    if (!cv::imencode(".jpg", image, encoded, {cv::IMWRITE_JPEG_QUALITY, cfg.jpeg_quality})) {
      throw std::runtime_error("synthetic scene: JPEG encoding failed");
    }
    cv::imdecode(encoded, cv::IMREAD_COLOR, &image);
    for (int y = 0; y < image.rows; ++y) {
      cv::Vec3b* row = image.ptr<cv::Vec3b>(y);
      for (int x = 0; x < image.cols; ++x) {
        if (!insideView(which, x, y)) {
          row[x] = cv::Vec3b(0, 0, 0);
        } else if (row[x] == cv::Vec3b(0, 0, 0)) {
          row[x] = cv::Vec3b(1, 1, 1);
        }
      }
    }
  }

  void render(int index, SyntheticFrame& out) const {
    if (index < 0) throw std::invalid_argument("frame index must be >= 0");
    const detail::FrameState fs = scene.frameState(index);
    CameraPass L, R;
    renderCamera(0, fs, L);
    renderCamera(1, fs, R);
    toImage(0, index, L, out.left);
    toImage(1, index, R, out.right);
    if (cfg.jpeg_quality > 0) {
      compress(0, out.left);
      compress(1, out.right);
    }

    const int W = cfg.width, H = cfg.height;
    out.gt.create(H, W, CV_32FC1);
    out.depth.create(H, W, CV_32FC1);
    out.label.create(H, W, CV_8UC1);
    out.specular_left.create(H, W, CV_32FC1);
    out.specular_right.create(H, W, CV_32FC1);
    out.textureless.create(H, W, CV_8UC1);
    const double fb = cam.fx * cam.baseline;
    const Vec3 eye_r = fs.rig.apply(Vec3(cam.baseline, 0, 0));
    for (int y = 0; y < H; ++y) {
      float* g = out.gt.ptr<float>(y);
      float* z = out.depth.ptr<float>(y);
      uchar* lab = out.label.ptr<uchar>(y);
      uchar* tl = out.textureless.ptr<uchar>(y);
      float* sl = out.specular_left.ptr<float>(y);
      float* sr = out.specular_right.ptr<float>(y);
      for (int x = 0; x < W; ++x) {
        const size_t i = static_cast<size_t>(y) * W + x;
        sl[x] = L.spec[i];
        sr[x] = R.spec[i];
        g[x] = 0.f;
        z[x] = L.t[i] > 0 ? static_cast<float>(L.t[i]) : std::numeric_limits<float>::quiet_NaN();
        tl[x] = 0;
        const bool inside = insideView(0, x, y);
        lab[x] = inside ? L.label[i] : static_cast<uchar>(kLabelNone);
        if (!inside || L.t[i] <= 0) continue;
        const double Z = L.t[i];
        const Vec3 p = rayDir(fs, x, y) * Z;  // relative to the left eye (rig origin)
        if (cfg.textureless_patch && L.label[i] == kLabelTissue) {
          Vec3 nrm;
          const detail::Material m = scene.material(fs.rig.apply(Vec3(0, 0, 0)) + p, kLabelTissue, fs, Z / cam.fx,
                                                    fs.rig.apply(Vec3(0.5 * cam.baseline, 0, 0)), nrm);
          if (m.patch > 0.5) tl[x] = 255;
        }
        if (L.ambiguous[i]) continue;
        const double d = fb / Z;
        const double xr = x - d;
        // Both pixels that interpolate the right image at x_r must be in view.
        if (xr < 0 || xr > W - 1 || d > kMaxGtDisparity) continue;
        const int xr0 = static_cast<int>(xr);
        if (!insideView(1, xr0, y) || !insideView(1, std::min(xr0 + 1, W - 1), y)) continue;
        // Visible from the right camera? When both right pixel centres around
        // x_r see this surface at this disparity (within 0.25 px), nothing
        // can stand in between but a sliver thinner than a pixel, which the
        // right image does not show either; otherwise cast the right ray
        // through the point.
        const int x0 = static_cast<int>(xr), x1 = std::min(x0 + 1, W - 1);
        const size_t j0 = static_cast<size_t>(y) * W + x0, j1 = static_cast<size_t>(y) * W + x1;
        if (R.t[j0] > 0 && R.t[j1] > 0 && R.label[j0] == L.label[i] && R.label[j1] == L.label[i] &&
            std::fabs(fb / R.t[j0] - d) < 0.25 && std::fabs(fb / R.t[j1] - d) < 0.25 && !R.edge[j0] &&
            !R.edge[j1]) {
          g[x] = static_cast<float>(d);
          continue;
        }
        const Vec3 dir_cam((x - cam.cx) / cam.fx - cam.baseline / Z, (y - cam.cy) / cam.fy, 1.0);
        const Vec3 dr = fs.rig.rotate(dir_cam);
        const int xri = static_cast<int>(std::lround(xr));
        const detail::Scene::Hit h =
            scene.intersect(eye_r, dr, fs, std::min(R.tileFree(xri, y), Z), Z * (1 + 1e-6) + 1e-9, Z);
        if (h.t <= 0 || h.t < Z * (1 - 1e-6) - 1e-9) continue;
        g[x] = static_cast<float>(d);
      }
    }
  }
};

SyntheticRenderer::SyntheticRenderer(const SceneConfig& config) : impl_(std::make_unique<Impl>(config)) {}
SyntheticRenderer::~SyntheticRenderer() = default;
SyntheticRenderer::SyntheticRenderer(SyntheticRenderer&&) noexcept = default;
SyntheticRenderer& SyntheticRenderer::operator=(SyntheticRenderer&&) noexcept = default;

const SceneConfig& SyntheticRenderer::config() const { return impl_->cfg; }

void SyntheticRenderer::render(int index, SyntheticFrame& out) const { impl_->render(index, out); }

SyntheticFrame SyntheticRenderer::render(int index) const {
  SyntheticFrame f;
  impl_->render(index, f);
  return f;
}

RayHit SyntheticRenderer::castRay(int index, const cv::Vec3d& origin, const cv::Vec3d& direction) const {
  const detail::FrameState fs = impl_->scene.frameState(index);
  const Vec3 o = fs.rig.apply(Vec3(origin[0], origin[1], origin[2]));
  const Vec3 d = fs.rig.rotate(Vec3(direction[0], direction[1], direction[2]));
  // Depth along the optical axis bounds t: tmax / |d.z| covers the scene.
  const double dz = std::fabs(direction[2]) > 1e-9 ? std::fabs(direction[2]) : 1e-9;
  const detail::Scene::Hit h = impl_->scene.intersect(o, d, fs, 0.0, impl_->scene.maxDepth() / dz);
  RayHit r;
  if (h.t > 0) {
    r.hit = true;
    r.t = h.t;
    r.label = h.label;
    r.point = origin + direction * h.t;
  }
  return r;
}

}  // namespace synth
}  // namespace bdis
