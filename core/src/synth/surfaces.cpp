// The scene's geometry: the B-spline and capsule primitives, the tissue
// surface and the tube, each an implicit surface with texture coordinates.
#include "scene.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace bdis {
namespace synth {
namespace detail {
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

}  // namespace detail
}  // namespace synth
}  // namespace bdis
