// Disparity to depth and 3-D points for a rectified pair.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include <opencv2/core.hpp>

#include "bdis_stereo/geometry.hpp"
#include "bdis_stereo/matcher.hpp"
#include "test_images.hpp"

namespace {

using bdis::kNoDisparity;
using bdis::StereoCamera;
using bdis_test::contains;
using bdis_test::invalidArgumentMessage;

const float kNaNf = std::numeric_limits<float>::quiet_NaN();

// Relative tolerance for float outputs of double formulas.
void expectRel(double actual, double expected, double rel = 1e-6) {
  EXPECT_NEAR(actual, expected, rel * std::fabs(expected)) << "expected " << expected;
}

TEST(GeometryCamera, SymmetricSetsBothPrincipalPoints) {
  const StereoCamera c = StereoCamera::symmetric(700, 690, 320.5, 240.25, 0.12);
  EXPECT_EQ(c.fx, 700);
  EXPECT_EQ(c.fy, 690);
  EXPECT_EQ(c.cx, 320.5);
  EXPECT_EQ(c.cy, 240.25);
  EXPECT_EQ(c.cx_right, 320.5);
  EXPECT_EQ(c.baseline, 0.12);
  EXPECT_NO_THROW(c.validate());
}

TEST(GeometryDepth, IsFxTimesBaselineOverDisparity) {
  const StereoCamera c = StereoCamera::symmetric(700, 690, 320, 240, 0.12);
  for (float d : {0.25f, 1.f, 7.5f, 35.f, 100.125f, 640.f}) {
    SCOPED_TRACE(d);
    EXPECT_FLOAT_EQ(c.depth(d), static_cast<float>(700.0 * 0.12 / d));
  }
  // Hand values: 700 * 0.12 = 84.
  EXPECT_FLOAT_EQ(c.depth(42.f), 2.f);
  EXPECT_FLOAT_EQ(c.depth(84.f), 1.f);
  EXPECT_FLOAT_EQ(c.depth(8.4f), 10.f);
}

TEST(GeometryDepth, NaNWithoutEstimateOrAtInfinity) {
  const StereoCamera c = StereoCamera::symmetric(700, 700, 320, 240, 0.12);
  EXPECT_TRUE(std::isnan(c.depth(kNoDisparity)));
  EXPECT_TRUE(std::isnan(c.depth(-0.5f)));
  EXPECT_TRUE(std::isnan(c.depth(kNaNf)));
  EXPECT_TRUE(std::isnan(c.depth(0.f)));  // d = cx - cx_right = 0: infinitely far
  EXPECT_FALSE(std::isnan(c.depth(1e-3f)));
}

TEST(GeometryDepth, PrincipalPointOffsetShiftsInfinity) {
  // cx - cx_right = 10: disparity 10 is at infinity.
  StereoCamera c = StereoCamera::symmetric(700, 700, 320, 240, 0.12);
  c.cx_right = 310;
  EXPECT_TRUE(std::isnan(c.depth(10.f)));
  EXPECT_TRUE(std::isnan(c.depth(9.f)));
  EXPECT_TRUE(std::isnan(c.depth(0.f)));
  EXPECT_TRUE(std::isnan(c.depth(kNoDisparity)));
  EXPECT_FLOAT_EQ(c.depth(10.5f), static_cast<float>(84.0 / 0.5));
  EXPECT_FLOAT_EQ(c.depth(30.f), static_cast<float>(84.0 / 20.0));
  EXPECT_FLOAT_EQ(c.depth(94.f), 1.f);

  // cx_right > cx: zero disparity is at finite depth.
  c.cx_right = 330;
  EXPECT_FLOAT_EQ(c.depth(0.f), static_cast<float>(84.0 / 10.0));
  EXPECT_FLOAT_EQ(c.depth(5.f), static_cast<float>(84.0 / 15.0));
  EXPECT_TRUE(std::isnan(c.depth(kNoDisparity)));
}

cv::Mat sampleDisparity() {
  // 3 x 5, including no estimate, zero, NaN and ordinary values.
  return (cv::Mat_<float>(3, 5) << 1.f, 7.5f, kNoDisparity, 0.f, 42.f,  //
          12.25f, kNaNf, 3.f, 100.f, 0.5f,                              //
          -3.f, 64.f, 8.f, 16.f, 2.f);
}

TEST(GeometryDepth, DisparityToDepthIsPerPixelDepth) {
  StereoCamera c = StereoCamera::symmetric(700, 650, 2.5, 1.25, 0.12);
  c.cx_right = 1.5;  // infinity at d = 1
  const cv::Mat d = sampleDisparity();
  cv::Mat z;
  bdis::disparityToDepth(d, c, z);
  ASSERT_EQ(z.type(), CV_32FC1);
  ASSERT_EQ(z.size(), d.size());
  int valid = 0;
  for (int y = 0; y < d.rows; ++y) {
    for (int x = 0; x < d.cols; ++x) {
      const float v = d.at<float>(y, x);
      const float zz = z.at<float>(y, x);
      if (v >= 0.f && v > 1.f) {
        ++valid;
        expectRel(zz, 84.0 / (v - 1.0));
      } else {
        EXPECT_TRUE(std::isnan(zz)) << "d = " << v << " gave " << zz;
      }
    }
  }
  EXPECT_EQ(valid, 9);
}

TEST(GeometryPoints, FollowThePinholeModel) {
  StereoCamera c;
  c.fx = 700;
  c.fy = 650;  // different from fx: y must use fy
  c.cx = 2.5;
  c.cy = 1.25;
  c.cx_right = 2.5;
  c.baseline = 0.12;
  const cv::Mat d = sampleDisparity();
  cv::Mat pts;
  bdis::disparityToPoints(d, c, pts);
  ASSERT_EQ(pts.type(), CV_32FC3);
  ASSERT_EQ(pts.size(), d.size());
  int valid = 0;
  for (int v = 0; v < d.rows; ++v) {
    for (int u = 0; u < d.cols; ++u) {
      SCOPED_TRACE("u = " + std::to_string(u) + ", v = " + std::to_string(v));
      const float disp = d.at<float>(v, u);
      const cv::Vec3f p = pts.at<cv::Vec3f>(v, u);
      if (!(disp > 0.f)) {
        EXPECT_TRUE(std::isnan(p[0]) && std::isnan(p[1]) && std::isnan(p[2]));
        continue;
      }
      ++valid;
      const double z = 700.0 * 0.12 / disp;
      expectRel(p[2], z);
      EXPECT_NEAR(p[0], (u - 2.5) * z / 700.0, 1e-6 * z);
      EXPECT_NEAR(p[1], (v - 1.25) * z / 650.0, 1e-6 * z);
      // And it projects back to (u, v).
      EXPECT_NEAR(c.cx + c.fx * p[0] / p[2], u, 1e-4);
      EXPECT_NEAR(c.cy + c.fy * p[1] / p[2], v, 1e-4);
    }
  }
  EXPECT_EQ(valid, 11);
}

TEST(GeometryPoints, PrincipalPointOffsetAffectsDepthNotProjection) {
  StereoCamera c = StereoCamera::symmetric(500, 500, 10, 8, 0.05);
  c.cx_right = 6;  // infinity at d = 4
  const cv::Mat d = (cv::Mat_<float>(1, 4) << 4.f, 5.f, 14.f, 3.f);
  cv::Mat pts;
  bdis::disparityToPoints(d, c, pts);
  EXPECT_TRUE(std::isnan(pts.at<cv::Vec3f>(0, 0)[2]));
  EXPECT_TRUE(std::isnan(pts.at<cv::Vec3f>(0, 3)[0]));
  const cv::Vec3f p1 = pts.at<cv::Vec3f>(0, 1), p2 = pts.at<cv::Vec3f>(0, 2);
  expectRel(p1[2], 25.0 / 1.0);
  expectRel(p2[2], 25.0 / 10.0);
  EXPECT_NEAR(p1[0], (1 - 10) * 25.0 / 500, 1e-5);
  EXPECT_NEAR(p2[1], (0 - 8) * 2.5 / 500, 1e-6);
}

TEST(GeometryPoints, RejectNonFloatOrEmptyDisparity) {
  const StereoCamera c = StereoCamera::symmetric(700, 700, 320, 240, 0.12);
  cv::Mat out;
  for (const cv::Mat& bad : {cv::Mat(), cv::Mat(4, 4, CV_16SC1, cv::Scalar(1)),
                             cv::Mat(4, 4, CV_32FC2, cv::Scalar::all(1)),
                             cv::Mat(4, 4, CV_64FC1, cv::Scalar(1))}) {
    EXPECT_TRUE(contains(invalidArgumentMessage([&] { bdis::disparityToDepth(bad, c, out); }),
                         "CV_32FC1"));
    EXPECT_TRUE(contains(invalidArgumentMessage([&] { bdis::disparityToPoints(bad, c, out); }),
                         "CV_32FC1"));
  }
}

TEST(GeometryCamera, ValidateNamesTheBadField) {
  const StereoCamera good = StereoCamera::symmetric(700, 700, 320, 240, 0.12);
  EXPECT_NO_THROW(good.validate());
  struct Case {
    double StereoCamera::*field;
    double value;
    std::vector<std::string> expected;
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const std::vector<Case> cases = {
      {&StereoCamera::fx, 0.0, {"fx"}},
      {&StereoCamera::fx, -700.0, {"fx"}},
      {&StereoCamera::fy, 0.0, {"fy"}},
      {&StereoCamera::baseline, 0.0, {"baseline", "swapped"}},
      {&StereoCamera::baseline, -0.12, {"baseline", "swapped"}},
      {&StereoCamera::fx, nan, {"fx"}},
      {&StereoCamera::fy, nan, {"fy"}},
      {&StereoCamera::cx, nan, {"camera cx "}},
      {&StereoCamera::cy, nan, {"cy"}},
      {&StereoCamera::cx_right, nan, {"cx_right"}},
      {&StereoCamera::baseline, nan, {"baseline"}},
      {&StereoCamera::fx, inf, {"fx"}},
      {&StereoCamera::cx_right, -inf, {"cx_right"}},
  };
  for (const Case& k : cases) {
    StereoCamera c = good;
    c.*k.field = k.value;
    const std::string msg = invalidArgumentMessage([&] { c.validate(); });
    for (const std::string& s : k.expected) {
      EXPECT_TRUE(contains(msg, s)) << "value " << k.value << ": '" << msg << "' lacks '" << s << "'";
    }
    // The conversions validate the camera too.
    cv::Mat out;
    const cv::Mat d(2, 2, CV_32FC1, cv::Scalar(5.f));
    EXPECT_THROW(bdis::disparityToDepth(d, c, out), std::invalid_argument);
    EXPECT_THROW(bdis::disparityToPoints(d, c, out), std::invalid_argument);
  }
  // Negative principal points are unusual but legal (cropped rectification).
  StereoCamera c = good;
  c.cx = -5;
  c.cx_right = -20;
  EXPECT_NO_THROW(c.validate());
}

TEST(GeometryPoints, WorkOnMatcherOutput) {
  // End to end: points from a matched plane of disparity 7.3 lie at the
  // plane's depth.
  const bdis_test::StereoPair pair = bdis_test::texturedPair(160, 120, {7.3, 0.0});
  bdis::Matcher m;
  bdis::MatchResult r;
  m.compute(pair.left, pair.right, r);
  const StereoCamera c = StereoCamera::symmetric(500, 500, 80, 60, 0.1);
  cv::Mat pts;
  bdis::disparityToPoints(r.disparity, c, pts);
  const double z = 500 * 0.1 / 7.3;
  int checked = 0;
  for (int v = 32; v < 88; ++v) {
    for (int u = 40; u < 128; ++u) {
      const cv::Vec3f p = pts.at<cv::Vec3f>(v, u);
      if (std::isnan(p[2])) continue;
      ++checked;
      EXPECT_NEAR(p[2], z, 0.02 * z);
    }
  }
  EXPECT_GT(checked, 1000);
}

}  // namespace
