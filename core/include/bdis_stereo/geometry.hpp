// From disparity to depth and 3-D points for a rectified stereo pair.
// ROS-free: the ROS layer fills StereoCamera from the two CameraInfos.
#pragma once

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
};

/// depth = fx * baseline / (d - (cx - cx_right)); CV_32FC1, NaN where unknown.
/// `disparity` is CV_32FC1 with negative values (kNoDisparity) for no estimate.
void disparityToDepth(const cv::Mat& disparity, const StereoCamera& camera, cv::Mat& depth);

/// Points in the left camera's optical frame (x right, y down, z forward);
/// CV_32FC3, NaN in all three channels where unknown.
void disparityToPoints(const cv::Mat& disparity, const StereoCamera& camera, cv::Mat& points);

}  // namespace bdis
