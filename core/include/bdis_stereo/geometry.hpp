// From disparity to depth and 3-D points for a rectified stereo pair.
// ROS-free: the ROS layer fills StereoCamera from the two CameraInfos.
#pragma once

#include <cstddef>
#include <cstdint>
#include <opencv2/core.hpp>

namespace bdis {

/// Rectified pinhole stereo pair, left camera as reference.
/// When the rectified principal points differ in x (cx_right != cx), the
/// disparity that corresponds to infinite depth is cx - cx_right, as in
/// image_geometry::StereoCameraModel.
struct StereoCamera {
  double fx = 0.0;        ///< px
  double fy = 0.0;        ///< px
  double cx = 0.0;        ///< left principal point x, px
  double cy = 0.0;        ///< px
  double cx_right = 0.0;  ///< right principal point x, px
  double baseline = 0.0;  ///< > 0; depth and points come out in its unit

  /// Same principal point in both cameras.
  static StereoCamera symmetric(double fx, double fy, double cx, double cy, double baseline);

  /// Throws std::invalid_argument naming the bad field (non-finite, fx/fy <= 0, baseline <= 0).
  void validate() const;

  /// Depth of one disparity; NaN when d is not an estimate or lies at or beyond infinity.
  float depth(float disparity) const;

  /// The camera of the image subsample() keeps with `stride` (>= 1): focal
  /// lengths and principal points divided by stride, the same baseline; its
  /// pixel (x, y) is pixel (stride x, stride y) here.
  StereoCamera subsampled(int stride) const;
};

/// Every `stride`-th pixel of every `stride`-th row of `image`, starting at
/// (0, 0): ceil(cols / stride) x ceil(rows / stride), of any type; `out` is
/// reused when it has that size and type. A depth image keeps its values,
/// so with camera.subsampled(stride) it gives the full image's points at the
/// pixels kept. Throws std::invalid_argument for stride < 1.
void subsample(const cv::Mat& image, int stride, cv::Mat& out);

/// depth = fx * baseline / (d - (cx - cx_right)); CV_32FC1, NaN where unknown.
/// `disparity` is CV_32FC1 with negative values (kNoDisparity) for no estimate.
void disparityToDepth(const cv::Mat& disparity, const StereoCamera& camera, cv::Mat& depth);

/// Points in the left camera's optical frame (x right, y down, z forward);
/// CV_32FC3, NaN in all three channels where unknown.
void disparityToPoints(const cv::Mat& disparity, const StereoCamera& camera, cv::Mat& points);

/// A rigid transform p' = R p + t (row-major R), e.g. from the camera's
/// optical frame into a robot's frame.
struct RigidTransform {
  double r[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  double t[3] = {0, 0, 0};
};

/// Bytes of one point record: float32 x, y, z at offsets 0, 4, 8 and, with
/// colour, the packed BGR as a float32 `rgb` at 12 (PCL: 0x00RRGGBB, native
/// byte order). The smallest point_step writePointCloud takes.
constexpr std::size_t kPointBytes = 12;
constexpr std::size_t kColouredPointBytes = 16;

/// The points writePointCloud writes for `depth`: every pixel when
/// `organized`, else the pixels with a depth (not NaN).
std::size_t pointCount(const cv::Mat& depth, bool organized);

/// The points of a depth image (CV_32FC1 as disparityToDepth writes it, NaN
/// where unknown) in the left camera's optical frame, with the values
/// disparityToPoints gives for the same disparity, written as records of
/// `point_step` bytes into `out` (pointCount(depth, organized) * point_step
/// bytes; the bytes of a record past the fields are left untouched).
/// organized: row by row, every pixel, NaN x, y, z where unknown; otherwise
/// only the pixels with a depth, in raster order. `bgr` (CV_8UC3 of the
/// depth's size, or empty for none) adds the packed colour at byte 12.
/// `transform` (may be null) maps each point into another frame. Throws
/// std::invalid_argument for a wrong depth or colour image, or a point_step
/// too small for the fields.
void writePointCloud(const cv::Mat& depth, const StereoCamera& camera, const cv::Mat& bgr, bool organized,
                     const RigidTransform* transform, std::size_t point_step, uint8_t* out);

}  // namespace bdis
