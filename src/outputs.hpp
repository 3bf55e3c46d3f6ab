// The nodelet's six outputs: one publisher and one small function each.
// Messages are reused once every subscriber has let go of them (no fresh
// multi-megabyte buffers per frame); conversions are ros_frame's.
#pragma once

#include <functional>

#include <image_transport/image_transport.h>
#include <opencv2/core.hpp>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <stereo_msgs/DisparityImage.h>

#include "ros_frame.hpp"

namespace bdis_stereo {

/// The outputs that have a subscriber: only these are computed.
struct WantedOutputs {
  bool disparity = false, disparity_image = false, depth = false, confidence = false, variance = false,
       points = false;
  bool any() const { return disparity || disparity_image || depth || confidence || variance || points; }
};

class Outputs {
 public:
  /// Advertises disparity, points2, depth/image_rect (+ depth/camera_info),
  /// confidence, variance and disparity_image in `nh`'s namespace;
  /// `on_connection` runs whenever a subscriber comes or goes.
  void advertise(ros::NodeHandle& nh, image_transport::ImageTransport& it,
                 const std::function<void()>& on_connection);

  WantedOutputs wanted() const;

  /// `disparity` (stereo_msgs) and/or `disparity_image` (its image alone, for rviz).
  void publishDisparity(const std_msgs::Header& header, const cv::Mat& disparity,
                        const bdis::StereoCamera& camera, const WantedOutputs& wanted);
  /// `depth/image_rect` with the left camera_info; returns the depth image (a
  /// view of the published message, to be read, never written).
  cv::Mat publishDepth(const std_msgs::Header& header, const cv::Mat& disparity,
                       const bdis::StereoCamera& camera, const sensor_msgs::CameraInfo& left_info);
  void publishConfidence(const std_msgs::Header& header, const cv::Mat& confidence);
  void publishVariance(const std_msgs::Header& header, const cv::Mat& variance);
  /// `points2` from a depth image, in the camera's frame or, with a
  /// `transform`, in `target_frame` (the frame it maps into).
  void publishPoints(const std_msgs::Header& header, const cv::Mat& depth, const bdis::StereoCamera& camera,
                     const cv::Mat& left_bgr, bool organized, const RigidTransform* transform,
                     const std::string& target_frame);

 private:
  ros::Publisher disparity_pub_, points_pub_;
  image_transport::CameraPublisher depth_pub_;
  image_transport::Publisher confidence_pub_, variance_pub_, disparity_image_pub_;
  stereo_msgs::DisparityImagePtr disparity_msg_;
  sensor_msgs::ImagePtr disparity_image_msg_, depth_msg_, confidence_msg_, variance_msg_;
  sensor_msgs::PointCloud2Ptr points_msg_;
};

}  // namespace bdis_stereo
