// The nodelet's per-frame validation and message conversion, without a master.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sensor_msgs/image_encodings.h>

#include "../../src/ros_frame.hpp"
#include "bdis_stereo/matcher.hpp"
#include "../../core/test/test_images.hpp"

using bdis_stereo::checkImage;
using bdis_stereo::checkImagePair;
using bdis_stereo::stereoCameraFromInfo;

namespace {

sensor_msgs::Image makeImage(int w, int h, const std::string& encoding, int channels) {
  sensor_msgs::Image img;
  img.width = w;
  img.height = h;
  img.encoding = encoding;
  img.step = w * channels;
  img.data.assign(static_cast<size_t>(img.step) * h, 100);
  return img;
}

sensor_msgs::CameraInfo makeInfo(double fx, double cx, double cy, double tx, int w = 64, int h = 48) {
  sensor_msgs::CameraInfo info;
  info.width = w;
  info.height = h;
  info.header.frame_id = "left_optical";
  info.P = {fx, 0, cx, tx, 0, fx, cy, 0, 0, 0, 1, 0};
  info.K = {fx, 0, cx, 0, fx, cy, 0, 0, 1};
  info.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  info.distortion_model = "plumb_bob";
  info.D = {0, 0, 0, 0, 0};
  return info;
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

}  // namespace

TEST(RosFrameCheckImage, AcceptsSupportedEncodings) {
  EXPECT_EQ(checkImage(makeImage(64, 48, "mono8", 1), "left", 1 << 20), "");
  EXPECT_EQ(checkImage(makeImage(64, 48, "bgr8", 3), "left", 1 << 20), "");
  EXPECT_EQ(checkImage(makeImage(64, 48, "rgb8", 3), "left", 1 << 20), "");
  EXPECT_EQ(checkImage(makeImage(64, 48, "bgra8", 4), "left", 1 << 20), "");
  EXPECT_EQ(checkImage(makeImage(64, 48, "rgba8", 4), "left", 1 << 20), "");
}

TEST(RosFrameCheckImage, SaysWhatIsWrong) {
  sensor_msgs::Image empty;
  EXPECT_TRUE(contains(checkImage(empty, "left", 1 << 20), "left image is empty"));
  EXPECT_TRUE(contains(checkImage(makeImage(64, 48, "mono16", 2), "right", 1 << 20),
                       "right image has encoding 'mono16'"));
  EXPECT_TRUE(contains(checkImage(makeImage(64, 48, "mono8", 1), "left", 1000),
                       "more than max_image_pixels = 1000"));
  EXPECT_TRUE(contains(checkImage(makeImage(16, 48, "mono8", 1), "left", 1 << 20), "at least 32 px"));
  sensor_msgs::Image short_data = makeImage(64, 48, "bgr8", 3);
  short_data.data.resize(100);
  EXPECT_TRUE(contains(checkImage(short_data, "left", 1 << 20), "inconsistent"));
  sensor_msgs::Image short_step = makeImage(64, 48, "bgr8", 3);
  short_step.step = 64;
  EXPECT_TRUE(contains(checkImage(short_step, "left", 1 << 20), "inconsistent"));
}

TEST(RosFrameCheckImage, PairSizesMustMatch) {
  EXPECT_EQ(checkImagePair(makeImage(64, 48, "mono8", 1), makeImage(64, 48, "bgr8", 3)), "");
  const std::string err = checkImagePair(makeImage(64, 48, "mono8", 1), makeImage(64, 40, "mono8", 1));
  EXPECT_TRUE(contains(err, "left image is 64x48 but right image is 64x40")) << err;
}

TEST(RosFrameCamera, BuildsTheModelFromTheCameraInfos) {
  bdis::StereoCamera cam;
  sensor_msgs::CameraInfo l = makeInfo(520, 32, 24, 0), r = makeInfo(520, 30, 24, -260);
  r.header.frame_id = "right_optical";  // differing frames are normal
  ASSERT_EQ(stereoCameraFromInfo(l, r, 64, 48, cam), "");
  EXPECT_DOUBLE_EQ(cam.fx, 520);
  EXPECT_DOUBLE_EQ(cam.fy, 520);
  EXPECT_DOUBLE_EQ(cam.cx, 32);
  EXPECT_DOUBLE_EQ(cam.cx_right, 30);
  EXPECT_DOUBLE_EQ(cam.cy, 24);
  EXPECT_DOUBLE_EQ(cam.baseline, 0.5);
}

TEST(RosFrameCamera, AppliesBinning) {
  bdis::StereoCamera cam;
  sensor_msgs::CameraInfo l = makeInfo(520, 64, 48, 0, 128, 96), r = makeInfo(520, 64, 48, -260, 128, 96);
  l.binning_x = l.binning_y = r.binning_x = r.binning_y = 2;
  ASSERT_EQ(stereoCameraFromInfo(l, r, 64, 48, cam), "");
  EXPECT_DOUBLE_EQ(cam.fx, 260);
  EXPECT_DOUBLE_EQ(cam.cx, 32);
  EXPECT_DOUBLE_EQ(cam.baseline, 0.5);
}

TEST(RosFrameCamera, SaysWhatIsWrong) {
  bdis::StereoCamera cam;
  const sensor_msgs::CameraInfo l = makeInfo(520, 32, 24, 0);
  std::string err = stereoCameraFromInfo(l, makeInfo(520, 32, 24, 0), 64, 48, cam);
  EXPECT_TRUE(contains(err, "right camera_info P[3] is 0: is the pair rectified as a stereo pair?")) << err;
  err = stereoCameraFromInfo(l, makeInfo(520, 32, 24, 260), 64, 48, cam);
  EXPECT_TRUE(contains(err, "are the cameras swapped?")) << err;
  sensor_msgs::CameraInfo nan_info = makeInfo(520, 32, 24, -260);
  nan_info.P[2] = std::numeric_limits<double>::quiet_NaN();
  err = stereoCameraFromInfo(l, nan_info, 64, 48, cam);
  EXPECT_TRUE(contains(err, "right camera_info P[2] is nan")) << err;
  nan_info.P[2] = std::numeric_limits<double>::infinity();
  err = stereoCameraFromInfo(nan_info, l, 64, 48, cam);
  EXPECT_TRUE(contains(err, "left camera_info P[2] is inf")) << err;
  sensor_msgs::CameraInfo zeros;  // an uncalibrated driver
  err = stereoCameraFromInfo(zeros, makeInfo(520, 32, 24, -260), 64, 48, cam);
  EXPECT_TRUE(contains(err, "is the camera calibrated")) << err;
  err = stereoCameraFromInfo(l, makeInfo(520, 32, 24, -260), 128, 48, cam);
  EXPECT_TRUE(contains(err, "left camera_info is for 64x48 (after binning/ROI) but the images are 128x48"))
      << err;
  err = stereoCameraFromInfo(l, makeInfo(600, 32, 24, -300), 64, 48, cam);
  EXPECT_TRUE(contains(err, "focal lengths differ")) << err;
}

TEST(RosFrameCamera, CameraInfoWithoutSizeIsAccepted) {
  bdis::StereoCamera cam;
  EXPECT_EQ(stereoCameraFromInfo(makeInfo(520, 32, 24, 0, 0, 0), makeInfo(520, 32, 24, -260, 0, 0), 64, 48, cam), "");
}

// Every value the outputs derive from the camera (DisparityImage f and T,
// depth = f * T / d, the points) is finite for the camera models accepted;
// P whose values would overflow them is refused, naming the entry.
TEST(RosFrameCamera, ImplausiblyLargeFocalLengthOrBaselineIsRefused) {
  bdis::StereoCamera cam;
  // fx = fy = 1e200, baseline 0.5: f and f * T overflow float32.
  std::string err = stereoCameraFromInfo(makeInfo(1e200, 32, 24, 0), makeInfo(1e200, 32, 24, -0.5e200),
                                         64, 48, cam);
  EXPECT_TRUE(contains(err, "left camera_info P[0] (fx) = 1e+200 px is not plausible (at most 1e+06 px)"))
      << err;
  sensor_msgs::CameraInfo tall = makeInfo(520, 32, 24, -260);
  tall.P[5] = 1e9;
  err = stereoCameraFromInfo(makeInfo(520, 32, 24, 0), tall, 64, 48, cam);
  EXPECT_TRUE(contains(err, "right camera_info P[5] (fy) = 1e+09 px is not plausible")) << err;
  // A normal fx with Tx = -1e300: a baseline of 2e297.
  err = stereoCameraFromInfo(makeInfo(500, 32, 24, 0), makeInfo(500, 32, 24, -1e300), 64, 48, cam);
  EXPECT_TRUE(contains(err, "right camera_info P[3] = -1e+300 gives baseline 2e+297 (-P[3] / fx), which "
                            "is not plausible (at most 1e+06)"))
      << err;
  // At the bounds everything the outputs derive stays finite.
  ASSERT_EQ(stereoCameraFromInfo(makeInfo(1e6, 32, 24, 0), makeInfo(1e6, 32, 24, -1e12), 64, 48, cam), "");
  EXPECT_DOUBLE_EQ(cam.baseline, 1e6);
  stereo_msgs::DisparityImage disparity_msg;
  cv::Mat d(40, 40, CV_32FC1, cv::Scalar(1e-3f));
  bdis_stereo::fillDisparityImage(d, cam, disparity_msg);
  EXPECT_TRUE(std::isfinite(disparity_msg.f) && std::isfinite(disparity_msg.T));
  EXPECT_TRUE(std::isfinite(disparity_msg.f * disparity_msg.T));
  sensor_msgs::Image depth_msg;
  bdis_stereo::fillDepthImage(d, cam, depth_msg);
  const float* z = reinterpret_cast<const float*>(depth_msg.data.data());
  EXPECT_TRUE(std::isfinite(z[0])) << z[0];
  sensor_msgs::PointCloud2 cloud;
  cv::Mat depth_buffer;
  bdis_stereo::fillPointCloud(d, cam, cv::Mat(), false, nullptr, depth_buffer, cloud);
  ASSERT_EQ(cloud.width, 1600u);
  const float* xyz = reinterpret_cast<const float*>(cloud.data.data());
  EXPECT_TRUE(std::isfinite(xyz[0]) && std::isfinite(xyz[1]) && std::isfinite(xyz[2]));
}

TEST(RosFrameCamera, CoreRefusesAnOverflowingFocalLengthTimesBaseline) {
  const bdis::StereoCamera cam = bdis::StereoCamera::symmetric(1e200, 1e200, 32, 24, 1e200);
  try {
    cam.validate();
    FAIL() << "validate accepted fx * baseline = inf";
  } catch (const std::invalid_argument& e) {
    EXPECT_TRUE(contains(e.what(), "fx * baseline is not finite")) << e.what();
  }
}

TEST(RosFrameCamera, NotARectifiedPairIsRefusedNamingTheEntry) {
  bdis::StereoCamera cam;
  const sensor_msgs::CameraInfo l = makeInfo(520, 32, 24, 0), r = makeInfo(520, 32, 24, -260);
  sensor_msgs::CameraInfo bad = r;
  bad.P[1] = 100;  // skew
  std::string err = stereoCameraFromInfo(l, bad, 64, 48, cam);
  EXPECT_TRUE(contains(err, "right camera_info P[1] (skew) = 100 but a rectified P has 0 there")) << err;
  bad = l;
  bad.P[8] = 5;
  err = stereoCameraFromInfo(bad, r, 64, 48, cam);
  EXPECT_TRUE(contains(err, "left camera_info P[8] (P[2][0]) = 5 but a rectified P has 0 there")) << err;
  bad = r;
  bad.P[7] = -100;  // Ty: the right camera above the left one
  err = stereoCameraFromInfo(l, bad, 64, 48, cam);
  EXPECT_TRUE(contains(err, "right camera_info P[7] (Ty) = -100 but a horizontal stereo pair has 0 there"))
      << err;
  bad = r;
  bad.P[11] = 0.2;
  err = stereoCameraFromInfo(l, bad, 64, 48, cam);
  EXPECT_TRUE(contains(err, "right camera_info P[11] (Tz) = 0.2")) << err;
  // Rounding as calibration files write it is accepted.
  bad = r;
  bad.P[1] = 1e-9;
  bad.P[7] = 1e-7;
  bad.P[8] = 1e-12;
  EXPECT_EQ(stereoCameraFromInfo(l, bad, 64, 48, cam), "");
}

TEST(RosFrameConvert, EightBitTypeEncodingsAreMono8AndBgr8) {
  sensor_msgs::Image grey = makeImage(40, 36, "8UC1", 1), colour = makeImage(40, 36, "8UC3", 3);
  EXPECT_TRUE(bdis_stereo::isSupportedEncoding("8UC1"));
  EXPECT_TRUE(bdis_stereo::isSupportedEncoding("8UC3"));
  EXPECT_EQ(checkImage(grey, "left", 1 << 20), "");
  EXPECT_EQ(checkImage(colour, "left", 1 << 20), "");
  EXPECT_EQ(checkImagePair(grey, colour), "");
  cv::Mat buffer;
  cv::Mat view = bdis_stereo::matcherView(grey, buffer);
  EXPECT_EQ(view.type(), CV_8UC1);
  EXPECT_EQ(view.data, grey.data.data());  // the mono8 bytes, no copy
  view = bdis_stereo::matcherView(colour, buffer);
  EXPECT_EQ(view.type(), CV_8UC3);
  EXPECT_EQ(view.data, colour.data.data());  // taken as bgr8, no copy
  // 8UC3 with the wrong step is still caught; other types still refused.
  sensor_msgs::Image short_step = colour;
  short_step.step = 40;
  EXPECT_TRUE(contains(checkImage(short_step, "left", 1 << 20), "inconsistent"));
  const std::string err = checkImage(makeImage(40, 36, "8UC2", 2), "right", 1 << 20);
  EXPECT_TRUE(contains(err, "8UC1 (as mono8) and 8UC3 (as bgr8)")) << err;
}

TEST(RosFrameConvert, MatcherViewWrapsOrConvertsToBgr) {
  sensor_msgs::Image bgr = makeImage(40, 36, "bgr8", 3);
  cv::Mat buffer;
  cv::Mat view = bdis_stereo::matcherView(bgr, buffer);
  EXPECT_EQ(view.type(), CV_8UC3);
  EXPECT_EQ(view.data, bgr.data.data());  // no copy
  sensor_msgs::Image rgba = makeImage(40, 36, "rgba8", 4);
  for (size_t i = 0; i < rgba.data.size(); i += 4) {
    rgba.data[i] = 10;  // r
    rgba.data[i + 1] = 20;
    rgba.data[i + 2] = 30;  // b
    rgba.data[i + 3] = 255;
  }
  view = bdis_stereo::matcherView(rgba, buffer);
  ASSERT_EQ(view.type(), CV_8UC3);
  EXPECT_EQ(view.at<cv::Vec3b>(5, 7), cv::Vec3b(30, 20, 10));
}

namespace {

// 6x5 disparity: constant 10 with one column without an estimate.
cv::Mat testDisparity() {
  cv::Mat d(5, 6, CV_32FC1, cv::Scalar(10.0f));
  d.col(0).setTo(bdis::kNoDisparity);
  d.at<float>(4, 5) = bdis::kNoDisparity;
  return d;
}

bdis::StereoCamera testCamera() {
  bdis::StereoCamera cam = bdis::StereoCamera::symmetric(520, 500, 3, 2, 0.5);
  cam.cx_right = 1;  // principal point offset: infinity at d = 2
  return cam;
}

}  // namespace

TEST(RosFrameConvert, DisparityImageFollowsStereoMsgs) {
  stereo_msgs::DisparityImage msg;
  bdis_stereo::fillDisparityImage(testDisparity(), testCamera(), msg);
  EXPECT_EQ(msg.image.encoding, "32FC1");
  EXPECT_EQ(msg.image.width, 6u);
  EXPECT_EQ(msg.image.height, 5u);
  EXPECT_FLOAT_EQ(msg.f, 520);
  EXPECT_FLOAT_EQ(msg.T, 0.5);
  EXPECT_FLOAT_EQ(msg.min_disparity, 0);
  EXPECT_FLOAT_EQ(msg.max_disparity, 8);
  const float* d = reinterpret_cast<const float*>(msg.image.data.data());
  EXPECT_FLOAT_EQ(d[0], -1.0f);  // no estimate: below min_disparity
  EXPECT_FLOAT_EQ(d[1], 8.0f);   // 10 - (cx - cx_right)
  EXPECT_FLOAT_EQ(d[4 * 6 + 5], -1.0f);
  // Z = f * T / d' equals the core's depth.
  EXPECT_FLOAT_EQ(msg.f * msg.T / d[1], testCamera().depth(10.0f));
  EXPECT_EQ(msg.valid_window.x_offset, 1u);
  EXPECT_EQ(msg.valid_window.y_offset, 0u);
  EXPECT_EQ(msg.valid_window.width, 5u);
  EXPECT_EQ(msg.valid_window.height, 5u);
}

TEST(RosFrameConvert, DisparityBeyondInfinityIsInvalid) {
  stereo_msgs::DisparityImage msg;
  cv::Mat d(4, 4, CV_32FC1, cv::Scalar(1.5f));  // below cx - cx_right = 2
  bdis_stereo::fillDisparityImage(d, testCamera(), msg);
  const float* p = reinterpret_cast<const float*>(msg.image.data.data());
  for (int i = 0; i < 16; ++i) EXPECT_LT(p[i], msg.min_disparity);
  EXPECT_EQ(msg.valid_window.width, 0u);
}

TEST(RosFrameConvert, DepthIsFxBOverShiftedDisparityNaNElsewhere) {
  sensor_msgs::Image msg;
  bdis_stereo::fillDepthImage(testDisparity(), testCamera(), msg);
  EXPECT_EQ(msg.encoding, "32FC1");
  const float* z = reinterpret_cast<const float*>(msg.data.data());
  EXPECT_TRUE(std::isnan(z[0]));
  EXPECT_FLOAT_EQ(z[1], 520 * 0.5 / 8);
}

TEST(RosFrameConvert, OrganisedCloudWithRgbAndTransform) {
  const cv::Mat disp = testDisparity();
  cv::Mat bgr(disp.size(), CV_8UC3, cv::Scalar(1, 2, 3));
  cv::Mat points;
  sensor_msgs::PointCloud2 msg;
  bdis_stereo::RigidTransform t;  // 90 degrees about z, then +1 in x
  const double r[9] = {0, -1, 0, 1, 0, 0, 0, 0, 1};
  std::copy(r, r + 9, t.r);
  t.t[0] = 1.0;
  bdis_stereo::fillPointCloud(disp, testCamera(), bgr, true, &t, points, msg);
  ASSERT_EQ(msg.fields.size(), 4u);
  EXPECT_EQ(msg.fields[3].name, "rgb");
  EXPECT_EQ(msg.fields[2].offset, 8u);
  EXPECT_EQ(msg.point_step, 16u);
  EXPECT_EQ(msg.height, 5u);
  EXPECT_EQ(msg.width, 6u);
  EXPECT_FALSE(msg.is_dense);
  EXPECT_EQ(msg.row_step, 6u * 16u);
  float p[4];
  std::memcpy(p, msg.data.data(), 16);  // (0, 0): no estimate
  EXPECT_TRUE(std::isnan(p[0]) && std::isnan(p[1]) && std::isnan(p[2]));
  const size_t i = (2 * 6 + 4) * 16;  // (x=4, y=2)
  std::memcpy(p, msg.data.data() + i, 16);
  const double z = 520 * 0.5 / 8, x = (4 - 3) * z / 520, y = (2 - 2) * z / 500;
  EXPECT_NEAR(p[0], -y + 1.0, 1e-5);
  EXPECT_NEAR(p[1], x, 1e-5);
  EXPECT_NEAR(p[2], z, 1e-5);
  uint32_t rgb;
  std::memcpy(&rgb, msg.data.data() + i + 12, 4);
  EXPECT_EQ(rgb, (3u << 16) | (2u << 8) | 1u);
}

TEST(RosFrameConvert, DenseCloudKeepsOnlyValidPointsWithoutRgbForMono) {
  const cv::Mat disp = testDisparity();
  cv::Mat points;
  sensor_msgs::PointCloud2 msg;
  bdis_stereo::fillPointCloud(disp, testCamera(), cv::Mat(), false, nullptr, points, msg);
  ASSERT_EQ(msg.fields.size(), 3u);
  EXPECT_EQ(msg.point_step, 12u);
  EXPECT_EQ(msg.height, 1u);
  EXPECT_EQ(msg.width, 30u - 5u - 1u);
  EXPECT_TRUE(msg.is_dense);
  EXPECT_EQ(msg.data.size(), msg.width * 12u);
  float p[3];
  std::memcpy(p, msg.data.data(), 12);  // first valid pixel: (1, 0)
  const double z = 520 * 0.5 / 8;
  EXPECT_NEAR(p[0], (1 - 3) * z / 520, 1e-5);
  EXPECT_NEAR(p[1], (0 - 2) * z / 500, 1e-5);
  EXPECT_NEAR(p[2], z, 1e-5);
}

namespace {

// Disparities over the whole range; 2 px = cx - cx_right is at infinity.
cv::Mat randomDisparity(int rows, int cols, uint64_t seed) {
  return bdis_test::mixedDisparity(rows, cols, seed, 2.0f);
}

bool sameFloat(float a, float b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

}  // namespace

TEST(RosFrameConvert, CloudFromDepthHasTheCoreGeometrysPoints) {
  const cv::Mat disp = randomDisparity(23, 37, 1);
  cv::Mat bgr(disp.size(), CV_8UC3);
  cv::randu(bgr, 0, 256);
  sensor_msgs::Image depth_msg;
  bdis_stereo::fillDepthImage(disp, testCamera(), depth_msg);
  const cv::Mat depth(23, 37, CV_32FC1, depth_msg.data.data(), depth_msg.step);
  sensor_msgs::PointCloud2 msg;
  bdis_stereo::fillPointCloudFromDepth(depth, testCamera(), bgr, true, nullptr, msg);
  cv::Mat points;
  bdis::disparityToPoints(disp, testCamera(), points);
  ASSERT_EQ(msg.data.size(), 23u * 37u * 16u);
  for (int y = 0; y < 23; ++y) {
    for (int x = 0; x < 37; ++x) {
      float p[4];
      std::memcpy(p, msg.data.data() + (y * 37 + x) * 16, 16);
      const cv::Vec3f q = points.at<cv::Vec3f>(y, x);
      EXPECT_TRUE(sameFloat(p[0], q[0]) && sameFloat(p[1], q[1]) && sameFloat(p[2], q[2]))
          << "at " << x << ", " << y;
      EXPECT_TRUE(sameFloat(p[2], testCamera().depth(disp.at<float>(y, x))));
      uint32_t rgb;
      std::memcpy(&rgb, &p[3], 4);
      const cv::Vec3b c = bgr.at<cv::Vec3b>(y, x);
      EXPECT_EQ(rgb, (uint32_t(c[2]) << 16) | (uint32_t(c[1]) << 8) | c[0]);
    }
  }
}

// The nodelet rewrites its previous messages: every byte must come from the
// new frame, whatever the old message held.
TEST(RosFrameConvert, ReusedMessagesEqualFreshOnes) {
  const cv::Mat first = randomDisparity(23, 37, 2), second = randomDisparity(23, 37, 3);
  cv::Mat bgr(first.size(), CV_8UC3);
  cv::randu(bgr, 0, 256);
  stereo_msgs::DisparityImage disparity, fresh_disparity;
  bdis_stereo::fillDisparityImage(first, testCamera(), disparity);
  bdis_stereo::fillDisparityImage(second, testCamera(), disparity);
  bdis_stereo::fillDisparityImage(second, testCamera(), fresh_disparity);
  EXPECT_EQ(disparity, fresh_disparity);
  sensor_msgs::Image depth, fresh_depth;
  bdis_stereo::fillDepthImage(first, testCamera(), depth);
  bdis_stereo::fillDepthImage(second, testCamera(), depth);
  bdis_stereo::fillDepthImage(second, testCamera(), fresh_depth);
  EXPECT_EQ(depth.data, fresh_depth.data);
  for (const bool organized : {true, false}) {
    for (const bool rgb : {true, false}) {
      cv::Mat scratch;
      sensor_msgs::PointCloud2 cloud, fresh_cloud;
      bdis_stereo::fillPointCloud(first, testCamera(), rgb ? bgr : cv::Mat(), organized, nullptr, scratch, cloud);
      bdis_stereo::fillPointCloud(second, testCamera(), rgb ? bgr : cv::Mat(), organized, nullptr, scratch, cloud);
      bdis_stereo::fillPointCloud(second, testCamera(), rgb ? bgr : cv::Mat(), organized, nullptr, scratch,
                                  fresh_cloud);
      EXPECT_EQ(cloud, fresh_cloud) << "organized " << organized << ", rgb " << rgb;
    }
  }
}

namespace {

geometry_msgs::TransformStamped tfOf(double qx, double qy, double qz, double qw, double tx = 0, double ty = 0,
                                     double tz = 0) {
  geometry_msgs::TransformStamped tf;
  tf.transform.rotation.x = qx;
  tf.transform.rotation.y = qy;
  tf.transform.rotation.z = qz;
  tf.transform.rotation.w = qw;
  tf.transform.translation.x = tx;
  tf.transform.translation.y = ty;
  tf.transform.translation.z = tz;
  return tf;
}

}  // namespace

TEST(RosFrameTransform, QuaternionAndTranslationBecomeTheRigidTransform) {
  bdis_stereo::RigidTransform t;
  // 90 degrees about z: x -> y, y -> -x; then (1, 2, 3).
  const double h = std::sqrt(0.5);
  ASSERT_EQ(bdis_stereo::rigidTransformFromTf(tfOf(0, 0, h, h, 1, 2, 3), t), "");
  const double expected[9] = {0, -1, 0, 1, 0, 0, 0, 0, 1};
  for (int i = 0; i < 9; ++i) EXPECT_NEAR(t.r[i], expected[i], 1e-12) << "r[" << i << "]";
  EXPECT_EQ(t.t[0], 1.0);
  EXPECT_EQ(t.t[1], 2.0);
  EXPECT_EQ(t.t[2], 3.0);
}

TEST(RosFrameTransform, QuaternionIsNormalisedFirst) {
  // The same rotation scaled by 3 (a publisher's rounding, exaggerated).
  bdis_stereo::RigidTransform scaled, unit;
  const double h = std::sqrt(0.5);
  ASSERT_EQ(bdis_stereo::rigidTransformFromTf(tfOf(3 * h, 0, 0, 3 * h), scaled), "");
  ASSERT_EQ(bdis_stereo::rigidTransformFromTf(tfOf(h, 0, 0, h), unit), "");
  for (int i = 0; i < 9; ++i) EXPECT_NEAR(scaled.r[i], unit.r[i], 1e-12) << "r[" << i << "]";
  // A rotation matrix: det 1, rows of length 1.
  const double* r = scaled.r;
  const double det = r[0] * (r[4] * r[8] - r[5] * r[7]) - r[1] * (r[3] * r[8] - r[5] * r[6]) +
                     r[2] * (r[3] * r[7] - r[4] * r[6]);
  EXPECT_NEAR(det, 1.0, 1e-12);
}

TEST(RosFrameTransform, InvalidRotationIsRefusedAndLeavesTheTransform) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (const auto& tf : {tfOf(0, 0, 0, 0, 1, 1, 1), tfOf(nan, 0, 0, 1), tfOf(0, inf, 0, 1)}) {
    bdis_stereo::RigidTransform t;
    t.t[0] = 7.0;
    EXPECT_EQ(bdis_stereo::rigidTransformFromTf(tf, t), "invalid rotation");
    EXPECT_EQ(t.t[0], 7.0);
    EXPECT_EQ(t.r[0], 1.0);
  }
}

// ---- compressed input (built-in decoding) -----------------------------------

namespace {

using bdis_stereo::decodeCompressedImage;

// A textured image: its JPEG has detail to lose.
cv::Mat texture(int w, int h, int type) {
  cv::Mat m(h, w, type);
  cv::randu(m, 0, 256);
  return m;
}

sensor_msgs::CompressedImage compressed(const cv::Mat& image, const std::string& ext, std::vector<int> params = {}) {
  std::vector<uint8_t> data;
  EXPECT_TRUE(cv::imencode(ext, image, data, params));
  sensor_msgs::CompressedImage msg;
  msg.header.frame_id = "left_optical";
  msg.header.stamp = ros::Time(12, 34);
  msg.format = "bgr8; " + std::string(ext == ".png" ? "png" : "jpeg") + " compressed bgr8";
  msg.data = data;
  return msg;
}

cv::Mat over(sensor_msgs::Image& image, int type) {
  return cv::Mat(static_cast<int>(image.height), static_cast<int>(image.width), type, image.data.data(), image.step);
}

}  // namespace

TEST(RosFrameDecode, PngIsLosslessAndJpegClose) {
  const cv::Mat bgr = texture(64, 48, CV_8UC3), grey = texture(64, 48, CV_8UC1);
  sensor_msgs::Image out;
  ASSERT_EQ(decodeCompressedImage(compressed(bgr, ".png"), "left", 1 << 20, out), "");
  EXPECT_EQ(out.encoding, "bgr8");
  EXPECT_EQ(out.header.frame_id, "left_optical");
  EXPECT_EQ(out.header.stamp, ros::Time(12, 34));
  EXPECT_EQ(std::make_tuple(out.width, out.height, out.step), std::make_tuple(64u, 48u, 64u * 3));
  EXPECT_EQ(cv::norm(over(out, CV_8UC3), bgr, cv::NORM_INF), 0.0);
  EXPECT_EQ(checkImage(out, "left", 1 << 20), "");

  ASSERT_EQ(decodeCompressedImage(compressed(grey, ".png"), "left", 1 << 20, out), "");
  EXPECT_EQ(out.encoding, "mono8");
  EXPECT_EQ(out.step, 64u);
  EXPECT_EQ(cv::norm(over(out, CV_8UC1), grey, cv::NORM_INF), 0.0);

  const cv::Mat smooth_bgr = [] {
    cv::Mat m = texture(64, 48, CV_8UC3);
    cv::GaussianBlur(m, m, cv::Size(0, 0), 2.0);
    return m;
  }();
  ASSERT_EQ(decodeCompressedImage(compressed(smooth_bgr, ".jpg", {cv::IMWRITE_JPEG_QUALITY, 95}), "left", 1 << 20,
                                  out),
            "");
  EXPECT_EQ(out.encoding, "bgr8");
  EXPECT_LT(cv::norm(over(out, CV_8UC3), smooth_bgr, cv::NORM_L1) / smooth_bgr.total() / 3, 2.0);
  ASSERT_EQ(decodeCompressedImage(compressed(grey, ".jpg"), "left", 1 << 20, out), "");
  EXPECT_EQ(out.encoding, "mono8");
}

// The decoder's check that it wrote anything (a canary in the first bytes)
// must not refuse an image that starts with the canary's values.
TEST(RosFrameDecode, ImageStartingWithTheCanaryIsDecoded) {
  cv::Mat grey = texture(64, 48, CV_8UC1);
  const uint8_t canary[8] = {0x5A, 0xA5, 0x3C, 0xC3, 0x96, 0x69, 0x0F, 0xF0};
  std::copy(canary, canary + 8, grey.ptr<uint8_t>(0));
  sensor_msgs::Image out;
  ASSERT_EQ(decodeCompressedImage(compressed(grey, ".png"), "left", 1 << 20, out), "");
  EXPECT_EQ(cv::norm(over(out, CV_8UC1), grey, cv::NORM_INF), 0.0);
}

TEST(RosFrameDecode, DecodesIntoTheSameBufferFrameAfterFrame) {
  sensor_msgs::Image out;
  ASSERT_EQ(decodeCompressedImage(compressed(texture(64, 48, CV_8UC3), ".jpg"), "left", 1 << 20, out), "");
  const uint8_t* buffer = out.data.data();
  for (int i = 0; i < 3; ++i) {
    const cv::Mat image = texture(64, 48, CV_8UC3);
    ASSERT_EQ(decodeCompressedImage(compressed(image, ".png"), "left", 1 << 20, out), "");
    EXPECT_EQ(out.data.data(), buffer) << "reallocated on frame " << i;
    EXPECT_EQ(cv::norm(over(out, CV_8UC3), image, cv::NORM_INF), 0.0);
  }
}

TEST(RosFrameDecode, BadDataIsRefusedWithTheReason) {
  sensor_msgs::Image out;
  auto error = [&out](const sensor_msgs::CompressedImage& msg, std::size_t max_pixels = 1 << 20) {
    return decodeCompressedImage(msg, "right", max_pixels, out);
  };
  const sensor_msgs::CompressedImage jpeg = compressed(texture(64, 48, CV_8UC3), ".jpg");
  const sensor_msgs::CompressedImage png = compressed(texture(64, 48, CV_8UC3), ".png");

  sensor_msgs::CompressedImage truncated = jpeg;
  truncated.data.resize(truncated.data.size() * 2 / 3);
  EXPECT_TRUE(contains(error(truncated), "right compressed image (format 'bgr8; jpeg compressed bgr8') is a "
                                         "truncated JPEG (no end-of-image marker)"))
      << error(truncated);
  truncated.data.resize(40);  // inside the header
  EXPECT_TRUE(contains(error(truncated), "truncated JPEG")) << error(truncated);
  sensor_msgs::CompressedImage corrupt = jpeg;
  std::fill(corrupt.data.begin() + 2, corrupt.data.begin() + 200, 0x5A);  // markers overwritten
  EXPECT_TRUE(contains(error(corrupt), "corrupt JPEG")) << error(corrupt);
  corrupt = jpeg;  // the scan names a component the frame does not have: libjpeg gives up
  const uint8_t sos[2] = {0xFF, 0xDA};
  const auto scan = std::search(corrupt.data.begin(), corrupt.data.end(), sos, sos + 2);
  ASSERT_NE(scan, corrupt.data.end());
  *(scan + 5) = 0x77;  // FF DA, length (2), component count, first component's id
  EXPECT_TRUE(contains(error(corrupt), "is a corrupt JPEG: OpenCV cannot decode it")) << error(corrupt);

  sensor_msgs::CompressedImage png_truncated = png;
  png_truncated.data.resize(png_truncated.data.size() - 20);
  EXPECT_TRUE(contains(error(png_truncated), "truncated PNG (no IEND chunk)")) << error(png_truncated);
  EXPECT_TRUE(contains(error(compressed(cv::Mat(48, 64, CV_16UC1, cv::Scalar(1000)), ".png")),
                       "is a 16-bit PNG: supported are 8-bit JPEG and PNG"));
  sensor_msgs::CompressedImage text = jpeg;
  text.data.assign({'h', 'e', 'l', 'l', 'o'});
  EXPECT_TRUE(contains(error(text), "is neither a JPEG nor a PNG")) << error(text);
  text.data.clear();
  EXPECT_TRUE(contains(error(text), "is empty")) << error(text);

  // The size is refused from the header, before anything is allocated.
  sensor_msgs::Image untouched;
  EXPECT_TRUE(contains(decodeCompressedImage(png, "left", 1000, untouched),
                       "left image is 64x48, more than max_image_pixels = 1000"));
  EXPECT_TRUE(untouched.data.empty());
  sensor_msgs::CompressedImage huge = png;  // IHDR says 100000 x 100000
  for (int offset : {16, 20}) {
    const uint8_t big_endian_100000[4] = {0x00, 0x01, 0x86, 0xA0};
    std::copy(big_endian_100000, big_endian_100000 + 4, huge.data.begin() + offset);
  }
  EXPECT_TRUE(contains(decodeCompressedImage(huge, "left", 1 << 24, untouched), "100000x100000, more than"));
  EXPECT_TRUE(untouched.data.empty());
  EXPECT_TRUE(contains(error(compressed(texture(16, 48, CV_8UC3), ".png")), "at least 32 px"));
}

// ---- raw frames for image_proc/rectify --------------------------------------

TEST(RosFrameRawCheck, AcceptsWhatImageProcRectifies) {
  const sensor_msgs::Image image = makeImage(64, 48, "bgr8", 3);
  sensor_msgs::CameraInfo info = makeInfo(520, 32, 24, 0);
  info.D = {-0.2, 0.05, 0, 0, 0};
  EXPECT_EQ(bdis_stereo::checkRawFrame(image, info, "left", 1 << 20), "");
  info.distortion_model = "rational_polynomial";
  info.D = {-0.2, 0.05, 0, 0, 0, 0.01, 0, 0};
  EXPECT_EQ(bdis_stereo::checkRawFrame(image, info, "left", 1 << 20), "");
  info.distortion_model = "equidistant";
  info.D = {0.05, 0.01, 0, 0};
  EXPECT_EQ(bdis_stereo::checkRawFrame(image, info, "left", 1 << 20), "");
  info.distortion_model = "";  // no distortion: passed on as it is, whatever the model
  info.D.clear();
  EXPECT_EQ(bdis_stereo::checkRawFrame(image, info, "left", 1 << 20), "");
  info = makeInfo(520, 64, 48, 0, 128, 96);  // binned 2x2
  info.binning_x = info.binning_y = 2;
  info.D = {-0.2, 0.05, 0, 0, 0};
  EXPECT_EQ(bdis_stereo::checkRawFrame(image, info, "left", 1 << 20), "");
}

TEST(RosFrameRawCheck, RefusesWhatWouldEndTheManagerOrGoWrong) {
  const sensor_msgs::Image image = makeImage(64, 48, "bgr8", 3);
  auto check = [&image](void (*edit)(sensor_msgs::CameraInfo&)) {
    sensor_msgs::CameraInfo info = makeInfo(520, 32, 24, 0);
    info.D = {-0.2, 0.05, 0, 0, 0};
    edit(info);
    return bdis_stereo::checkRawFrame(image, info, "right", 1 << 20);
  };
  std::string err = check([](sensor_msgs::CameraInfo& i) { i.distortion_model = "fisheye_v2"; });
  EXPECT_TRUE(contains(err, "right camera_info has distortion model 'fisheye_v2': image_proc/rectify "
                            "(image_geometry) undistorts plumb_bob, rational_polynomial and equidistant"))
      << err;
  err = check([](sensor_msgs::CameraInfo& i) { i.D.resize(3); });
  EXPECT_TRUE(contains(err, "has 3 distortion coefficients for model 'plumb_bob'")) << err;
  err = check([](sensor_msgs::CameraInfo& i) { i.distortion_model = "equidistant"; });
  EXPECT_TRUE(contains(err, "has 5 distortion coefficients for model 'equidistant' (4 expected)")) << err;
  err = check([](sensor_msgs::CameraInfo& i) { i.width = 128; });
  EXPECT_TRUE(contains(err, "right camera_info is for 128x48 (after binning/ROI) but the raw image is 64x48")) << err;
  err = check([](sensor_msgs::CameraInfo& i) { i.width = i.height = 0; });
  EXPECT_TRUE(contains(err, "gives no image size")) << err;
  err = check([](sensor_msgs::CameraInfo& i) { i.K.fill(0.0); });
  EXPECT_TRUE(contains(err, "the camera is not calibrated")) << err;
  err = check([](sensor_msgs::CameraInfo& i) { i.R.fill(0.0); });
  EXPECT_TRUE(contains(err, "R is not a rotation")) << err;
  err = check([](sensor_msgs::CameraInfo& i) { i.D[1] = std::numeric_limits<double>::quiet_NaN(); });
  EXPECT_TRUE(contains(err, "D has a non-finite entry")) << err;
  err = check([](sensor_msgs::CameraInfo& i) {
    i.D.assign(5, 0.0);  // no distortion but a rectifying rotation (about y)
    i.R = {0.8, 0, 0.6, 0, 1, 0, -0.6, 0, 0.8};
  });
  EXPECT_TRUE(contains(err, "no distortion (D all zero) but R is not the identity")) << err;
  sensor_msgs::CameraInfo info = makeInfo(520, 32, 24, 0);
  EXPECT_TRUE(contains(bdis_stereo::checkRawFrame(makeImage(64, 48, "bayer_rggb8", 1), info, "left", 1 << 20),
                       "left image has encoding 'bayer_rggb8'"));
}
