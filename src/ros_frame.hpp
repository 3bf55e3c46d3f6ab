// Per-frame validation and message conversion of the bdis_stereo nodelet.
// Needs ROS message types and image_geometry but no master, no node handle and
// no callbacks, so test_ros_frame checks every message and conversion offline.
// Nothing here throws for bad input: checks return a message saying what is
// wrong and how to fix it ("" when the frame is fine).
#pragma once

#include <cstddef>
#include <string>

#include <geometry_msgs/TransformStamped.h>
#include <opencv2/core.hpp>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <stereo_msgs/DisparityImage.h>

#include "bdis_stereo/geometry.hpp"

namespace bdis_stereo {

/// Default for the `max_image_pixels` parameter: frames with more pixels are
/// refused (bounded memory and time). 4096 x 4096.
constexpr std::size_t kDefaultMaxImagePixels = 4096u * 4096u;

/// mono8, bgr8, rgb8, bgra8, rgba8, and 8UC1 / 8UC3 (the bytes of mono8 / bgr8).
bool isSupportedEncoding(const std::string& encoding);

/// Checks one input image: not empty, at least bdis::kMinImageSide per side,
/// at most `max_pixels` pixels, a supported encoding, and `step`/`data`
/// consistent with width, height and encoding. `side` is "left" or "right".
std::string checkImage(const sensor_msgs::Image& image, const char* side, std::size_t max_pixels);

/// Checks that the two images can be matched as a pair (equal sizes).
std::string checkImagePair(const sensor_msgs::Image& left, const sensor_msgs::Image& right);

/// Decodes a sensor_msgs/CompressedImage (JPEG or PNG, 8 bits per sample,
/// told apart by their first bytes, whatever `format` says) with OpenCV into
/// `image`: mono8 for grey, bgr8 for colour, msg's header. The size is
/// checked (at most `max_pixels`, at least bdis::kMinImageSide per side)
/// before anything is allocated, and the pixels are decoded straight into
/// `image.data`, which keeps its capacity from frame to frame. Returns "" or
/// what is wrong, naming `side` ("left", "right"): not JPEG or PNG,
/// truncated, corrupt, 16-bit, too large; `image` is then unspecified.
std::string decodeCompressedImage(const sensor_msgs::CompressedImage& msg, const char* side, std::size_t max_pixels,
                                  sensor_msgs::Image& image);

/// The distortion models image_geometry (and so image_proc/rectify) undistorts.
bool isRectifiableDistortionModel(const std::string& model);

/// Checks a raw image and its camera_info (the calibrator's: D, K, R, P) for
/// what image_proc/rectify needs: checkImage, a calibrated camera_info (K
/// and R finite, fx, fy > 0, R a rotation) of the image's size (after
/// binning/ROI), and distortion coefficients of a model image_geometry knows,
/// in a number OpenCV takes. image_proc/rectify itself throws out of its
/// callback, ending the manager, for an unknown model or a wrong number of
/// coefficients, and silently remaps an image of another size to the
/// camera_info's. Also refused: no distortion with R not the identity, which
/// image_proc/rectify passes on unrotated. `side` is "left" or "right".
std::string checkRawFrame(const sensor_msgs::Image& image, const sensor_msgs::CameraInfo& info, const char* side,
                          std::size_t max_pixels);

/// Builds the rectified stereo model from the two camera_infos (image_geometry,
/// so binning and ROI are applied) and checks it against the image size:
/// finite projection matrices of the rectified form [fx 0 cx Tx; 0 fy cy 0;
/// 0 0 1 0] (no skew, Ty = Tz = 0, up to rounding), 0 < fx, fy <= 1e6 px in
/// both, equal fx, camera_info size equal to the image size (when the
/// camera_info gives one), right P[3] < 0 (a positive baseline, at most 1e6).
/// Differing frame_ids are accepted. On success fills
/// `camera` (baseline in the unit of P[3] / fx, metres by ROS convention) and
/// returns "".
std::string stereoCameraFromInfo(const sensor_msgs::CameraInfo& left,
                                 const sensor_msgs::CameraInfo& right, int image_width,
                                 int image_height, bdis::StereoCamera& camera);

/// A view of a checked image in what the matcher takes: CV_8UC1 (mono8) or
/// CV_8UC3 BGR. mono8, 8UC1, bgr8 and 8UC3 are wrapped without a copy (the view lives as
/// long as `image`); rgb8, bgra8, rgba8 are converted into `buffer`, which is
/// reused from frame to frame.
cv::Mat matcherView(const sensor_msgs::Image& image, cv::Mat& buffer);

/// Writes a CV_32FC1 image into `msg` (32FC1, header untouched); `msg.data`
/// keeps its capacity when the size is unchanged.
void fillFloatImage(const cv::Mat& image, sensor_msgs::Image& msg);

/// stereo_msgs/DisparityImage as stereo_image_proc fills it (header untouched):
/// f = fx, T = baseline, disparity d' = d - (cx - cx_right) so that
/// Z = f * T / d' holds whatever the principal-point offset; pixels without an
/// estimate, and those at or beyond infinity (d' <= 0), are set to
/// min_disparity - 1 = -1. min_disparity = 0, max_disparity = the largest
/// value in this frame (0 if none), delta_d = 1/16 (nominal: the matcher's
/// output is continuous), valid_window = bounding box of the pixels with an
/// estimate (all zero when there is none).
void fillDisparityImage(const cv::Mat& disparity, const bdis::StereoCamera& camera,
                        stereo_msgs::DisparityImage& msg);

/// REP 118 depth image (32FC1, unit of the baseline, NaN where unknown),
/// computed straight into `msg.data`.
void fillDepthImage(const cv::Mat& disparity, const bdis::StereoCamera& camera,
                    sensor_msgs::Image& msg);

/// The cloud's transform (bdis::RigidTransform: p' = R p + t, row-major R).
using RigidTransform = bdis::RigidTransform;

/// A tf2 transform as a RigidTransform: the rotation from the quaternion,
/// normalised first (publishers round unit quaternions). Returns "" on
/// success, else what is wrong ("invalid rotation" for a zero or non-finite
/// quaternion), leaving `transform` untouched.
std::string rigidTransformFromTf(const geometry_msgs::TransformStamped& tf, RigidTransform& transform);

/// sensor_msgs/PointCloud2 with float32 x, y, z and, when `left_bgr` is a
/// CV_8UC3 BGR image, a packed float32 rgb field (PCL convention), from a
/// depth image (CV_32FC1 as fillDepthImage writes it, NaN where unknown):
/// x, y, z as bdis::disparityToPoints gives them (bdis::writePointCloud writes them). organized: height x
/// width of the image, NaN for pixels without an estimate, is_dense = false; otherwise height 1 and only
/// valid points, is_dense = true. `transform` (may be null) maps the camera-frame points into another frame.
/// Written straight into `msg.data`, which keeps its capacity (and, at an unchanged size, is not cleared
/// first) when `msg` is reused. Header untouched.
void fillPointCloudFromDepth(const cv::Mat& depth, const bdis::StereoCamera& camera,
                             const cv::Mat& left_bgr, bool organized, const RigidTransform* transform,
                             sensor_msgs::PointCloud2& msg);

/// fillPointCloudFromDepth from a disparity image; `depth` is a reused
/// scratch buffer for its depth image.
void fillPointCloud(const cv::Mat& disparity, const bdis::StereoCamera& camera,
                    const cv::Mat& left_bgr, bool organized, const RigidTransform* transform,
                    cv::Mat& depth, sensor_msgs::PointCloud2& msg);

}  // namespace bdis_stereo
