// The texture centroid correction (texture_centroid_correction.hpp): an
// estimate moves by the surface's slope times the offset of its box's
// texture centroid, so a box textured on one side pulls it back to the
// pixel's own disparity; uniform texture, no texture, holes and small maps
// leave it; a depth jump moves it by the limit at most, and never below 0.
#include <algorithm>

#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "bdis_stereo/matcher.hpp"
#include "pyramid.hpp"
#include "texture_centroid_correction.hpp"

namespace {

using bdis::kNoDisparity;
using bdis::detail::PyramidLevel;
using bdis::detail::TextureCentroidCorrection;

constexpr int kW = 48, kH = 40, kPatch = 8;  // boxes of 9 x 9, slopes over 4 px each way
constexpr float kLimit = 1.f;

/// A level whose left image has horizontal gradient `gx(x, y)`, all valid.
template <class Gradient>
PyramidLevel levelWith(Gradient gx) {
  PyramidLevel level;
  level.width = kW;
  level.height = kH;
  level.left_gx.create(kH, kW);
  level.left_valid.create(kH, kW);
  level.left_valid.setTo(1);
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) level.left_gx(y, x) = gx(x, y);
  }
  return level;
}

cv::Mat1f plane(float a, float b, float c) {
  cv::Mat1f d(kH, kW);
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) d(y, x) = a + b * static_cast<float>(x) + c * static_cast<float>(y);
  }
  return d;
}

cv::Mat1f corrected(const PyramidLevel& level, cv::Mat1f disparity) {
  TextureCentroidCorrection correction;
  correction.apply(level, kPatch, kLimit, disparity);
  return disparity;
}

TEST(TextureCentroidCorrection, UniformTextureLeavesTheInteriorOfASlantedPlane) {
  const cv::Mat1f d = plane(10.f, 0.2f, 0.1f);
  const cv::Mat1f out = corrected(levelWith([](int, int) { return 5.f; }), d.clone());
  for (int y = 4; y < kH - 4; ++y) {
    for (int x = 4; x < kW - 4; ++x) ASSERT_NEAR(out(y, x), d(y, x), 1e-4f) << x << ", " << y;
  }
}

// Texture in columns 20.. only: at x = 18 the box (14..22) has its texture
// centred on column 21, 3 px right, where a slope of 0.2 px per px puts the
// disparity 0.6 px higher: the estimate, read there, comes back down by 0.6.
TEST(TextureCentroidCorrection, TextureOnOneSideMovesAlongTheSlopeInX) {
  const cv::Mat1f d = plane(10.f, 0.2f, 0.f);
  const cv::Mat1f out = corrected(levelWith([](int x, int) { return x >= 20 ? 5.f : 0.f; }), d.clone());
  for (int y = 4; y < kH - 4; ++y) {
    ASSERT_NEAR(out(y, 18), d(y, 18) - 0.6f, 1e-4f) << "row " << y;
    ASSERT_NEAR(out(y, 17), d(y, 17) - 0.2f * 3.5f, 1e-4f) << "row " << y;  // texture 20, 21: centred 3.5 px right
    ASSERT_NEAR(out(y, 30), d(y, 30), 1e-4f) << "row " << y;               // all textured: centred on the pixel
  }
}

// The same along the rows: texture in rows 20.. only, slope 0.1 px per row;
// at y = 17 the box (13..21) has it centred on row 20.5, 3.5 rows below.
TEST(TextureCentroidCorrection, TextureOnOneSideMovesAlongTheSlopeInY) {
  const cv::Mat1f d = plane(10.f, 0.f, 0.1f);
  const cv::Mat1f out = corrected(levelWith([](int, int y) { return y >= 20 ? 3.f : 0.f; }), d.clone());
  for (int x = 4; x < kW - 4; ++x) ASSERT_NEAR(out(17, x), d(17, x) - 0.35f, 1e-4f) << "column " << x;
}

// Within a patch side of the image's side the box lies against it, as the
// patches do: at x = 1 it spans columns 0..8, so texture in columns 6..8
// (centred on 7, 6 px right) counts, which a box clipped to 0..5 would miss.
// The slope is the one 3 r = 12 columns in (box means at 8 and 16, both
// whole), 0.15: the estimate moves by 0.9.
TEST(TextureCentroidCorrection, BoxesLieAgainstTheImageSides) {
  const cv::Mat1f d = plane(10.f, 0.15f, 0.f);
  const cv::Mat1f out = corrected(levelWith([](int x, int) { return x >= 6 && x <= 8 ? 4.f : 0.f; }), d.clone());
  for (int y = 4; y < kH - 4; ++y) ASSERT_NEAR(out(y, 1), d(y, 1) - 0.9f, 1e-4f) << "row " << y;
}

// What the fusion leaves by the sides of a slanted plane: within a half
// patch (4 px) of a side every patch covering a pixel lies further in, so
// the estimates there stay at the value 4 px in. Uniform texture centres each
// box (against the side) 4 - k px in from the pixel k px from the side, and
// the slope from box means clear of that strip moves each estimate back onto
// the plane, corners included. (A slope from the box means beside the side
// sees the flat strip: at x = 0 a one-sided slope from the box means at 0
// and 4 is 0.042 of the 0.15.)
TEST(TextureCentroidCorrection, EstimatesFlattenedBySideCoverageReturnToThePlane) {
  const cv::Mat1f truth = plane(10.f, 0.15f, 0.05f);
  cv::Mat1f d(kH, kW);
  const int r = kPatch / 2;
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) d(y, x) = truth(std::clamp(y, r, kH - 1 - r), std::clamp(x, r, kW - 1 - r));
  }
  const cv::Mat1f out = corrected(levelWith([](int, int) { return 5.f; }), d.clone());
  EXPECT_GT(cv::norm(d, truth, cv::NORM_INF), 0.7);  // 0.15 x 4 + 0.05 x 4 at the corners
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) ASSERT_NEAR(out(y, x), truth(y, x), 1e-4f) << x << ", " << y;
  }
}

TEST(TextureCentroidCorrection, NoTextureAndHolesStayAsTheyAre) {
  cv::Mat1f d = plane(10.f, 0.2f, 0.1f);
  d(20, 20) = kNoDisparity;
  const cv::Mat1f flat = corrected(levelWith([](int, int) { return 0.f; }), d.clone());
  EXPECT_EQ(cv::norm(flat, d, cv::NORM_INF), 0.0);
  const cv::Mat1f textured = corrected(levelWith([](int x, int) { return x >= 20 ? 5.f : 0.f; }), d.clone());
  EXPECT_EQ(textured(20, 20), kNoDisparity);
}

// A depth jump at column 30, texture only beyond it: the box means' slope
// across the jump is no surface's, and the move stops at the limit; an
// estimate near 0 stops at 0, not below (below 0 would read as a hole).
TEST(TextureCentroidCorrection, ADepthJumpMovesByTheLimitAndNeverBelowZero) {
  for (const float near_side : {10.f, 0.25f}) {
    cv::Mat1f d(kH, kW);
    for (int y = 0; y < kH; ++y) {
      for (int x = 0; x < kW; ++x) d(y, x) = x < 30 ? near_side : 40.f;
    }
    const cv::Mat1f out = corrected(levelWith([](int x, int) { return x >= 30 ? 5.f : 0.f; }), d.clone());
    for (int y = 4; y < kH - 4; ++y) {
      ASSERT_EQ(out(y, 28), std::max(near_side - kLimit, 0.f)) << "row " << y;
      ASSERT_GE(out(y, 29), 0.f);
    }
  }
}

TEST(TextureCentroidCorrection, MapsSmallerThanABoxAreLeftAsTheyAre) {
  PyramidLevel level;
  level.left_gx = cv::Mat1f(6, 40, 5.f);
  level.left_valid = cv::Mat1b(6, 40, uchar{1});
  cv::Mat1f d(6, 40, 7.f);
  TextureCentroidCorrection correction;
  correction.apply(level, kPatch, kLimit, d);
  EXPECT_EQ(cv::countNonZero(d != 7.f), 0);
}

}  // namespace
