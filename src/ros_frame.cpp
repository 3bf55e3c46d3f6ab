#include "ros_frame.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <sstream>
#include <stdexcept>

#include <image_geometry/pinhole_camera_model.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sensor_msgs/distortion_models.h>
#include <sensor_msgs/image_encodings.h>
#include <tf2/LinearMath/Matrix3x3.h>
#include <tf2/LinearMath/Quaternion.h>

#include "bdis_stereo/image_header.hpp"
#include "bdis_stereo/matcher.hpp"

namespace bdis_stereo {
namespace enc = sensor_msgs::image_encodings;

namespace {

constexpr float kInvalidDisparity = -1.0f;  // DisparityImage: min_disparity (0) - 1

// 8UC1 and 8UC3 carry the same bytes as mono8 and bgr8 (drivers and
// cv_bridge::toImageMsg without an encoding publish them): taken as those.
int channelsOf(const std::string& encoding) {
  if (encoding == enc::MONO8 || encoding == enc::TYPE_8UC1) return 1;
  if (encoding == enc::BGR8 || encoding == enc::RGB8 || encoding == enc::TYPE_8UC3) return 3;
  if (encoding == enc::BGRA8 || encoding == enc::RGBA8) return 4;
  return 0;
}

std::string num(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

// The largest focal length taken as plausible: a 4096 px wide image at 1e6 px
// spans a quarter of a degree. Beyond that P is in the wrong unit or garbage,
// and near 1e38 the float32 outputs (DisparityImage f, depth) become infinite.
constexpr double kMaxFocalLengthPx = 1e6;
// The largest baseline taken as plausible, in the unit of P[3] / fx: a
// kilometre in millimetres. With the focal length bound it keeps
// fx * baseline (depth = fx * baseline / disparity) far inside float32.
constexpr double kMaxBaseline = 1e6;
// Tolerances of the entries a rectified P has as exact zeros (stereoRectify
// writes zeros; calibration files may round them to a tiny value): relative
// to fx for the pixel entries, to the baseline for the translations.
constexpr double kZeroPixelTolerance = 1e-6;
constexpr double kZeroTranslationTolerance = 1e-3;

// "" when all 12 entries of P are finite, the focal lengths positive and
// plausible and P[10] = 1, else what is wrong, naming the entry.
std::string checkProjection(const sensor_msgs::CameraInfo& info, const char* side) {
  for (int i = 0; i < 12; ++i) {
    if (!std::isfinite(info.P[i])) {
      return std::string(side) + " camera_info P[" + std::to_string(i) + "] is " + num(info.P[i]) +
             ": the calibration is invalid; republish a rectified camera_info";
    }
  }
  if (!(info.P[0] > 0.0) || !(info.P[5] > 0.0)) {
    return std::string(side) + " camera_info P[0] (fx) = " + num(info.P[0]) + ", P[5] (fy) = " +
           num(info.P[5]) +
           ": focal lengths must be > 0; is the camera calibrated (an all-zero camera_info means "
           "uncalibrated)?";
  }
  for (int i : {0, 5}) {
    if (info.P[i] > kMaxFocalLengthPx) {
      return std::string(side) + " camera_info P[" + std::to_string(i) + "] (" +
             (i == 0 ? "fx" : "fy") + ") = " + num(info.P[i]) + " px is not plausible (at most " +
             num(kMaxFocalLengthPx) + " px): is the calibration in pixels?";
    }
  }
  if (info.P[10] != 1.0) {
    return std::string(side) + " camera_info P[10] = " + num(info.P[10]) +
           " (expected 1): the projection matrix is not a rectified pinhole P";
  }
  return "";
}

// At most max_pixels, at least kMinImageSide per side.
std::string checkImageSize(const std::string& side, uint64_t width, uint64_t height, std::size_t max_pixels) {
  if (width * height > max_pixels) {
    return side + " image is " + std::to_string(width) + "x" + std::to_string(height) +
           ", more than max_image_pixels = " + std::to_string(max_pixels) +
           ": downscale the images (image_proc/resize) or raise max_image_pixels";
  }
  if (width < static_cast<uint64_t>(bdis::kMinImageSide) || height < static_cast<uint64_t>(bdis::kMinImageSide)) {
    return side + " image is " + std::to_string(width) + "x" + std::to_string(height) +
           ": each side must be at least " + std::to_string(bdis::kMinImageSide) + " px";
  }
  return "";
}

// "" when P has the form of a rectified camera, [fx 0 cx Tx; 0 fy cy 0; 0 0 1 0]
// (up to rounding), apart from Ty = P[7] and Tz = P[11], which checkTranslation
// checks once the baseline is known; else the first entry that is not.
std::string checkRectifiedForm(const sensor_msgs::CameraInfo& info, const char* side) {
  const struct {
    int index;
    const char* what;
    double tolerance;
  } zeros[] = {{1, "skew", kZeroPixelTolerance * info.P[0]},
               {4, "P[1][0]", kZeroPixelTolerance * info.P[5]},
               {8, "P[2][0]", kZeroPixelTolerance},
               {9, "P[2][1]", kZeroPixelTolerance}};
  for (const auto& zero : zeros) {
    if (std::abs(info.P[zero.index]) > zero.tolerance) {
      return std::string(side) + " camera_info P[" + std::to_string(zero.index) + "] (" + zero.what +
             ") = " + num(info.P[zero.index]) +
             " but a rectified P has 0 there: publish the rectified projection matrix "
             "(stereo calibration, e.g. camera_calibration or stereoRectify), not K";
    }
  }
  return "";
}

// "" when Ty = P[7] and Tz = P[11] are 0 in both cameras (a horizontal pair,
// rectified to one image plane), up to a fraction of the baseline.
std::string checkTranslation(const sensor_msgs::CameraInfo& info, const char* side, double baseline) {
  const double ty_tolerance = kZeroTranslationTolerance * baseline * info.P[5];
  if (std::abs(info.P[7]) > ty_tolerance) {
    return std::string(side) + " camera_info P[7] (Ty) = " + num(info.P[7]) +
           " but a horizontal stereo pair has 0 there (baseline " + num(baseline) +
           "): the cameras are not rectified side by side (vertical pairs are not supported)";
  }
  if (std::abs(info.P[11]) > kZeroTranslationTolerance * baseline) {
    return std::string(side) + " camera_info P[11] (Tz) = " + num(info.P[11]) +
           " but a rectified pair has 0 there: the cameras are not rectified to one image plane";
  }
  return "";
}

/// Sizes `msg` as a dense 32FC1 image and returns a Mat over its data.
cv::Mat floatImageOver(int rows, int cols, sensor_msgs::Image& msg) {
  msg.height = rows;
  msg.width = cols;
  msg.encoding = enc::TYPE_32FC1;
  msg.is_bigendian = 0;
  msg.step = cols * sizeof(float);
  msg.data.resize(static_cast<std::size_t>(msg.step) * msg.height);
  return cv::Mat(rows, cols, CV_32FC1, msg.data.data(), msg.step);
}

// One row of the DisparityImage: d - offset where that is an estimate in
// front of infinity, else kInvalidDisparity. Without branches, so that it
// vectorises.
void shiftedDisparityRow(const float* d, int width, float offset, float* out) {
  for (int x = 0; x < width; ++x) {
    const float shifted = d[x] - offset;
    out[x] = d[x] >= 0.0f && shifted > 0.0f ? shifted : kInvalidDisparity;
  }
}

}  // namespace

bool isSupportedEncoding(const std::string& encoding) { return channelsOf(encoding) > 0; }

std::string checkImage(const sensor_msgs::Image& image, const char* side, std::size_t max_pixels) {
  const std::string s(side);
  if (image.width == 0 || image.height == 0 || image.data.empty()) {
    return s + " image is empty (" + std::to_string(image.width) + "x" +
           std::to_string(image.height) + ", " + std::to_string(image.data.size()) +
           " bytes): is the camera driver running?";
  }
  if (!isSupportedEncoding(image.encoding)) {
    return s + " image has encoding '" + image.encoding +
           "': supported are mono8, bgr8, rgb8, bgra8, rgba8, 8UC1 (as mono8) and 8UC3 (as "
           "bgr8); convert 16-bit or Bayer images first (e.g. image_proc)";
  }
  const std::string size_error = checkImageSize(s, image.width, image.height, max_pixels);
  if (!size_error.empty()) return size_error;
  const std::size_t row_bytes = static_cast<std::size_t>(image.width) * channelsOf(image.encoding);
  if (image.step < row_bytes ||
      image.data.size() < static_cast<std::size_t>(image.step) * image.height) {
    return s + " image message is inconsistent: step = " + std::to_string(image.step) +
           " for width " + std::to_string(image.width) + " (" + image.encoding + ") and " +
           std::to_string(image.data.size()) + " bytes of data for height " +
           std::to_string(image.height);
  }
  return "";
}

std::string decodeCompressedImage(const sensor_msgs::CompressedImage& msg, const char* side, std::size_t max_pixels,
                                  sensor_msgs::Image& image) {
  // The messages are composed only on failure: no strings are built for a good frame.
  const auto what = [&msg, side] { return std::string(side) + " compressed image (format '" + msg.format + "')"; };
  if (msg.data.size() > static_cast<std::size_t>(std::numeric_limits<int>::max())) return what() + " is too large";
  bdis::ImageHeader h;
  if (msg.data.empty()) return what() + " is empty: the frame cannot be decoded";
  if (!bdis::detectImageFormat(msg.data.data(), msg.data.size(), h.format) ||
      (h.format != bdis::ImageHeader::Format::Jpeg && h.format != bdis::ImageHeader::Format::Png)) {
    return what() + " is neither a JPEG nor a PNG: the frame cannot be decoded";
  }
  const std::string header_error = bdis::readImageHeader(msg.data.data(), msg.data.size(), h);
  if (!header_error.empty()) return what() + " " + header_error + ": the frame cannot be decoded";
  const char* kind = bdis::formatName(h.format);
  if (h.bit_depth > 8) {
    return what() + " is a " + std::to_string(h.bit_depth) + "-bit " + kind +
           ": supported are 8-bit JPEG and PNG (mono8, bgr8 or rgb8 images compressed); convert 16-bit "
           "images to 8 bits first";
  }
  const std::string size_error = checkImageSize(std::string(side), h.width, h.height, max_pixels);
  if (!size_error.empty()) return size_error + " (" + kind + ")";

  image.header = msg.header;
  image.height = h.height;
  image.width = h.width;
  image.encoding = h.channels == 1 ? enc::MONO8 : enc::BGR8;
  image.is_bigendian = 0;
  image.step = h.width * h.channels;
  image.data.resize(static_cast<std::size_t>(image.step) * image.height);  // no allocation at an unchanged size
  const cv::Mat target(h.height, h.width, CV_MAKETYPE(CV_8U, h.channels), image.data.data());
  // imdecode with a destination decodes into it when size and type agree,
  // but leaves it untouched, saying nothing, when it cannot read the header:
  // the canary, which decoding overwrites, tells. (An image that happens to
  // start with it is decoded once more, without a destination, to be sure.)
  static const uint8_t kCanary[8] = {0x5A, 0xA5, 0x3C, 0xC3, 0x96, 0x69, 0x0F, 0xF0};
  std::memcpy(image.data.data(), kCanary, sizeof kCanary);  // at least kMinImageSide^2 bytes
  const int flags = (h.channels == 1 ? cv::IMREAD_GRAYSCALE : cv::IMREAD_COLOR) | cv::IMREAD_IGNORE_ORIENTATION;
  try {
    const cv::Mat encoded(1, static_cast<int>(msg.data.size()), CV_8UC1, const_cast<uint8_t*>(msg.data.data()));
    cv::Mat decoded = target;
    cv::imdecode(encoded, flags, &decoded);
    if (decoded.data == target.data && std::memcmp(target.data, kCanary, sizeof kCanary) == 0) {
      decoded = cv::imdecode(encoded, flags);
    }
    if (decoded.empty()) return what() + " is a corrupt " + kind + ": OpenCV cannot decode it";
    if (decoded.size() != target.size() || decoded.type() != target.type()) {
      return what() + " decoded to " + std::to_string(decoded.cols) + "x" + std::to_string(decoded.rows) + "x" +
             std::to_string(decoded.channels()) + " instead of the " + std::to_string(h.width) + "x" +
             std::to_string(h.height) + "x" + std::to_string(h.channels) + " its header gives";
    }
    if (decoded.data != target.data) decoded.copyTo(target);
  } catch (const cv::Exception& e) {
    return what() + " cannot be decoded (" + kind + "): " + e.what();
  }
  return "";
}

bool isRectifiableDistortionModel(const std::string& model) {
  namespace dm = sensor_msgs::distortion_models;
  return model == dm::PLUMB_BOB || model == dm::RATIONAL_POLYNOMIAL || model == dm::EQUIDISTANT;
}

std::string checkRawFrame(const sensor_msgs::Image& image, const sensor_msgs::CameraInfo& info, const char* side,
                          std::size_t max_pixels) {
  std::string error = checkImage(image, side, max_pixels);
  if (!error.empty()) return error;
  const std::string s = std::string(side) + " camera_info";
  for (int i = 0; i < 9; ++i) {
    if (!std::isfinite(info.K[i]) || !std::isfinite(info.R[i])) {
      return s + " K or R has a non-finite entry: the calibration is invalid";
    }
  }
  for (const double d : info.D) {
    if (!std::isfinite(d)) return s + " D has a non-finite entry: the calibration is invalid";
  }
  if (!(info.K[0] > 0.0) || !(info.K[4] > 0.0)) {
    return s + " K[0] (fx) = " + num(info.K[0]) + ", K[4] (fy) = " + num(info.K[4]) +
           ": the camera is not calibrated (image_proc/rectify needs K, D, R and P)";
  }
  if (info.width == 0 || info.height == 0) {
    return s + " gives no image size (width, height): image_proc/rectify needs it";
  }
  // R must rotate: R R^T = I (calibrators write about 9 digits).
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 3; ++col) {
      double dot = 0.0;
      for (int k = 0; k < 3; ++k) dot += info.R[3 * row + k] * info.R[3 * col + k];
      if (std::abs(dot - (row == col ? 1.0 : 0.0)) > 1e-3) {
        return s + " R is not a rotation (an all-zero R means uncalibrated): the calibration is invalid";
      }
    }
  }
  image_geometry::PinholeCameraModel model;
  try {
    model.fromCameraInfo(info);
  } catch (const std::exception& e) {
    return s + " rejected by image_geometry: " + e.what();
  }
  const cv::Size size = model.reducedResolution();
  if (size.width != static_cast<int>(image.width) || size.height != static_cast<int>(image.height)) {
    return s + " is for " + std::to_string(size.width) + "x" + std::to_string(size.height) +
           " (after binning/ROI) but the raw image is " + std::to_string(image.width) + "x" +
           std::to_string(image.height) + ": does the camera_info belong to this camera?";
  }
  const bool distorted = std::any_of(info.D.begin(), info.D.end(), [](double d) { return d != 0.0; });
  if (!distorted) {
    for (int i = 0; i < 9; ++i) {
      if (std::abs(info.R[i] - (i % 4 == 0 ? 1.0 : 0.0)) > 1e-9) {
        return s + " has no distortion (D all zero) but R is not the identity: image_proc/rectify passes such "
                   "an image on unrotated, so the pair would not be rectified";
      }
    }
    return "";
  }
  if (!isRectifiableDistortionModel(info.distortion_model)) {
    return s + " has distortion model '" + info.distortion_model +
           "': image_proc/rectify (image_geometry) undistorts plumb_bob, rational_polynomial and equidistant";
  }
  const std::size_t n = info.D.size();
  const bool count_ok = info.distortion_model == sensor_msgs::distortion_models::EQUIDISTANT
                            ? n == 4
                            : n == 4 || n == 5 || n == 8 || n == 12 || n == 14;
  if (!count_ok) {
    return s + " has " + std::to_string(n) + " distortion coefficients for model '" + info.distortion_model +
           "' (" +
           (info.distortion_model == sensor_msgs::distortion_models::EQUIDISTANT ? "4" : "5, or 4, 8, 12, 14") +
           " expected)";
  }
  return "";
}

std::string checkImagePair(const sensor_msgs::Image& left, const sensor_msgs::Image& right) {
  if (left.width != right.width || left.height != right.height) {
    return "left image is " + std::to_string(left.width) + "x" + std::to_string(left.height) +
           " but right image is " + std::to_string(right.width) + "x" +
           std::to_string(right.height) +
           ": both must be rectified to the same size (check the topics and the rectification)";
  }
  return "";
}

std::string stereoCameraFromInfo(const sensor_msgs::CameraInfo& left,
                                 const sensor_msgs::CameraInfo& right, int image_width,
                                 int image_height, bdis::StereoCamera& camera) {
  for (const auto* info : {&left, &right}) {
    const char* side = info == &left ? "left" : "right";
    std::string err = checkProjection(*info, side);
    if (err.empty()) err = checkRectifiedForm(*info, side);
    if (!err.empty()) return err;
    if (info->binning_x > 64 || info->binning_y > 64) {
      return std::string(side) + " camera_info binning " + std::to_string(info->binning_x) + "x" +
             std::to_string(info->binning_y) + " is not plausible";
    }
  }
  image_geometry::PinholeCameraModel lm, rm;
  try {
    lm.fromCameraInfo(left);
    rm.fromCameraInfo(right);
  } catch (const std::exception& e) {
    return std::string("camera_info rejected by image_geometry: ") + e.what();
  }
  for (const auto* model : {&lm, &rm}) {
    const char* side = model == &lm ? "left" : "right";
    const cv::Size size = model->reducedResolution();
    if (size.width == 0 && size.height == 0) continue;  // camera_info gives no size
    if (size.width != image_width || size.height != image_height) {
      return std::string(side) + " camera_info is for " + std::to_string(size.width) + "x" +
             std::to_string(size.height) + " (after binning/ROI) but the images are " +
             std::to_string(image_width) + "x" + std::to_string(image_height) +
             ": does the camera_info belong to these images?";
    }
  }
  const double fx = lm.fx();
  if (std::abs(rm.fx() - fx) > 1e-3 * fx || std::abs(rm.fy() - lm.fy()) > 1e-3 * lm.fy()) {
    return "left and right camera_info focal lengths differ (fx " + num(fx) + " vs " +
           num(rm.fx()) + ", fy " + num(lm.fy()) + " vs " + num(rm.fy()) +
           "): the pair is not rectified as a stereo pair";
  }
  const double right_tx = rm.Tx();
  if (right_tx == 0.0) {
    return "right camera_info P[3] is 0: is the pair rectified as a stereo pair? "
           "(P[3] = Tx = -fx * baseline, negative for the right camera)";
  }
  // Baseline from the difference of the two P[3] (left P[3] is 0 for the usual
  // left-reference pair, as image_geometry assumes).
  const double baseline = (lm.Tx() - right_tx) / fx;
  if (!(baseline > 0.0)) {
    return "right camera_info P[3] = " + num(right_tx) + " gives baseline " + num(baseline) +
           " <= 0: are the cameras swapped? (the right camera's P[3] must be -fx * baseline < 0)";
  }
  if (!(baseline <= kMaxBaseline)) {
    return "right camera_info P[3] = " + num(right_tx) + " gives baseline " + num(baseline) +
           " (-P[3] / fx), which is not plausible (at most " + num(kMaxBaseline) +
           "): is P[3] = -fx * baseline?";
  }
  for (const auto* info : {&left, &right}) {
    const std::string err = checkTranslation(*info, info == &left ? "left" : "right", baseline);
    if (!err.empty()) return err;
  }
  camera.fx = fx;
  camera.fy = lm.fy();
  camera.cx = lm.cx();
  camera.cy = lm.cy();
  camera.cx_right = rm.cx();
  camera.baseline = baseline;
  try {
    camera.validate();
  } catch (const std::invalid_argument& e) {
    return std::string("camera model from camera_info is invalid: ") + e.what();
  }
  return "";
}

cv::Mat matcherView(const sensor_msgs::Image& image, cv::Mat& buffer) {
  const int channels = channelsOf(image.encoding);
  const int type = CV_MAKETYPE(CV_8U, channels);
  const cv::Mat wrapped(static_cast<int>(image.height), static_cast<int>(image.width), type,
                        const_cast<uint8_t*>(image.data.data()), image.step);
  if (image.encoding == enc::MONO8 || image.encoding == enc::BGR8 ||
      image.encoding == enc::TYPE_8UC1 || image.encoding == enc::TYPE_8UC3) {
    return wrapped;
  }
  int code = cv::COLOR_RGB2BGR;
  if (image.encoding == enc::BGRA8) code = cv::COLOR_BGRA2BGR;
  if (image.encoding == enc::RGBA8) code = cv::COLOR_RGBA2BGR;
  cv::cvtColor(wrapped, buffer, code);
  return buffer;
}

void fillFloatImage(const cv::Mat& image, sensor_msgs::Image& msg) {
  CV_Assert(image.type() == CV_32FC1);
  image.copyTo(floatImageOver(image.rows, image.cols, msg));
}

void fillDisparityImage(const cv::Mat& disparity, const bdis::StereoCamera& camera,
                        stereo_msgs::DisparityImage& msg) {
  CV_Assert(disparity.type() == CV_32FC1);
  cv::Mat out_image = floatImageOver(disparity.rows, disparity.cols, msg.image);
  const float offset = static_cast<float>(camera.cx - camera.cx_right);
  int x0 = disparity.cols, y0 = disparity.rows, x1 = -1, y1 = -1;
  for (int y = 0; y < disparity.rows; ++y) {
    float* out = out_image.ptr<float>(y);
    shiftedDisparityRow(disparity.ptr<float>(y), disparity.cols, offset, out);
    int first = 0, last = disparity.cols - 1;
    while (first < disparity.cols && !(out[first] > 0.0f)) ++first;
    if (first == disparity.cols) continue;  // no estimate in this row
    while (!(out[last] > 0.0f)) --last;
    x0 = std::min(x0, first);
    x1 = std::max(x1, last);
    y0 = std::min(y0, y);
    y1 = y;
  }
  double max_d = 0.0;
  if (x1 >= 0) cv::minMaxIdx(out_image, nullptr, &max_d);
  msg.f = static_cast<float>(camera.fx);
  msg.T = static_cast<float>(camera.baseline);
  msg.min_disparity = 0.0f;
  msg.max_disparity = std::ceil(static_cast<float>(max_d));
  msg.delta_d = 1.0f / 16.0f;
  if (x1 >= 0) {
    msg.valid_window.x_offset = x0;
    msg.valid_window.y_offset = y0;
    msg.valid_window.width = x1 - x0 + 1;
    msg.valid_window.height = y1 - y0 + 1;
  } else {
    msg.valid_window = sensor_msgs::RegionOfInterest();
  }
}

void fillDepthImage(const cv::Mat& disparity, const bdis::StereoCamera& camera,
                    sensor_msgs::Image& msg) {
  cv::Mat out = floatImageOver(disparity.rows, disparity.cols, msg);
  bdis::disparityToDepth(disparity, camera, out);  // same size and type: writes in place
}

void fillPointCloud(const cv::Mat& disparity, const bdis::StereoCamera& camera,
                    const cv::Mat& left_bgr, bool organized, const RigidTransform* transform,
                    cv::Mat& depth, sensor_msgs::PointCloud2& msg) {
  bdis::disparityToDepth(disparity, camera, depth);
  fillPointCloudFromDepth(depth, camera, left_bgr, organized, transform, msg);
}

void fillPointCloudFromDepth(const cv::Mat& depth, const bdis::StereoCamera& camera,
                             const cv::Mat& left_bgr, bool organized, const RigidTransform* transform,
                             sensor_msgs::PointCloud2& msg) {
  CV_Assert(depth.type() == CV_32FC1);
  const bool rgb = !left_bgr.empty() && left_bgr.type() == CV_8UC3 && left_bgr.size() == depth.size();
  const uint32_t point_step = rgb ? bdis::kColouredPointBytes : bdis::kPointBytes;
  if (msg.fields.size() != (rgb ? 4u : 3u)) {
    msg.fields.clear();
    const char* names[] = {"x", "y", "z", "rgb"};
    for (uint32_t i = 0; i < (rgb ? 4u : 3u); ++i) {
      sensor_msgs::PointField f;
      f.name = names[i];
      f.offset = 4 * i;
      f.datatype = sensor_msgs::PointField::FLOAT32;
      f.count = 1;
      msg.fields.push_back(f);
    }
  }
  msg.is_bigendian = false;
  msg.point_step = point_step;
  const std::size_t count = bdis::pointCount(depth, organized);
  // Sized without zero-filling where the message is reused (same size: no-op).
  msg.data.resize(count * point_step);
  bdis::writePointCloud(depth, camera, rgb ? left_bgr : cv::Mat(), organized, transform, point_step,
                        msg.data.data());
  if (organized) {
    msg.height = depth.rows;
    msg.width = depth.cols;
    msg.is_dense = false;
  } else {
    msg.height = 1;
    msg.width = static_cast<uint32_t>(count);
    msg.is_dense = true;
  }
  msg.row_step = msg.width * point_step;
}

std::string rigidTransformFromTf(const geometry_msgs::TransformStamped& tf, RigidTransform& transform) {
  const auto& q = tf.transform.rotation;
  const tf2::Quaternion rotation(q.x, q.y, q.z, q.w);
  // tf2 hands out quaternions as published; normalise, so that a slightly
  // off unit quaternion (rounded by its publisher) still gives a rotation.
  const double norm = rotation.length();
  if (!(norm > 0.0) || !std::isfinite(norm)) return "invalid rotation";
  const tf2::Matrix3x3 r(rotation / norm);
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 3; ++col) transform.r[3 * row + col] = r[row][col];
  }
  transform.t[0] = tf.transform.translation.x;
  transform.t[1] = tf.transform.translation.y;
  transform.t[2] = tf.transform.translation.z;
  return "";
}

}  // namespace bdis_stereo
