// The ground truth of the synthetic scenes is exact: geometric re-projection
// into the right view, photometric consistency of the GT-warped right image
// on diffuse noise-free renders, and unknown exactly where it must be.
#include <gtest/gtest.h>

#include <filesystem>

#include "bdis_stereo/evaluation.hpp"
#include "synth_test_util.hpp"

namespace {

using namespace synth_test;
using bdis::synth::RayHit;

struct Reprojection {
  int checked = 0;
  int inconsistent = 0;  // right ray through (x - d, y) hits at another depth or label
  double max_rel = 0;    // max |Z_right - Z_gt| / Z_gt
};

// For every `step`-th pixel with ground truth: the right camera's ray through
// (x - d, y) must first hit the surface at depth fx * B / d, on the same object.
Reprojection reproject(const SceneConfig& cfg, int index, int step, float gt_offset = 0.f) {
  const SyntheticFrame& f = cachedFrame(cfg, index);
  const SyntheticRenderer renderer(cfg);
  const bdis::StereoCamera cam = cfg.camera();
  Reprojection r;
  for (int y = 0; y < f.gt.rows; y += step) {
    for (int x = 0; x < f.gt.cols; x += step) {
      if (!(f.gt.at<float>(y, x) > 0.f)) continue;
      const float d = f.gt.at<float>(y, x) + gt_offset;
      ++r.checked;
      const double z = cam.fx * cam.baseline / d;
      const cv::Vec3d dir((x - d - cam.cx) / cam.fx, (y - cam.cy) / cam.fy, 1.0);
      const RayHit h = renderer.castRay(index, cv::Vec3d(cam.baseline, 0, 0), dir);
      const double rel = h.hit ? std::fabs(h.t - z) / z : 1.0;
      r.max_rel = std::max(r.max_rel, rel);
      // 1e-4 of the depth is 0.01 px of disparity at d = 100 (below the
      // 1/256 px of the 16-bit files); grazing rays at silhouettes reach
      // 2e-5 because the float32 GT moves the right ray by ~1e-5 px.
      if (rel > 1e-4 || h.label != f.label.at<uchar>(y, x)) ++r.inconsistent;
    }
  }
  return r;
}

TEST(GroundTruth, ReprojectsToTheSameSurfacePointInTheRightView) {
  // Tissue with instrument and borders (the sample), and the tube.
  // Measured: 0 inconsistent of ~30k each; max relative depth error 2e-7
  // (sample) and 2e-5 (tube, grazing rays on fold and tool silhouettes).
  for (const char* name : {"sample", "tube"}) {
    const Reprojection r = reproject(variant(name), 2, 3);
    std::printf("%s: %d pixels re-projected, %d inconsistent, max relative depth error %.2e\n", name, r.checked,
                r.inconsistent, r.max_rel);
    EXPECT_GT(r.checked, 20000) << name;
    EXPECT_EQ(r.inconsistent, 0) << name;
    EXPECT_LT(r.max_rel, 1e-4) << name;
    // Sensitivity: with the GT off by 0.05 px the check fails nearly everywhere.
    const Reprojection off = reproject(variant(name), 2, 9, 0.05f);
    EXPECT_GT(off.inconsistent, 0.95 * off.checked) << name;
  }
}

TEST(GroundTruth, IsUnknownWhereTheRightViewIsOccludedOrOutside) {
  // Converse of the re-projection: wherever the left pixel's surface point is
  // hidden from the right camera (here: behind the instrument) or projects
  // outside the right image or into its black border, the GT must be 0.
  const SceneConfig cfg = variant("sample");
  const SyntheticFrame& f = cachedFrame(cfg, 0);
  const SyntheticRenderer renderer(cfg);
  const bdis::StereoCamera cam = cfg.camera();
  int occluded = 0, outside = 0, violations = 0;
  for (int y = 0; y < f.gt.rows; y += 2) {
    for (int x = 0; x < f.gt.cols; x += 2) {
      const float z = f.depth.at<float>(y, x);
      if (!(z > 0) || f.label.at<uchar>(y, x) == bdis::synth::kLabelNone) continue;
      const double d = cam.fx * cam.baseline / z;
      const double xr = x - d;
      const bool known = f.gt.at<float>(y, x) > 0.f;
      const int xl = static_cast<int>(std::floor(xr));
      if (xr < 0 || xl + 1 >= f.right.cols || f.right.at<cv::Vec3b>(y, xl) == cv::Vec3b(0, 0, 0) ||
          f.right.at<cv::Vec3b>(y, xl + 1) == cv::Vec3b(0, 0, 0)) {
        ++outside;
        if (known) ++violations;
        continue;
      }
      const cv::Vec3d dir((xr - cam.cx) / cam.fx, (y - cam.cy) / cam.fy, 1.0);
      const RayHit h = renderer.castRay(0, cv::Vec3d(cam.baseline, 0, 0), dir);
      if (h.hit && h.t < z * (1.0 - 1e-4)) {
        ++occluded;
        if (known) ++violations;
      }
    }
  }
  std::printf("sample frame 0: %d occluded, %d outside the right view, %d with GT\n", occluded, outside, violations);
  EXPECT_GT(occluded, 200);  // the instrument hides tissue from the right camera
  EXPECT_GT(outside, 200);   // a band on the left and the black borders
  EXPECT_EQ(violations, 0);
}

TEST(GroundTruth, IsUnknownInTheBlackBordersAndOnlyThere) {
  const SyntheticFrame& f = cachedFrame(variant("sample"), 0);
  int border = 0, border_with_gt = 0, inner_unknown = 0, inner = 0;
  for (int y = 0; y < f.gt.rows; ++y) {
    for (int x = 0; x < f.gt.cols; ++x) {
      const bool black = f.left.at<cv::Vec3b>(y, x) == cv::Vec3b(0, 0, 0);
      if (black) {
        ++border;
        if (f.gt.at<float>(y, x) > 0.f) ++border_with_gt;
      } else if (x > 130 && x < f.gt.cols - 40 && y > 20 && y < f.gt.rows - 20) {
        ++inner;
        if (!(f.gt.at<float>(y, x) > 0.f)) ++inner_unknown;
      }
    }
  }
  // Measured: the borders are ~4% of the image; in the interior only the
  // instrument's occlusion shadow and its edges are unknown (~2%).
  std::printf("border %d px (%d with GT); interior %d px, %.2f%% unknown\n", border, border_with_gt, inner,
              100.0 * inner_unknown / inner);
  EXPECT_GT(border, 0.02 * f.gt.total());
  EXPECT_EQ(border_with_gt, 0);
  EXPECT_LT(inner_unknown, 0.05 * inner);
}

TEST(GroundTruth, WarpedRightMatchesLeftOnDiffuseNoiseFreeRenders) {
  // Diffuse, noise-free: the right image sampled at x - gt reproduces the left
  // image up to bilinear interpolation (and the box filter of supersampled
  // edge pixels). Measured: tissue mean 0.12 grey levels, p99 1; tube mean
  // 0.18, p99 2. A GT one pixel off raises the mean ~4-fold (the tissue is
  // smooth, low-contrast mucosa).
  for (const char* name : {"diffuse", "tube"}) {
    SceneConfig cfg = variant(name, 0.0);
    cfg.lighting = bdis::synth::Lighting::Diffuse;
    const SyntheticFrame& f = cachedFrame(cfg, 1);
    const cv::Mat known = knownMask(f);
    const std::vector<float> e = valuesWhere(photometricError(f), known);
    const std::vector<float> e_off = valuesWhere(photometricError(f, 1.0f), known);
    std::printf("%s: %zu px, |left - warped right| mean %.3f p99 %.1f grey; GT + 1 px: mean %.3f\n", name, e.size(),
                mean(e), quantile(e, 0.99), mean(e_off));
    EXPECT_GT(e.size(), 0.8 * f.gt.total()) << name;
    EXPECT_LT(mean(e), 0.3) << name;
    EXPECT_LE(quantile(e, 0.99), 3.0) << name;
    EXPECT_GT(mean(e_off), 2.5 * mean(e)) << name;  // the check notices a wrong GT
  }
}

TEST(GroundTruth, DisparitiesAreInARealisticRange) {
  // 640x480, fx = 520 px, B = 5 mm: tissue 4.5-6.5 cm away, instrument
  // 3.3-4 cm; colon wall 2.3-25 cm, forceps 1.8-4.3 cm. Measured percentiles (1%, 99%):
  // sample (42, 78) px, tube (10, 129) px.
  struct Range {
    const char* name;
    double lo, hi;
  };
  for (const Range& r : {Range{"sample", 20, 120}, Range{"tube", 5, 150}}) {
    const SyntheticFrame& f = cachedFrame(variant(r.name), 0);
    const std::vector<float> d = valuesWhere(f.gt, knownMask(f));
    const double p1 = quantile(d, 0.01), p99 = quantile(d, 0.99);
    std::printf("%s: %zu px with GT (%.1f%%), disparity p1 %.1f p99 %.1f max %.1f\n", r.name, d.size(),
                100.0 * d.size() / f.gt.total(), p1, p99, *std::max_element(d.begin(), d.end()));
    EXPECT_GT(d.size(), 0.75 * f.gt.total()) << r.name;
    EXPECT_GE(p1, r.lo) << r.name;
    EXPECT_LE(p99, r.hi) << r.name;
    EXPECT_GT(p99 - p1, 20) << r.name;  // real depth variation, not a plane
  }
}

}  // namespace
