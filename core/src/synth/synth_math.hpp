// Small deterministic building blocks of the synthetic renderer: a 3-vector,
// integer hashing, 2-D gradient noise with analytic derivatives, band-limited
// fbm, cubic B-splines and a portable Gaussian RNG (Marsaglia polar on
// mt19937_64, because std::normal_distribution differs between standard
// libraries).
// Internal header.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>

namespace bdis {
namespace synth {
namespace detail {

constexpr double kPi = 3.14159265358979323846;

struct Vec3 {
  double x = 0, y = 0, z = 0;
  Vec3() = default;
  constexpr Vec3(double x_, double y_, double z_) : x(x_), y(y_), z(z_) {}
  Vec3 operator+(const Vec3& o) const { return {x + o.x, y + o.y, z + o.z}; }
  Vec3 operator-(const Vec3& o) const { return {x - o.x, y - o.y, z - o.z}; }
  Vec3 operator*(double s) const { return {x * s, y * s, z * s}; }
  Vec3 operator-() const { return {-x, -y, -z}; }
  Vec3& operator+=(const Vec3& o) { x += o.x; y += o.y; z += o.z; return *this; }
};
inline double dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double norm(const Vec3& a) { return std::sqrt(dot(a, a)); }
inline Vec3 normalized(const Vec3& a) {
  const double n = norm(a);
  return n > 0 ? a * (1.0 / n) : a;
}

/// Rotation (columns = the rotated frame's axes) and translation.
struct Pose {
  Vec3 cx{1, 0, 0}, cy{0, 1, 0}, cz{0, 0, 1};
  Vec3 t{0, 0, 0};
  Vec3 rotate(const Vec3& v) const { return cx * v.x + cy * v.y + cz * v.z; }
  Vec3 apply(const Vec3& p) const { return rotate(p) + t; }
  Vec3 rotateInverse(const Vec3& v) const { return {dot(cx, v), dot(cy, v), dot(cz, v)}; }
  Vec3 applyInverse(const Vec3& p) const { return rotateInverse(p - t); }
};

inline double clamp01(double v) { return v < 0 ? 0 : (v > 1 ? 1 : v); }
inline double smoothstep(double a, double b, double x) {
  const double t = clamp01((x - a) * (1.0 / (b - a)));  // a, b are constants: no division
  return t * t * (3 - 2 * t);
}
inline double lerp(double a, double b, double t) { return a + (b - a) * t; }
inline Vec3 lerp(const Vec3& a, const Vec3& b, double t) { return a + (b - a) * t; }

/// x^n for integer n >= 0 by binary exponentiation (Blinn-Phong exponents).
inline double powi(double x, int n) {
  double r = 1.0;
  while (n > 0) {
    if (n & 1) r *= x;
    x *= x;
    n >>= 1;
  }
  return r;
}

/// splitmix64: seeds streams from (seed, purpose) deterministically.
inline uint64_t mix64(uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}
inline uint32_t subSeed(uint64_t seed, uint64_t purpose) {
  return static_cast<uint32_t>(mix64(seed * 0x100000001b3ull + purpose) >> 32);
}

inline uint32_t hash2(int32_t x, int32_t y, uint32_t seed) {
  uint32_t h = seed ^ (static_cast<uint32_t>(x) * 0x8da6b343u) ^ (static_cast<uint32_t>(y) * 0xd8163841u);
  h ^= h >> 16;
  h *= 0x7feb352du;
  h ^= h >> 15;
  h *= 0x846ca68bu;
  h ^= h >> 16;
  return h;
}

/// Uniform double in [0, 1) from a 64-bit generator, identical everywhere.
inline double uniform01(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

/// Standard normal samples by Marsaglia's polar method on mt19937_64
/// (portable, unlike std::normal_distribution; no trigonometry).
class GaussianRng {
 public:
  explicit GaussianRng(uint64_t seed) : rng_(seed) {}
  double operator()() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double a, b, s;
    do {
      a = 2.0 * uniform01(rng_) - 1.0;
      b = 2.0 * uniform01(rng_) - 1.0;
      s = a * a + b * b;
    } while (s >= 1.0 || s == 0.0);
    const double k = std::sqrt(-2.0 * std::log(s) / s);
    spare_ = b * k;
    has_spare_ = true;
    return a * k;
  }
  double uniform() { return uniform01(rng_); }

 private:
  std::mt19937_64 rng_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

/// 2-D gradient (Perlin) noise with analytic derivatives, value roughly in
/// [-1, 1]. Lattice coordinates; `period` > 0 wraps the second coordinate
/// (for textures around a tube).
struct NoiseValue {
  double v, dx, dy;
};

inline const double* gradientTable() {
  // 16 unit gradients at angles 2 pi (i + 0.37) / 16: off the axes, so no
  // lattice direction dominates. Literal values: no initialisation guard.
  static constexpr double g[32] = {
      0.98946270760001842, 0.1447879493218977,
      0.85873639432325055, 0.51241760807441306,
      0.59727524947556698, 0.80203633107478312,
      0.24488436220884752, 0.96955229314646352,
      -0.1447879493218977, 0.98946270760001842,
      -0.51241760807441272, 0.85873639432325066,
      -0.802036331074783, 0.5972752494755672,
      -0.96955229314646352, 0.24488436220884779,
      -0.98946270760001853, -0.14478794932189742,
      -0.85873639432325077, -0.51241760807441272,
      -0.59727524947556765, -0.80203633107478267,
      -0.24488436220884785, -0.96955229314646341,
      0.14478794932189692, -0.98946270760001853,
      0.51241760807441272, -0.85873639432325077,
      0.80203633107478267, -0.59727524947556765,
      0.96955229314646341, -0.24488436220884791,
  };
  return g;
}

/// floor() as an integer, inline (the library call is not, on baseline
/// x86-64); |x| < 2^31.
inline int ifloor(double x) {
  const int i = static_cast<int>(x);
  return x < i ? i - 1 : i;
}

/// atan2 by a minimax polynomial (|error| < 2e-5 rad), inline and the same on
/// every platform; result in [0, 2 pi). Scaled to be exact at |x| = |y|, so
/// the octant swap there leaves no seam: continuous everywhere but at 2 pi.
inline double atan2Positive(double y, double x) {
  constexpr double c1 = 0.99997726, c3 = -0.33262347, c5 = 0.19354346, c7 = -0.11643287, c9 = 0.05265332,
                   c11 = -0.01172120;
  constexpr double kAtOne = c1 + c3 + c5 + c7 + c9 + c11;  // the polynomial at 1
  constexpr double kScale = 0.25 * kPi / kAtOne;
  const double ax = std::fabs(x), ay = std::fabs(y);
  const double mx = ax > ay ? ax : ay, mn = ax > ay ? ay : ax;
  if (mx == 0) return 0.0;
  const double a = mn / mx, s = a * a;
  double r = kScale * a * (c1 + s * (c3 + s * (c5 + s * (c7 + s * (c9 + s * c11)))));
  if (ay > ax) r = 0.5 * kPi - r;
  if (x < 0) r = kPi - r;
  if (y < 0) r = 2 * kPi - r;
  return r >= 2 * kPi ? r - 2 * kPi : r;
}

inline NoiseValue gradientNoise(double x, double y, uint32_t seed, int period = 0) {
  int32_t ix = ifloor(x), iy = ifloor(y);
  const double px = x - ix, py = y - iy;
  int32_t iy1 = iy + 1;
  if (period > 0) {
    if (iy < 0 || iy >= period) {
      iy %= period;
      if (iy < 0) iy += period;
    }
    iy1 = iy + 1 == period ? 0 : iy + 1;
  }
  const double* g = gradientTable();
  const double* ga = g + 2 * (hash2(ix, iy, seed) & 15u);
  const double* gb = g + 2 * (hash2(ix + 1, iy, seed) & 15u);
  const double* gc = g + 2 * (hash2(ix, iy1, seed) & 15u);
  const double* gd = g + 2 * (hash2(ix + 1, iy1, seed) & 15u);
  const double va = ga[0] * px + ga[1] * py;
  const double vb = gb[0] * (px - 1) + gb[1] * py;
  const double vc = gc[0] * px + gc[1] * (py - 1);
  const double vd = gd[0] * (px - 1) + gd[1] * (py - 1);
  const double ux = px * px * px * (px * (px * 6 - 15) + 10);
  const double uy = py * py * py * (py * (py * 6 - 15) + 10);
  const double dux = 30 * px * px * (px * (px - 2) + 1);
  const double duy = 30 * py * py * (py * (py - 2) + 1);
  const double k = va - vb - vc + vd;
  NoiseValue n;
  const double s = 1.4;  // peak of 2-D gradient noise is about 1/sqrt(2)
  n.v = s * (va + ux * (vb - va) + uy * (vc - va) + ux * uy * k);
  n.dx = s * (ga[0] + ux * (gb[0] - ga[0]) + uy * (gc[0] - ga[0]) + ux * uy * (ga[0] - gb[0] - gc[0] + gd[0]) +
              dux * (uy * k + (vb - va)));
  n.dy = s * (ga[1] + ux * (gb[1] - ga[1]) + uy * (gc[1] - ga[1]) + ux * uy * (ga[1] - gb[1] - gc[1] + gd[1]) +
              duy * (ux * k + (vc - va)));
  return n;
}

/// Uniform cubic B-spline basis weights and their derivatives at t in [0, 1).
inline void bsplineWeights(double t, double w[4], double dw[4]) {
  const double t2 = t * t, t3 = t2 * t, it = 1 - t;
  w[0] = it * it * it / 6.0;
  w[1] = (3 * t3 - 6 * t2 + 4) / 6.0;
  w[2] = (-3 * t3 + 3 * t2 + 3 * t + 1) / 6.0;
  w[3] = t3 / 6.0;
  dw[0] = -it * it / 2.0;
  dw[1] = (9 * t2 - 12 * t) / 6.0;
  dw[2] = (-9 * t2 + 6 * t + 3) / 6.0;
  dw[3] = t2 / 2.0;
}

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

}  // namespace detail
}  // namespace synth
}  // namespace bdis
