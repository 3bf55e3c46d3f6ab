// The scenes of the synthetic renderer: surfaces, their motion, textures and
// the ray caster. Internal header; the public API is synthetic_scene.hpp.
//
// Conventions: "world" is the frame the geometry is defined in. For the
// tissue scene it is the left camera's optical frame (the tissue moves, the
// rig stays); for the tube it is the tube's frame (the rig moves along the
// tube). Rays are o + t d with d = R (x', y', 1) for camera-frame direction
// (x', y', 1), so t is the depth Z in the camera frame (the same for both
// cameras of the rectified rig).
#pragma once

#include <memory>
#include <vector>

#include "bdis_stereo/synthetic_scene.hpp"
#include "synth_math.hpp"

namespace bdis {
namespace synth {
namespace detail {

/// A capsule: segment a-b (b = tip) with a radius.
struct Capsule {
  Vec3 a, b;
  double radius = 0;
  /// Smallest t in (tmin, tmax) where o + t d enters the capsule; -1 if none.
  double intersect(const Vec3& o, const Vec3& d, double tmin, double tmax) const;
  Vec3 normal(const Vec3& p) const;
  /// Distance from the tip along the axis (m) and angle around it.
  void surfaceCoords(const Vec3& p, double& s, double& phi) const;
};

/// Everything that changes from frame to frame.
struct FrameState {
  Pose rig;                  ///< left camera optical frame -> world
  double ox = 0, oy = 0;     ///< tissue: material offset (camera pan over the tissue), m
  double breath = 0;         ///< tissue: breathing phase value in [-1, 1]
  bool has_tool = false;
  Capsule tool;              ///< world frame
};

/// Appearance of a surface point before lighting.
struct Material {
  Vec3 albedo;               ///< linear RGB
  double ks_sharp = 0;       ///< sharp specular lobe (wet highlights) ...
  int m_sharp = 1;           ///< ... and its Blinn-Phong exponent
  double ks_broad = 0;       ///< broad sheen
  int m_broad = 1;
  double bump_u = 0, bump_v = 0;     ///< shading-normal slopes along the two tangents
  double patch = 0;          ///< 1 inside the textureless patch
};

/// Uniform cubic B-spline over a regular grid; clamped outside it in u,
/// clamped or periodic in v.
class BSpline2 {
 public:
  BSpline2() = default;
  BSpline2(int nu, int nv, double u0, double v0, double hu, double hv, bool periodic_v);
  double& at(int i, int j) { return c_[static_cast<size_t>(i) * nv_ + j]; }
  int nu() const { return nu_; }
  int nv() const { return nv_; }
  /// Value and derivatives w.r.t. u and v.
  double eval(double u, double v, double* du = nullptr, double* dv = nullptr) const;

 private:
  int nu_ = 0, nv_ = 0;
  double u0_ = 0, v0_ = 0, hu_ = 1, hv_ = 1;
  bool periodic_v_ = false;
  std::vector<double> c_;
};

/// A surface given implicitly by F(p) > 0 in free space, F = 0 on the
/// surface, with |grad F| <= lipschitz() wherever a ray can reach.
class Surface {
 public:
  virtual ~Surface() = default;
  virtual double F(const Vec3& p, const FrameState& fs) const = 0;
  /// Unit normal pointing into free space, and texture coordinates (m) with
  /// their tangent directions.
  virtual void local(const Vec3& p, const FrameState& fs, Vec3& normal, double& u, double& v,
                     Vec3& tu, Vec3& tv) const = 0;
  double lipschitz() const { return lipschitz_; }
  /// Optional exact shortcut for the first zero along o + t d in [t0, tmax]
  /// (t0 proven free): its t, -1 if none by tmax, or kNoShortcut when the
  /// surface cannot prove a unique zero for this ray.
  static constexpr double kNoShortcut = -2.0;
  /// `hint`: a guess of the root (a neighbour's), only a starting point.
  virtual double monotoneRoot(const Vec3&, const Vec3&, const FrameState&, double, double, double) const {
    return kNoShortcut;
  }
  /// Period of the v texture coordinate (m), 0 = none.
  double periodV() const { return period_v_; }

 protected:
  double lipschitz_ = 1.0;
  double period_v_ = 0.0;
};

/// Curved tissue height field Z = h(X + ox, Y + oy) + breathing.
class TissueSurface : public Surface {
 public:
  explicit TissueSurface(uint64_t seed);
  double F(const Vec3& p, const FrameState& fs) const override;
  void local(const Vec3& p, const FrameState& fs, Vec3& normal, double& u, double& v, Vec3& tu,
             Vec3& tv) const override;
  /// Height and its gradient in material coordinates.
  double height(double u, double v, double breath, double* hu, double* hv) const;
  double monotoneRoot(const Vec3& o, const Vec3& d, const FrameState& fs, double t0, double tmax,
                      double hint) const override;

 private:
  BSpline2 bumps_;
  std::vector<double> ring_slope_;  // max |grad h| within (k + 1) * 5 mm of the origin
  double height_max_ = 0;
  double z0_, tilt_u_, tilt_v_, curvature_;
  double breath_amp_, breath_u_, breath_v_, breath_r2_;
};

/// Colon-like tube along world z with a meandering centreline, haustral folds
/// and taeniae; closes at its far end so every ray hits.
class TubeSurface : public Surface {
 public:
  explicit TubeSurface(uint64_t seed);
  double F(const Vec3& p, const FrameState& fs) const override;
  void local(const Vec3& p, const FrameState& fs, Vec3& normal, double& u, double& v, Vec3& tu,
             Vec3& tv) const override;
  /// Centreline (x, y) at z and its derivative.
  void centre(double z, double& cx, double& cy, double* dcx = nullptr, double* dcy = nullptr) const;
  double radius0() const { return r0_; }
  /// grad F (points towards the axis); optionally the angle theta of p.
  Vec3 gradient(const Vec3& p, double* theta = nullptr) const;

 private:
  BSpline2 radius_;  // over (z, theta)
  double r0_;
  double ax_, kx_, px_, ay_, ky_, py_;  // centreline: a * sin(k z + p)
  std::vector<double> c_;               // per knot: cx, cx', cy, cy'
  double c_z0_ = 0, c_h_ = 0.001;
};

/// Procedural textures (linear RGB albedo, bump slopes), band-limited by the
/// pixel footprint `fp` (m per pixel at the point's depth).
struct TissueTexture {
  uint32_t seed = 1;
  double period_v = 0;          ///< wrap of the v coordinate (tube), 0 = none
  bool patch = false;           ///< albedo-flat disk
  double patch_u = 0, patch_v = 0, patch_r = 0;
  Material eval(double u, double v, double fp, bool specular) const;
};
Material instrumentMaterial(double s, double phi, double radius, double fp, uint32_t seed, bool specular);

/// One scene: surfaces, motion and materials, built from a SceneConfig.
class Scene {
 public:
  explicit Scene(const SceneConfig& config);
  const SceneConfig& config() const { return cfg_; }
  FrameState frameState(int index) const;
  const Surface& surface() const { return *surface_; }

  /// First hit along o + t d for t in (tmin, tmax]. `t_free` <= the first
  /// surface zero is a start the caller has proven free (cone marching).
  struct Hit {
    double t = -1;
    int label = kLabelNone;
  };
  /// `hint`: a guess of the depth (a neighbour's hit), only used to start
  /// root finding where the surface has proven a unique root.
  Hit intersect(const Vec3& o, const Vec3& d, const FrameState& fs, double t_free, double tmax,
                double hint = -1) const;
  /// First zero of the surface (not the tool) from t0 on; -1 if none by tmax.
  double traceSurface(const Vec3& o, const Vec3& d, const FrameState& fs, double t0, double tmax,
                      double hint = -1) const;
  /// Cone march: a t up to which no ray of the cone (axis o + t dc, radius r t
  /// around it) meets the surface.
  double coneFreeT(const Vec3& o, const Vec3& dc, double r, const FrameState& fs, double tmax) const;

  /// Material and shading normal at a hit point; `fp` the pixel footprint
  /// (m) at the point's depth, `rig_centre` the light / rig centre.
  Material material(const Vec3& p, int label, const FrameState& fs, double fp, const Vec3& rig_centre,
                    Vec3& normal) const;
  /// True when the segment p -> light is blocked by the tool.
  bool shadowed(const Vec3& p, const Vec3& light, const FrameState& fs) const;

  double maxDepth() const { return max_depth_; }
  /// Light power (W-like units: irradiance = power * spot / r^2).
  double lightPower() const { return light_power_; }

 private:
  SceneConfig cfg_;
  std::unique_ptr<Surface> surface_;
  TissueTexture texture_;
  double max_depth_ = 0.5;
  double light_power_ = 0.0018;
  double tool_radius_ = 0.0025;
  uint32_t tool_seed_ = 1;
  double tube_start_z_ = 0;
};

}  // namespace detail
}  // namespace synth
}  // namespace bdis
