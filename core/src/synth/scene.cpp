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

inline int clampi(int v, int lo, int hi) { return v < lo ? lo : (v > hi ? hi : v); }

// Noise of wavelength `lambda` (m) at texture coordinates (u, v) (m); the
// derivatives come back per metre. With period_v > 0 the lattice is stretched
// slightly in v so that it wraps exactly around the tube.
inline NoiseValue noiseAt(double u, double v, double lambda, uint32_t seed, double period_v) {
  double su = 1.0 / lambda, sv = su;
  int period = 0;
  if (period_v > 0) {
    period = std::max(1, static_cast<int>(std::lround(period_v / lambda)));
    sv = period / period_v;
  }
  NoiseValue n = gradientNoise(u * su, v * sv, seed, period);
  n.dx *= su;
  n.dy *= sv;
  return n;
}

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
BSpline2::BSpline2(int nu, int nv, double u0, double v0, double hu, double hv, bool periodic_v)
    : nu_(nu), nv_(nv), u0_(u0), v0_(v0), hu_(hu), hv_(hv), periodic_v_(periodic_v),
      c_(static_cast<size_t>(nu) * nv, 0.0) {}

double BSpline2::eval(double u, double v, double* du, double* dv) const {
  // Clamped to a few cells outside the grid, then offset so that the integer
  // cast is a floor (the library's floor() is a call on baseline x86-64).
  const double x = std::clamp((u - u0_) / hu_, -4.0, nu_ + 4.0) + 8.0;
  double y = (v - v0_) / hv_;
  if (periodic_v_) {
    if (y < 0 || y >= nv_) y -= nv_ * std::floor(y / nv_);  // [0, nv)
  } else {
    y = std::clamp(y, -4.0, nv_ + 4.0);
  }
  y += 8.0;
  const int ix = static_cast<int>(x), iy = static_cast<int>(y);
  const double tx = x - ix, ty = y - iy;
  const int i = ix - 8, j = iy - 8;
  const bool deriv = du || dv;
  double wu[4], dwu[4], wv[4], dwv[4];
  bsplineWeights(tx, wu, dwu);
  bsplineWeights(ty, wv, dwv);
  // The 4 x 4 control points: rows i-1..i+2, columns j-1..j+2 (clamped or
  // wrapped at the edges; a direct pointer inside the grid).
  const double* rows[4];
  int cols[4];
  const bool inner_cols = j >= 1 && j + 2 < nv_;
  for (int k = 0; k < 4; ++k) {
    rows[k] = &c_[static_cast<size_t>(clampi(i - 1 + k, 0, nu_ - 1)) * nv_];
    int jj = j - 1 + k;
    if (!inner_cols) {
      if (periodic_v_) {
        jj = jj < 0 ? jj + nv_ : (jj >= nv_ ? jj - nv_ : jj);
      } else {
        jj = clampi(jj, 0, nv_ - 1);
      }
    }
    cols[k] = jj;
  }
  double val = 0, gu = 0, gv = 0;
  for (int a = 0; a < 4; ++a) {
    const double* row = rows[a];
    const double c0 = row[cols[0]], c1 = row[cols[1]], c2 = row[cols[2]], c3 = row[cols[3]];
    const double r = wv[0] * c0 + wv[1] * c1 + wv[2] * c2 + wv[3] * c3;
    val += wu[a] * r;
    if (deriv) {
      gu += dwu[a] * r;
      gv += wu[a] * (dwv[0] * c0 + dwv[1] * c1 + dwv[2] * c2 + dwv[3] * c3);
    }
  }
  if (du) *du = gu / hu_;
  if (dv) *dv = gv / hv_;
  return val;
}

// ---------------------------------------------------------------------------
double Capsule::intersect(const Vec3& o, const Vec3& d_in, double tmin, double tmax) const {
  // Early out: the line misses the bounding sphere.
  {
    const Vec3 c = (a + b) * 0.5, oc = o - c;
    const Vec3 half = (b - a) * 0.5;
    const double rb = std::sqrt(dot(half, half)) + radius;
    const double dd = dot(d_in, d_in), k = dot(oc, d_in);
    if (dot(oc, oc) - k * k / dd > rb * rb) return -1;
  }
  // Inigo Quilez's capsule intersection, on a unit direction.
  const double dn = norm(d_in);
  const Vec3 rd = d_in * (1.0 / dn);
  const Vec3 ba = b - a, oa = o - a;
  const double baba = dot(ba, ba), bard = dot(ba, rd), baoa = dot(ba, oa), rdoa = dot(rd, oa),
               oaoa = dot(oa, oa);
  const double r2 = radius * radius;
  double t = -1;
  const double qa = baba - bard * bard;
  if (qa > 1e-18) {
    const double qb = baba * rdoa - baoa * bard;
    const double qc = baba * oaoa - baoa * baoa - r2 * baba;
    const double h = qb * qb - qa * qc;
    if (h >= 0) {
      const double tb = (-qb - std::sqrt(h)) / qa;
      const double y = baoa + tb * bard;
      if (y > 0 && y < baba) {
        t = tb;
      } else {
        const Vec3 oc = y <= 0 ? oa : o - b;
        const double cb = dot(rd, oc), cc = dot(oc, oc) - r2;
        const double hc = cb * cb - cc;
        if (hc > 0) t = -cb - std::sqrt(hc);
      }
    }
  } else {
    // Ray along the axis: only the caps.
    for (const Vec3& c : {a, b}) {
      const Vec3 oc = o - c;
      const double cb = dot(rd, oc), cc = dot(oc, oc) - r2;
      const double hc = cb * cb - cc;
      if (hc > 0) {
        const double tc = -cb - std::sqrt(hc);
        if (tc > 0 && (t < 0 || tc < t)) t = tc;
      }
    }
  }
  if (t < 0) return -1;
  // Two Newton steps on the signed distance along the ray remove the
  // cancellation of the quadratic (1e-5 relative at grazing incidence).
  for (int k = 0; k < 2; ++k) {
    const Vec3 p = o + rd * t;
    const double h = std::clamp(dot(p - a, ba) / baba, 0.0, 1.0);
    const Vec3 q = p - (a + ba * h);
    const double qn = norm(q);
    const double slope = dot(q, rd) / qn;  // d(distance)/dt, < 0 entering
    if (!(slope < -1e-3)) break;           // grazing: keep the quadratic's root
    t -= (qn - radius) / slope;
  }
  t /= dn;
  return (t > tmin && t <= tmax) ? t : -1;
}

Vec3 Capsule::normal(const Vec3& p) const {
  const Vec3 ba = b - a;
  const double h = std::clamp(dot(p - a, ba) / dot(ba, ba), 0.0, 1.0);
  return normalized(p - (a + ba * h));
}

void Capsule::surfaceCoords(const Vec3& p, double& s, double& phi) const {
  const Vec3 ba = b - a;
  const double len = norm(ba);
  const Vec3 axis = ba * (1.0 / len);
  s = dot(b - p, axis);  // from the tip back along the shaft (negative on the tip's cap)
  Vec3 e1 = cross(axis, Vec3(0, 1, 0));
  if (norm(e1) < 1e-6) e1 = cross(axis, Vec3(1, 0, 0));
  e1 = normalized(e1);
  const Vec3 e2 = cross(axis, e1);
  const Vec3 r = p - a;
  phi = std::atan2(dot(r, e2), dot(r, e1));
}

// ---------------------------------------------------------------------------
namespace {
constexpr double kGridCos = 0.87758256189037276, kGridSin = 0.47942553860420301;  // 0.5 rad
}

// Tissue: a bowl-shaped organ surface (nearer in the middle, farther at the
// periphery and towards the top of the image) with multi-scale bumps and a
// fold, stored as a cubic B-spline, plus a breathing bulge.
TissueSurface::TissueSurface(uint64_t seed) {
  std::mt19937_64 rng(subSeed(seed, 11));
  auto uni = [&](double lo, double hi) { return lo + (hi - lo) * uniform01(rng); };
  z0_ = 0.052;
  tilt_u_ = uni(-0.06, 0.06);
  tilt_v_ = uni(-0.26, -0.18);  // top of the image (y < 0) farther
  curvature_ = uni(2.0, 3.0);   // 1/m: 2.5 mm deeper 3 cm off the middle
  breath_amp_ = 0.0018;         // m towards the camera at full inspiration
  breath_u_ = uni(-0.012, 0.012);
  breath_v_ = uni(-0.010, 0.010);
  breath_r2_ = 0.04 * 0.04;

  const double h = 0.006, lo = -0.15;
  const int n = static_cast<int>(std::ceil(0.30 / h)) + 1;
  bumps_ = BSpline2(n, n, lo, lo, h, h, false);
  const uint32_t s1 = subSeed(seed, 12), s2 = subSeed(seed, 13);
  // A fold of tissue (nearer to the camera) along a random line.
  const double fold_angle = uni(0, kPi), fold_u = uni(-0.02, 0.02), fold_v = uni(-0.01, 0.025);
  const double fdx = std::cos(fold_angle), fdy = std::sin(fold_angle);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const double u = lo + h * i, v = lo + h * j;
      // Control points sample the relief at >= 2 cells per wavelength: finer
      // octaves would show the grid's tensor-product structure.
      double z = 0.0032 * noiseAt(u, v, 0.032, s1, 0).v + 0.0016 * noiseAt(u, v, 0.014, s2, 0).v;
      const double du = u - fold_u, dv = v - fold_v;
      const double across = -fdy * du + fdx * dv, along = fdx * du + fdy * dv;
      z -= 0.0035 * std::exp(-across * across / (2 * 0.0045 * 0.0045)) *
           std::exp(-along * along / (2 * 0.022 * 0.022));
      bumps_.at(i, j) = z;
    }
  }
  // Lipschitz bound of F = height - z over the reachable material region,
  // both breathing extremes, with a margin.
  double gmax = 0;
  for (double u = -0.14; u <= 0.14; u += 0.001) {
    for (double v = -0.14; v <= 0.14; v += 0.001) {
      for (double b : {-1.0, 1.0}) {
        double hu = 0, hv = 0;
        height(u, v, b, &hu, &hv);
        gmax = std::max(gmax, hu * hu + hv * hv);
      }
    }
  }
  lipschitz_ = 1.15 * std::sqrt(1.0 + gmax);

  // Slope bound per disk |(u, v)| <= (k + 1) * 5 mm, and the highest point
  // (for the unique-root test of monotoneRoot).
  ring_slope_.assign(30, 0.0);
  height_max_ = -1e9;
  for (double u = -0.15; u <= 0.15; u += 0.001) {
    for (double v = -0.15; v <= 0.15; v += 0.001) {
      const int k = std::min(29, static_cast<int>(std::hypot(u, v) / 0.005));
      for (double b : {-1.0, 1.0}) {
        double hu = 0, hv = 0;
        height_max_ = std::max(height_max_, height(u, v, b, &hu, &hv));
        ring_slope_[k] = std::max(ring_slope_[k], std::hypot(hu, hv));
      }
    }
  }
  for (int k = 1; k < 30; ++k) ring_slope_[k] = std::max(ring_slope_[k], ring_slope_[k - 1]);
  for (double& g : ring_slope_) g = 1.1 * g + 0.01;  // margin over the sampling
}

double TissueSurface::monotoneRoot(const Vec3& o, const Vec3& d, const FrameState& fs, double t0, double tmax,
                                   double hint) const {
  // g(t) = h(o.xy + t d.xy + offset) - (o.z + t d.z). Where the slope bound
  // times |d.xy| stays below d.z on the whole path, g strictly decreases: one
  // root, so safeguarded Newton cannot step over an occluder.
  if (d.z <= 0) return kNoShortcut;
  const double t_hi = (height_max_ - o.z) / d.z;  // g(t_hi) <= 0
  if (t_hi <= t0) return kNoShortcut;
  const double dxy = std::sqrt(d.x * d.x + d.y * d.y);
  const double ox = o.x + fs.ox, oy = o.y + fs.oy;
  const double reach = std::sqrt(ox * ox + oy * oy) + dxy * t_hi;
  const int k = static_cast<int>(reach / 0.005);
  if (k >= 30 || ring_slope_[k] * dxy >= 0.95 * d.z) return kNoShortcut;
  double a = t0, b = t_hi, t = hint > t0 && hint < t_hi ? hint : t0;
  for (int it = 0; it < 60; ++it) {
    double hu = 0, hv = 0;
    const double g = height(o.x + t * d.x + fs.ox, o.y + t * d.y + fs.oy, fs.breath, &hu, &hv) - (o.z + t * d.z);
    if (g > 0) {
      a = t;
    } else {
      b = t;
    }
    if (std::fabs(g) < 1e-13 || b - a < 1e-12) break;
    const double dg = hu * d.x + hv * d.y - d.z;  // < 0
    double tn = t - g / dg;
    if (!(tn > a && tn < b)) tn = 0.5 * (a + b);
    if (std::fabs(tn - t) < 1e-13) {
      t = tn;
      break;
    }
    t = tn;
  }
  return t <= tmax ? t : -1.0;
}

double TissueSurface::height(double u, double v, double breath, double* hu, double* hv) const {
  // The bump spline lives on a grid rotated by kGridAngle, so that no
  // residue of its cells lines up with the image axes.
  double su = 0, sv = 0, gu = 0, gv = 0;
  const double s = bumps_.eval(kGridCos * u + kGridSin * v, -kGridSin * u + kGridCos * v, hu ? &gu : nullptr,
                               hv ? &gv : nullptr);
  if (hu || hv) {
    su = kGridCos * gu - kGridSin * gv;
    sv = kGridSin * gu + kGridCos * gv;
  }
  const double bu = u - breath_u_, bv = v - breath_v_;
  const double q = 1.0 / (1.0 + (bu * bu + bv * bv) / breath_r2_);
  const double z = z0_ + tilt_u_ * u + tilt_v_ * v + curvature_ * (u * u + v * v) + s -
                   breath * breath_amp_ * q;
  if (hu || hv) {
    // d q / d u = -q^2 * 2 bu / r2
    const double k = breath * breath_amp_ * q * q * 2.0 / breath_r2_;
    if (hu) *hu = tilt_u_ + 2 * curvature_ * u + su + k * bu;
    if (hv) *hv = tilt_v_ + 2 * curvature_ * v + sv + k * bv;
  }
  return z;
}

double TissueSurface::F(const Vec3& p, const FrameState& fs) const {
  return height(p.x + fs.ox, p.y + fs.oy, fs.breath, nullptr, nullptr) - p.z;
}

void TissueSurface::local(const Vec3& p, const FrameState& fs, Vec3& normal, double& u, double& v,
                          Vec3& tu, Vec3& tv) const {
  u = p.x + fs.ox;
  v = p.y + fs.oy;
  double hu = 0, hv = 0;
  height(u, v, fs.breath, &hu, &hv);
  normal = normalized(Vec3(hu, hv, -1.0));  // grad F: towards the camera side
  tu = normalized(Vec3(1, 0, hu));
  tv = normalized(Vec3(0, 1, hv));
}

// ---------------------------------------------------------------------------
// Tube: radius R(z, theta) around a meandering centreline, as a periodic
// cubic B-spline; three taeniae, crescent haustral folds every ~26 mm, small
// bumps, closing over its last 50 mm.
namespace {
constexpr double kTubeZ0 = -0.16, kTubeZ1 = 0.45, kTubeClose = 0.40;
}

TubeSurface::TubeSurface(uint64_t seed) {
  std::mt19937_64 rng(subSeed(seed, 21));
  auto uni = [&](double lo, double hi) { return lo + (hi - lo) * uniform01(rng); };
  r0_ = 0.021;
  period_v_ = 2 * kPi * r0_;
  ax_ = 0.011;
  kx_ = 2 * kPi / 0.17;
  px_ = uni(0, 2 * kPi);
  ay_ = 0.005;
  ky_ = 2 * kPi / 0.23;
  py_ = uni(0, 2 * kPi);
  c_z0_ = kTubeZ0 - 0.02;
  c_h_ = 0.001;
  for (double z = c_z0_; z <= kTubeZ1 + 0.02 + c_h_; z += c_h_) {
    c_.push_back(ax_ * std::sin(kx_ * z + px_));
    c_.push_back(ax_ * kx_ * std::cos(kx_ * z + px_));
    c_.push_back(ay_ * std::sin(ky_ * z + py_));
    c_.push_back(ay_ * ky_ * std::cos(ky_ * z + py_));
  }
  const double taenia = uni(0, 2 * kPi);

  struct Fold {
    double z, depth, width, skew, phase;
    double sector[3];
  };
  std::vector<Fold> folds;
  for (double z = kTubeZ0 + uni(0, 0.02); z < kTubeClose; z += uni(0.022, 0.030)) {
    Fold f{z, r0_ * uni(0.15, 0.27), uni(0.0030, 0.0040), uni(-0.003, 0.003), uni(0, 2 * kPi), {}};
    for (double& s : f.sector) s = uni(0.3, 1.0);
    folds.push_back(f);
  }
  const uint32_t sb = subSeed(seed, 22);
  const double hz = 0.0008;
  const int nz = static_cast<int>(std::ceil((kTubeZ1 - kTubeZ0) / hz)) + 1, nt = 128;
  const double ht = 2 * kPi / nt;
  radius_ = BSpline2(nz, nt, kTubeZ0, 0.0, hz, ht, true);
  for (int i = 0; i < nz; ++i) {
    const double z = kTubeZ0 + hz * i;
    for (int j = 0; j < nt; ++j) {
      const double th = ht * j;
      double r = r0_ * (1.0 + 0.07 * std::cos(3 * (th - taenia)));
      // Folds hang between the taeniae: deepest where cos(3 (th - taenia)) = -1.
      const double between = smoothstep(0.0, 0.7, 0.5 * (1.0 - std::cos(3 * (th - taenia))));
      // Sectors change at the taeniae, where `between` is 0: no seam.
      const int sector = static_cast<int>(std::floor(3 * std::fmod(th - taenia + 4 * kPi, 2 * kPi) /
                                                     (2 * kPi))) % 3;
      for (const Fold& f : folds) {
        const double dz = z - f.z - f.skew * std::sin(th + f.phase);
        if (std::fabs(dz) > 5 * f.width) continue;
        r -= f.depth * f.sector[sector] * between * std::exp(-dz * dz / (f.width * f.width));
      }
      r += 0.0006 * noiseAt(z, th * r0_, 0.008, sb, period_v_).v;
      r *= 1.0 - 0.97 * smoothstep(kTubeClose - 0.05, kTubeClose, z);
      radius_.at(i, j) = r;
    }
  }
  // Lipschitz bound: |grad F| sampled on the wall and halfway to the axis,
  // and the bound that keeps F / L below the distance to the wall from the
  // axis region, with a margin.
  double gmax = 1.0, rmin = 1e9, rmax = 0;
  for (double z = kTubeZ0; z < kTubeZ1; z += 0.0004) {
    double cx = 0, cy = 0;
    centre(z, cx, cy);
    for (int j = 0; j < 256; ++j) {
      const double th = 2 * kPi * (j + 0.5) / 256;
      const double r = radius_.eval(z, th);
      if (z < kTubeClose - 0.05) {
        rmin = std::min(rmin, r);
        rmax = std::max(rmax, r);
      }
      for (double rho : {r, 0.5 * r}) {
        const Vec3 p(cx + rho * std::cos(th), cy + rho * std::sin(th), z);
        const Vec3 g = gradient(p);
        gmax = std::max(gmax, dot(g, g));
      }
    }
  }
  const double cslope = std::hypot(ax_ * kx_, ay_ * ky_);
  lipschitz_ = 1.15 * std::max(std::sqrt(gmax), (1.0 + cslope) * rmax / rmin);
}

Vec3 TubeSurface::gradient(const Vec3& p, double* theta) const {
  double cx = 0, cy = 0, dcx = 0, dcy = 0;
  centre(p.z, cx, cy, &dcx, &dcy);
  const double qx = p.x - cx, qy = p.y - cy;
  const double rho = std::max(1e-9, std::sqrt(qx * qx + qy * qy));
  const double th = atan2Positive(qy, qx);  // as in F
  if (theta) *theta = th;
  double rz = 0, rt = 0;
  radius_.eval(p.z, th, &rz, &rt);
  const double r2 = rho * rho;
  const Vec3 drho(qx / rho, qy / rho, -(qx * dcx + qy * dcy) / rho);
  const Vec3 dth(-qy / r2, qx / r2, (qy * dcx - qx * dcy) / r2);
  return dth * rt + Vec3(0, 0, rz) - drho;
}

void TubeSurface::centre(double z, double& cx, double& cy, double* dcx, double* dcy) const {
  // Cubic Hermite through the tabulated analytic centreline (exact values
  // and slopes at 1 mm knots): two sines per call would dominate F.
  const double x = std::clamp((z - c_z0_) / c_h_, 0.0, static_cast<double>(c_.size() / 4 - 2) + 0.999999);
  const int i = static_cast<int>(x);
  const double t = x - i, t2 = t * t, t3 = t2 * t;
  const double* k0 = &c_[4 * static_cast<size_t>(i)];
  const double* k1 = k0 + 4;
  const double h00 = 2 * t3 - 3 * t2 + 1, h10 = (t3 - 2 * t2 + t) * c_h_, h01 = -2 * t3 + 3 * t2,
               h11 = (t3 - t2) * c_h_;
  cx = h00 * k0[0] + h10 * k0[1] + h01 * k1[0] + h11 * k1[1];
  cy = h00 * k0[2] + h10 * k0[3] + h01 * k1[2] + h11 * k1[3];
  if (dcx || dcy) {
    const double d00 = (6 * t2 - 6 * t) / c_h_, d10 = 3 * t2 - 4 * t + 1, d01 = (-6 * t2 + 6 * t) / c_h_,
                 d11 = 3 * t2 - 2 * t;
    if (dcx) *dcx = d00 * k0[0] + d10 * k0[1] + d01 * k1[0] + d11 * k1[1];
    if (dcy) *dcy = d00 * k0[2] + d10 * k0[3] + d01 * k1[2] + d11 * k1[3];
  }
}

double TubeSurface::F(const Vec3& p, const FrameState&) const {
  double cx = 0, cy = 0;
  centre(p.z, cx, cy);
  const double qx = p.x - cx, qy = p.y - cy;
  const double rho = std::sqrt(qx * qx + qy * qy);
  return radius_.eval(p.z, atan2Positive(qy, qx)) - rho;
}

void TubeSurface::local(const Vec3& p, const FrameState&, Vec3& normal, double& u, double& v, Vec3& tu,
                        Vec3& tv) const {
  double th = 0;
  normal = normalized(gradient(p, &th));  // towards the axis: free space
  double cx = 0, cy = 0, dcx = 0, dcy = 0;
  centre(p.z, cx, cy, &dcx, &dcy);
  u = p.z;
  v = th * r0_;
  tu = normalized(Vec3(dcx, dcy, 1.0));
  tv = Vec3(-std::sin(th), std::cos(th), 0.0);
}

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
