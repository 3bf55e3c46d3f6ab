// Disparity to depth and 3-D points for a rectified pair.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

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

// ---- Point clouds into a byte buffer -------------------------------------------

// Disparities over the whole range; 2 px is at infinity for cloudCamera().
cv::Mat mixedDisparity(int rows, int cols, uint64_t seed) { return bdis_test::mixedDisparity(rows, cols, seed, 2.0f); }

StereoCamera cloudCamera() {
  StereoCamera c = StereoCamera::symmetric(520, 500, 3.5, 2.25, 0.5);
  c.cx_right = 1.5;
  return c;
}

struct Record {
  float x, y, z;
  uint32_t rgb;
};

Record readRecord(const std::vector<uint8_t>& buffer, std::size_t offset, bool colour) {
  Record r{};
  std::memcpy(&r, buffer.data() + offset, colour ? 16 : 12);
  return r;
}

bool sameFloat(float a, float b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

uint32_t packed(const cv::Vec3b& bgr) { return (uint32_t(bgr[2]) << 16) | (uint32_t(bgr[1]) << 8) | bgr[0]; }

// Organised: every pixel in raster order, bit-identical to disparityToPoints,
// for widths that exercise the four-point path and its scalar tail, with and
// without colour, at the packed and at a padded point_step (the padding bytes
// stay as they were).
TEST(GeometryCloud, OrganisedRecordsEqualDisparityToPoints) {
  const StereoCamera camera = cloudCamera();
  for (const int width : {1, 4, 5, 8, 37}) {
    const cv::Mat disparity = mixedDisparity(7, width, static_cast<uint64_t>(width));
    cv::Mat depth, points;
    bdis::disparityToDepth(disparity, camera, depth);
    bdis::disparityToPoints(disparity, camera, points);
    cv::Mat bgr(disparity.size(), CV_8UC3);
    cv::randu(bgr, 0, 256);
    EXPECT_EQ(bdis::pointCount(depth, true), depth.total());
    for (const bool colour : {true, false}) {
      for (const std::size_t step :
           {colour ? bdis::kColouredPointBytes : bdis::kPointBytes, std::size_t{24}}) {
        SCOPED_TRACE("width " + std::to_string(width) + ", colour " + std::to_string(colour) + ", step " +
                     std::to_string(step));
        std::vector<uint8_t> buffer(depth.total() * step, 0xAB);
        bdis::writePointCloud(depth, camera, colour ? bgr : cv::Mat(), true, nullptr, step, buffer.data());
        for (int y = 0; y < depth.rows; ++y) {
          for (int x = 0; x < depth.cols; ++x) {
            const std::size_t offset = (static_cast<std::size_t>(y) * width + x) * step;
            const Record r = readRecord(buffer, offset, colour);
            const cv::Vec3f q = points.at<cv::Vec3f>(y, x);
            EXPECT_TRUE(sameFloat(r.x, q[0]) && sameFloat(r.y, q[1]) && sameFloat(r.z, q[2]))
                << "at " << x << ", " << y;
            if (colour) {
              EXPECT_EQ(r.rgb, packed(bgr.at<cv::Vec3b>(y, x))) << "at " << x << ", " << y;
            }
            const std::size_t used = colour ? 16 : 12;
            for (std::size_t b = used; b < step; ++b)
              ASSERT_EQ(buffer[offset + b], 0xAB) << "padding written";
          }
        }
      }
    }
  }
}

// A subsampled depth image with the subsampled camera: the full image's
// points and colours at the kept pixels (within float rounding), on a grid of
// ceil(size / stride), for strides that divide the size and ones that do not.
TEST(GeometryCloud, SubsampledDepthGivesTheFullImagesPointsAtTheKeptPixels) {
  const StereoCamera camera = cloudCamera();
  const cv::Mat disparity = mixedDisparity(9, 13, 3);
  cv::Mat depth, points, bgr(disparity.size(), CV_8UC3);
  cv::randu(bgr, 0, 256);
  bdis::disparityToDepth(disparity, camera, depth);
  bdis::disparityToPoints(disparity, camera, points);
  for (const int stride : {1, 2, 3, 4, 13}) {
    SCOPED_TRACE("stride " + std::to_string(stride));
    cv::Mat small_depth, small_bgr;
    bdis::subsample(depth, stride, small_depth);
    bdis::subsample(bgr, stride, small_bgr);
    ASSERT_EQ(small_depth.size(), cv::Size((13 + stride - 1) / stride, (9 + stride - 1) / stride));
    ASSERT_EQ(small_bgr.size(), small_depth.size());
    std::vector<uint8_t> buffer(small_depth.total() * bdis::kColouredPointBytes);
    bdis::writePointCloud(small_depth, camera.subsampled(stride), small_bgr, true, nullptr,
                          bdis::kColouredPointBytes, buffer.data());
    for (int y = 0; y < small_depth.rows; ++y) {
      for (int x = 0; x < small_depth.cols; ++x) {
        const Record r =
            readRecord(buffer, (static_cast<std::size_t>(y) * small_depth.cols + x) * bdis::kColouredPointBytes, true);
        const cv::Vec3f q = points.at<cv::Vec3f>(y * stride, x * stride);
        if (std::isnan(q[2])) {
          EXPECT_TRUE(std::isnan(r.x) && std::isnan(r.y) && std::isnan(r.z)) << "at " << x << ", " << y;
        } else {
          EXPECT_NEAR(r.x, q[0], 1e-6 * std::fabs(q[2])) << "at " << x << ", " << y;
          EXPECT_NEAR(r.y, q[1], 1e-6 * std::fabs(q[2])) << "at " << x << ", " << y;
          EXPECT_EQ(r.z, q[2]) << "at " << x << ", " << y;
        }
        EXPECT_EQ(r.rgb, packed(bgr.at<cv::Vec3b>(y * stride, x * stride))) << "at " << x << ", " << y;
      }
    }
  }
  // Every element size (the common ones have a loop of their own): the kept pixels exactly.
  for (const int type : {CV_8UC1, CV_8UC3, CV_32FC1, CV_32FC3, CV_16UC1, CV_64FC2}) {
    cv::Mat image(11, 17, type), small;
    cv::randu(image, 0, 255);
    bdis::subsample(image, 3, small);
    ASSERT_EQ(small.size(), cv::Size(6, 4));
    for (int y = 0; y < small.rows; ++y) {
      for (int x = 0; x < small.cols; ++x) {
        EXPECT_EQ(std::memcmp(small.ptr(y, x), image.ptr(3 * y, 3 * x), image.elemSize()), 0)
            << "type " << type << " at " << x << ", " << y;
      }
    }
  }
  cv::Mat out;
  EXPECT_THROW(bdis::subsample(depth, 0, out), std::invalid_argument);
  EXPECT_THROW(camera.subsampled(0), std::invalid_argument);
  // In place: the kept pixels, at the smaller size.
  cv::Mat in_place = depth.clone();
  bdis::subsample(in_place, 2, in_place);
  EXPECT_EQ(in_place.size(), cv::Size(7, 5));
  EXPECT_TRUE(sameFloat(in_place.at<float>(2, 3), depth.at<float>(4, 6)));
}

TEST(GeometryCloud, DenseKeepsOnlyThePointsWithDepthInRasterOrder) {
  const StereoCamera camera = cloudCamera();
  const cv::Mat disparity = mixedDisparity(9, 13, 5);
  cv::Mat depth, points;
  bdis::disparityToDepth(disparity, camera, depth);
  bdis::disparityToPoints(disparity, camera, points);
  std::vector<cv::Vec3f> expected;
  for (int y = 0; y < points.rows; ++y) {
    for (int x = 0; x < points.cols; ++x) {
      if (!std::isnan(points.at<cv::Vec3f>(y, x)[2])) expected.push_back(points.at<cv::Vec3f>(y, x));
    }
  }
  ASSERT_GT(expected.size(), 20u);
  ASSERT_LT(expected.size(), depth.total());
  ASSERT_EQ(bdis::pointCount(depth, false), expected.size());
  std::vector<uint8_t> buffer(expected.size() * bdis::kPointBytes);
  bdis::writePointCloud(depth, camera, cv::Mat(), false, nullptr, bdis::kPointBytes, buffer.data());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const Record r = readRecord(buffer, i * bdis::kPointBytes, false);
    EXPECT_EQ(r.x, expected[i][0]) << i;
    EXPECT_EQ(r.y, expected[i][1]) << i;
    EXPECT_EQ(r.z, expected[i][2]) << i;
  }
}

TEST(GeometryCloud, TransformMapsEveryPointAndKeepsUnknownsNaN) {
  const StereoCamera camera = cloudCamera();
  const cv::Mat disparity = mixedDisparity(6, 11, 9);
  cv::Mat depth, points;
  bdis::disparityToDepth(disparity, camera, depth);
  bdis::disparityToPoints(disparity, camera, points);
  bdis::RigidTransform t;  // 90 degrees about z, then (1, -2, 0.5)
  const double r[9] = {0, -1, 0, 1, 0, 0, 0, 0, 1};
  std::copy(r, r + 9, t.r);
  t.t[0] = 1.0;
  t.t[1] = -2.0;
  t.t[2] = 0.5;
  cv::Mat bgr(disparity.size(), CV_8UC3, cv::Scalar(10, 20, 30));
  for (const bool organized : {true, false}) {
    SCOPED_TRACE(organized ? "organised" : "dense");
    std::vector<uint8_t> buffer(bdis::pointCount(depth, organized) * 16);
    bdis::writePointCloud(depth, camera, bgr, organized, &t, 16, buffer.data());
    std::size_t i = 0;
    for (int y = 0; y < depth.rows; ++y) {
      for (int x = 0; x < depth.cols; ++x) {
        const cv::Vec3f p = points.at<cv::Vec3f>(y, x);
        if (std::isnan(p[2]) && !organized) continue;
        const Record rec = readRecord(buffer, 16 * i++, true);
        EXPECT_EQ(rec.rgb, (30u << 16) | (20u << 8) | 10u);
        if (std::isnan(p[2])) {
          EXPECT_TRUE(std::isnan(rec.x) && std::isnan(rec.y) && std::isnan(rec.z));
          continue;
        }
        EXPECT_NEAR(rec.x, -p[1] + 1.0, 1e-4 * std::abs(p[2]) + 1e-5);
        EXPECT_NEAR(rec.y, p[0] - 2.0, 1e-4 * std::abs(p[2]) + 1e-5);
        EXPECT_NEAR(rec.z, p[2] + 0.5, 1e-4 * std::abs(p[2]) + 1e-5);
      }
    }
    EXPECT_EQ(i * 16, buffer.size());
  }
}

TEST(GeometryCloud, RefusesWhatItCannotWrite) {
  const StereoCamera camera = cloudCamera();
  const cv::Mat depth(4, 5, CV_32FC1, cv::Scalar(2.f));
  std::vector<uint8_t> buffer(4 * 5 * 32);
  auto write = [&](const cv::Mat& d, const cv::Mat& bgr, std::size_t step) {
    return invalidArgumentMessage(
        [&] { bdis::writePointCloud(d, camera, bgr, true, nullptr, step, buffer.data()); });
  };
  EXPECT_TRUE(contains(write(cv::Mat(4, 5, CV_64FC1, cv::Scalar(2.0)), cv::Mat(), 12), "CV_32FC1"));
  EXPECT_TRUE(contains(write(depth, cv::Mat(), 8), "point_step 8"));
  EXPECT_TRUE(contains(write(depth, cv::Mat(4, 5, CV_8UC3), 12), "point_step 12"));
  EXPECT_TRUE(contains(write(depth, cv::Mat(4, 5, CV_8UC1), 16), "CV_8UC3"));
  EXPECT_TRUE(contains(write(depth, cv::Mat(5, 5, CV_8UC3), 16), "CV_8UC3"));
  StereoCamera bad = camera;
  bad.fx = 0;
  EXPECT_THROW(bdis::writePointCloud(depth, bad, cv::Mat(), true, nullptr, 12, buffer.data()),
               std::invalid_argument);
}

}  // namespace
