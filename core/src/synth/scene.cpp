// The scene: the tissue's and the instrument's materials (noise, vessels,
// specular layers) and the frame-by-frame scene (motion, ray casting,
// shadows). The surfaces are in surfaces.cpp.
#include "scene.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace bdis {
namespace synth {
namespace detail {

namespace {

// Frames are 1/30 s apart (motion speeds below are per second).
constexpr double kFps = 30.0;

// Weight of a texture component of wavelength lambda when a pixel covers fp
// metres: 1 above 3 px per wavelength, 0 below 1.5 px (band-limiting, so one
// sample per pixel does not alias; identical in both views because Z is).
inline double lodWeight(double lambda, double fp) { return smoothstep(1.5, 3.0, lambda / fp); }

// Fractal sum of `octaves` octaves from wavelength lambda0 down, gain 0.5,
// band-limited by fp, normalised by the full amplitude sum (so fading an
// octave lowers the contrast, as a blur would). Optional gradient per metre.
double fbm(double u, double v, double lambda0, int octaves, double fp, uint32_t seed, double period_v,
           double* du = nullptr, double* dv = nullptr) {
  double sum = 0, amp = 1, norm_sum = 0, gu = 0, gv = 0, lambda = lambda0;
  const double inv_fp = 1.0 / fp;
  for (int o = 0; o < octaves; ++o) {
    norm_sum += amp;
    const double w = smoothstep(1.5, 3.0, lambda * inv_fp);
    if (w > 0) {
      const NoiseValue n = noiseAt(u, v, lambda, seed + 977u * static_cast<uint32_t>(o), period_v);
      sum += amp * w * n.v;
      gu += amp * w * n.dx;
      gv += amp * w * n.dy;
    } else {
      // Finer octaves fade out too.
      for (++o; o < octaves; ++o) norm_sum += (amp *= 0.5);
      break;
    }
    amp *= 0.5;
    lambda *= 0.5;
  }
  if (du) *du = gu / norm_sum;
  if (dv) *dv = gv / norm_sum;
  return sum / norm_sum;
}

// Vessel-like lines: the zero set of a (domain-warped) noise field, drawn
// with a Gaussian profile of width `width` (m), using |n| / |grad n| as the
// distance to the zero set. Band-limited: thinner than the pixel, a line
// widens and fades (same ink). `calibre` in [-1, 1] varies the width along
// the vessel. Also returns that distance, so that finer vessels can branch
// off near coarser ones.
struct VesselSample {
  double line = 0;
  double dist = 1e9;  // m
};

VesselSample vessel(double wu, double wv, double lambda, double width, double calibre, double fp, uint32_t seed,
                    double period_v) {
  VesselSample out;
  const NoiseValue n = noiseAt(wu, wv, lambda, seed, period_v);
  const double g = std::sqrt(n.dx * n.dx + n.dy * n.dy);
  out.dist = std::fabs(n.v) / std::max(g, 1e-9);
  const double w = width * (0.7 + 0.5 * calibre);
  const double w_eff2 = w * w + 0.5 * fp * fp;
  const double x2 = out.dist * out.dist / w_eff2;
  if (x2 < 16) out.line = (w / std::sqrt(w_eff2)) * std::exp(-x2);
  return out;
}

}  // namespace

// ---------------------------------------------------------------------------
Material TissueTexture::eval(double u, double v, double fp, bool specular) const {
  const double pv = period_v;
  // Large smooth, nearly textureless regions of the tissue itself.
  const double smooth_noise = noiseAt(u, v, 0.035, seed + 101u, pv).v;
  const double smooth = smoothstep(-0.15, 0.25, smooth_noise);
  double detail = 1.0 - 0.97 * smooth;
  double in_patch = 0.0;
  if (patch) {
    const double dist = std::sqrt((u - patch_u) * (u - patch_u) + (v - patch_v) * (v - patch_v));
    in_patch = 1.0 - smoothstep(patch_r - 0.0015, patch_r, dist);
    detail *= 1.0 - in_patch;
  }
  const double keep = 1.0 - in_patch;
  const double mottle = keep * fbm(u, v, 0.024, 2, fp, seed + 202u, pv);
  // Fine granular mucosa; its two coarse octaves also make the bump relief.
  double bu = 0, bv = 0;
  const double grain_coarse = fbm(u, v, 0.0024, 2, fp, seed + 303u, pv, &bu, &bv);
  const double grain = 0.8 * grain_coarse + 0.2 * fbm(u, v, 0.0006, 1, fp, seed + 313u, pv);
  // Vessels in three calibres sharing one domain warp (tortuosity). Large
  // ones come in long open segments; medium ones branch off within a few mm
  // of a large one (or, sparsely, on their own); capillaries hang off the
  // medium ones and fill the textured regions faintly.
  const NoiseValue w1 = noiseAt(u, v, 0.020, seed + 808u, pv), w2 = noiseAt(u, v, 0.020, seed + 909u, pv);
  const double wu = u + 0.007 * w1.v, wv = v + 0.007 * w2.v;
  const VesselSample s1 = vessel(wu, wv, 0.030, 0.00045, w2.v, fp, seed + 404u, pv);
  // (Presence reuses the low-frequency fields: large vessels run where the
  // tissue is textured, medium ones also where the warp field is high.)
  const double p1 = smoothstep(-0.35, 0.15, -smooth_noise);
  const VesselSample s2 = vessel(wu, wv, 0.010, 0.00022, w1.v, fp, seed + 505u, pv);
  const double p2 = std::max(p1 * smoothstep(0.007, 0.002, s1.dist),
                             0.6 * smoothstep(0.25, 0.55, w1.v));
  const VesselSample s3 = vessel(wu, wv, 0.0040, 0.00009, 0.0, fp, seed + 606u, pv);
  const double p3 = std::max(p2 * smoothstep(0.004, 0.001, s2.dist), 0.35 * detail);
  const double v1 = keep * p1 * s1.line;
  const double v2 = keep * p2 * s2.line;
  const double v3 = keep * detail * p3 * s3.line;

  // Linear RGB; sRGB of the base is about (230, 130, 118): pink mucosa.
  const Vec3 base(0.78, 0.22, 0.18), pale(0.86, 0.42, 0.33), deep(0.62, 0.11, 0.10);
  const Vec3 vein(0.30, 0.03, 0.07), artery(0.50, 0.04, 0.04), capillary(0.60, 0.08, 0.08);
  Vec3 a = mottle > 0 ? lerp(base, pale, std::min(1.0, 0.9 * mottle)) : lerp(base, deep, std::min(1.0, -0.8 * mottle));
  a = a * (1.0 + 0.07 * detail * grain);
  a = lerp(a, capillary, std::min(1.0, 0.45 * v3));
  a = lerp(a, artery, std::min(1.0, 0.65 * v2));
  a = lerp(a, vein, std::min(1.0, 0.75 * v1));

  Material m;
  m.albedo = a;
  const double bump = 0.00010 * (0.1 + 0.9 * detail);  // m of relief, as slopes below
  m.bump_u = bump * bu;
  m.bump_v = bump * bv;
  m.patch = in_patch;
  if (specular) {
    m.ks_sharp = 1.6;
    m.m_sharp = 30;
    m.ks_broad = 0.12;
    m.m_broad = 6;
  }
  return m;
}

Material instrumentMaterial(double s, double phi, double radius, double fp, uint32_t seed, bool specular) {
  Material m;
  const double v = phi * radius;
  const double period = 2 * kPi * radius;
  if (s < 0.012) {
    // Metal jaws: brushed steel with serrations across and the jaw gap along.
    const double brushed = noiseAt(s * 0.2, v * 4, 0.0008, seed, period).v;
    double a = 0.50 * (1.0 + 0.08 * brushed);
    const double serr = 0.5 + 0.5 * std::sin(2 * kPi * s / 0.0009);
    a *= 1.0 - 0.35 * lodWeight(0.0009, fp) * serr * (s > 0.002 ? 1.0 : 0.0);
    const double gap = std::min(std::fabs(std::remainder(phi, kPi)), 1.0) * radius;
    a *= 1.0 - 0.85 * std::exp(-gap * gap / (0.00025 * 0.00025 + 0.25 * fp * fp));
    m.albedo = Vec3(a, a, a * 1.04);
    if (specular) {
      m.ks_sharp = 1.6;
      m.m_sharp = 60;
      m.ks_broad = 0.15;
      m.m_broad = 8;
    }
  } else {
    // Shaft: black insulation with a white depth marking and faint wear.
    double a = 0.045 * (1.0 + 0.25 * fbm(s, v, 0.004, 2, fp, seed + 1u, period));
    const double ring = std::fmod(s - 0.012, 0.025);
    if (s > 0.02 && ring < 0.003) a = 0.55;
    m.albedo = Vec3(a, a, a * 1.05);
    if (specular) {
      m.ks_sharp = 0.5;
      m.m_sharp = 30;
      m.ks_broad = 0.05;
      m.m_broad = 6;
    }
  }
  return m;
}

// ---------------------------------------------------------------------------
Scene::Scene(const SceneConfig& config) : cfg_(config) {
  cfg_.validate();
  const uint64_t seed = cfg_.seed;
  texture_.seed = subSeed(seed, 31);
  tool_seed_ = subSeed(seed, 32);
  if (cfg_.scene == SceneType::Tissue) {
    surface_ = std::make_unique<TissueSurface>(seed);
    max_depth_ = 0.30;
    light_power_ = 0.0032;
    tool_radius_ = 0.0025;
  } else {
    surface_ = std::make_unique<TubeSurface>(seed);
    max_depth_ = 0.75;
    light_power_ = 0.0009;
    tool_radius_ = 0.0012;
  }
  texture_.period_v = surface_->periodV();
  if (cfg_.textureless_patch && cfg_.scene == SceneType::Tissue) {
    // Centre the patch on the surface point seen at (0.40 W, 0.45 H) at frame
    // 0, radius 8 mm (about 80 px at 640 x 480).
    const FrameState fs = frameState(0);
    const StereoCamera cam = cfg_.camera();
    const Vec3 d((0.40 * cfg_.width - cam.cx) / cam.fx, (0.45 * cfg_.height - cam.cy) / cam.fy, 1.0);
    const double t = traceSurface(Vec3(0, 0, 0), d, fs, 0.0, max_depth_);
    const Vec3 p = d * t;
    texture_.patch = true;
    texture_.patch_u = p.x + fs.ox;
    texture_.patch_v = p.y + fs.oy;
    texture_.patch_r = 0.008;
  }
}

FrameState Scene::frameState(int index) const {
  FrameState fs;
  const double t = cfg_.motion * index / kFps;  // seconds of scene time
  const double w = 2 * kPi;
  const StereoCamera cam = cfg_.camera();
  std::mt19937_64 rng(subSeed(cfg_.seed, 41));
  auto uni = [&](double lo, double hi) { return lo + (hi - lo) * uniform01(rng); };
  if (cfg_.scene == SceneType::Tissue) {
    // Slow pan over the tissue and breathing (bounded, periodic: any index is fine).
    fs.ox = 0.006 * std::sin(w * t / 11.0);
    fs.oy = 0.004 * std::sin(w * t / 17.0);
    fs.breath = std::sin(w * t / 4.0);
    if (cfg_.instrument) {
      // A 5 mm instrument entering from the right, its tip 1 cm above the tissue.
      const Vec3 a(0.060, 0.016 + uni(-0.004, 0.004), 0.022);
      const Vec3 b0(0.006 + uni(-0.003, 0.003), 0.004 + uni(-0.003, 0.003), 0.040);
      const Vec3 axis = normalized(b0 - a);
      const Vec3 b = b0 + axis * (0.004 * std::sin(w * t / 5.0)) +
                     Vec3(0, 0.0015 * std::sin(w * t / 7.0), 0.0015 * std::sin(w * t / 9.0));
      fs.has_tool = true;
      fs.tool = Capsule{a, b, tool_radius_};
    }
  } else {
    // Forward then back along the tube (bounded, periodic), looking along
    // the centreline with a slight yaw and pitch.
    const auto& tube = static_cast<const TubeSurface&>(*surface_);
    const double zc = 0.09 * std::sin(w * t / 40.0);
    double cx = 0, cy = 0, dcx = 0, dcy = 0;
    tube.centre(zc, cx, cy, &dcx, &dcy);
    const double yaw = 0.04 * std::sin(w * t / 13.0), pitch = -0.03 + 0.03 * std::sin(w * t / 9.0);
    Vec3 fwd = normalized(Vec3(dcx + yaw, dcy + pitch, 1.0));
    const Vec3 x = normalized(cross(Vec3(0, 1, 0), fwd));
    const Vec3 y = cross(fwd, x);
    fs.rig.cx = x;
    fs.rig.cy = y;
    fs.rig.cz = fwd;
    const double off = 0.15 * tube.radius0();
    fs.rig.t = Vec3(cx + off * std::sin(w * t / 7.0) - cam.baseline / 2, cy + 0.5 * off, zc);
    if (cfg_.instrument) {
      // Forceps out of the working channel at the bottom right.
      const Vec3 a(0.011, 0.0095, 0.018);
      const Vec3 b(0.004 + uni(-0.001, 0.001), 0.0035 + uni(-0.001, 0.001), 0.040 + 0.004 * std::sin(w * t / 5.0));
      fs.has_tool = true;
      fs.tool = Capsule{fs.rig.apply(a), fs.rig.apply(b), tool_radius_};
    }
  }
  return fs;
}

double Scene::traceSurface(const Vec3& o, const Vec3& d, const FrameState& fs, double t0, double tmax,
                           double hint) const {
  const Surface& s = *surface_;
  const double shortcut = s.monotoneRoot(o, d, fs, t0, tmax, hint);
  if (shortcut != Surface::kNoShortcut) return shortcut;
  // Sphere tracing with the Lipschitz bound; once the samples approach the
  // surface, a secant prediction may step up to kMaxBlindStep past the proven
  // distance (a feature thinner than that along the ray can be missed: only
  // rays grazing a fold's rim, within a fraction of a pixel; left and right
  // rays then disagree and the ground truth there is left unknown). A
  // crossing is then bracketed and solved by Illinois to 1e-12 m.
  constexpr double kMaxBlindStep = 0.001, kMinStep = 1e-5;  // m along the ray
  const double dn = norm(d);
  const double inv = 1.0 / (s.lipschitz() * dn);
  double t = t0, f = s.F(o + d * t, fs);
  if (f <= 0) return t0;  // already on or behind the surface
  double t_prev = -1, f_prev = 0;
  for (int i = 0; i < 4096; ++i) {
    double step = std::max(f * inv, kMinStep / dn);
    if (t_prev >= 0 && f < f_prev) {
      const double predicted = 1.1 * f * (t - t_prev) / (f_prev - f);
      step = std::max(step, std::min(predicted, kMaxBlindStep / dn));
    }
    double tn = t + step;
    const bool last = tn >= tmax;
    if (last) tn = tmax;
    const double fn = s.F(o + d * tn, fs);
    if (fn <= 0) {
      double a = t, fa = f, b = tn, fb = fn;
      int side = 0;
      for (int k = 0; k < 100 && b - a > 1e-12; ++k) {
        const double c = (a * fb - b * fa) / (fb - fa);
        const double fc = s.F(o + d * c, fs);
        if (fc > 0) {
          a = c;
          fa = fc;
          if (side == 1) fb *= 0.5;
          side = 1;
        } else {
          b = c;
          fb = fc;
          if (side == -1) fa *= 0.5;
          side = -1;
        }
        if (std::fabs(fc) < 1e-13) return c;
      }
      return b;
    }
    if (last) return -1;
    t_prev = t;
    f_prev = f;
    t = tn;
    f = fn;
  }
  return -1;
}

double Scene::coneFreeT(const Vec3& o, const Vec3& dc, double r, const FrameState& fs, double tmax) const {
  const Surface& s = *surface_;
  const double L = s.lipschitz(), dn = norm(dc);
  double t = 0;
  for (int i = 0; i < 256 && t < tmax; ++i) {
    const double D = s.F(o + dc * t, fs) / L;
    const double slack = D - r * t;
    if (slack <= 0.3 * D) break;
    t += 0.98 * slack / (dn + r);
  }
  return std::min(t, tmax);
}

Scene::Hit Scene::intersect(const Vec3& o, const Vec3& d, const FrameState& fs, double t_free, double tmax,
                            double hint) const {
  Hit h;
  double limit = tmax;
  double t_tool = -1;
  if (fs.has_tool) {
    t_tool = fs.tool.intersect(o, d, 0.0, tmax);
    if (t_tool > 0) limit = t_tool;
  }
  const double ts = traceSurface(o, d, fs, t_free, limit, hint);
  if (ts > 0) {
    h.t = ts;
    h.label = kLabelTissue;
  } else if (t_tool > 0) {
    h.t = t_tool;
    h.label = kLabelInstrument;
  }
  return h;
}

Material Scene::material(const Vec3& p, int label, const FrameState& fs, double fp, const Vec3& rig_centre,
                         Vec3& normal) const {
  const bool specular = cfg_.lighting == Lighting::Specular;
  // Foreshortening widens the footprint on oblique surfaces; measured from
  // the rig centre, so both views band-limit a point alike.
  const Vec3 to_rig = normalized(rig_centre - p);
  if (label == kLabelInstrument) {
    double s = 0, phi = 0;
    fs.tool.surfaceCoords(p, s, phi);
    normal = fs.tool.normal(p);
    fp /= std::max(0.2, std::fabs(dot(normal, to_rig)));
    return instrumentMaterial(s, phi, fs.tool.radius, fp, tool_seed_, specular);
  }
  double u = 0, v = 0;
  Vec3 tu, tv;
  surface_->local(p, fs, normal, u, v, tu, tv);
  fp /= std::max(0.2, std::fabs(dot(normal, to_rig)));
  Material m = texture_.eval(u, v, fp, specular);
  normal = normalized(normal - tu * m.bump_u - tv * m.bump_v);
  return m;
}

bool Scene::shadowed(const Vec3& p, const Vec3& light, const FrameState& fs) const {
  if (!fs.has_tool) return false;
  return fs.tool.intersect(p, light - p, 1e-6, 1.0) > 0;
}

}  // namespace detail
}  // namespace synth
}  // namespace bdis
