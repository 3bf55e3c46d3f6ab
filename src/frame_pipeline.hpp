// One synchronised stereo frame through the nodelet: validate, compute,
// publish. Runs on the worker thread only; reports to NodeStatistics. Bad
// input is a dropped frame with a clear, throttled error, never an exception.
#pragma once

#include <memory>
#include <string>

#include <opencv2/core.hpp>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include "bdis_stereo/matcher.hpp"
#include "matcher_reconfigure.hpp"
#include "node_params.hpp"
#include "node_statistics.hpp"
#include "outputs.hpp"

namespace bdis_stereo {

/// A synchronised pair and when it formed.
struct StereoFrame {
  sensor_msgs::ImageConstPtr left, right;
  sensor_msgs::CameraInfoConstPtr left_info, right_info;
  ros::WallTime arrival;
};

class FramePipeline {
 public:
  /// Listens to tf in `nh` when params.target_frame is set.
  FramePipeline(std::string log_name, const NodeParams& params, const bdis::MatcherParams& matcher_params,
                ros::NodeHandle& nh, Outputs& outputs, NodeStatistics& statistics,
                MatcherReconfigure& reconfigure);

  /// The frame's outputs that have a subscriber; nothing when none has one.
  /// Throws only for what cannot happen with validated input (the worker
  /// counts it as an error).
  void process(const StereoFrame& frame);

 private:
  /// The images the matcher takes: grey or BGR views, both the same kind.
  struct MatcherInput {
    cv::Mat left, right;
    cv::Mat left_colour;  ///< BGR left image for the cloud's colour; empty for mono
  };

  void noteStamp(const ros::Time& stamp);
  std::string validate(const StereoFrame& frame, bdis::StereoCamera& camera) const;
  MatcherInput matcherInput(const StereoFrame& frame);
  bool camerasLookSwapped(const MatcherInput& input, ros::WallTime now);
  void publish(const StereoFrame& frame, const bdis::StereoCamera& camera, const MatcherInput& input,
               const WantedOutputs& wanted);
  void publishPoints(const std_msgs::Header& header, cv::Mat depth, const bdis::StereoCamera& camera,
                     const cv::Mat& left_colour);
  bool cloudTransform(const std_msgs::Header& header, RigidTransform& transform) const;
  void reject(const std::string& what);

  static constexpr double kSignCheckPeriod = 1.0;  ///< s between checks for swapped cameras

  const std::string log_name_;
  const NodeParams params_;
  Outputs& outputs_;
  NodeStatistics& statistics_;
  MatcherReconfigure& reconfigure_;
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;

  bdis::Matcher matcher_;
  bdis::MatchResult result_;
  // Reused from frame to frame (no allocation once the size is known).
  cv::Mat left_buffer_, right_buffer_, grey_buffer_;
  cv::Mat depth_buffer_;  ///< depth for points2 while depth/image_rect has no subscriber
  cv::Mat cloud_disparity_, cloud_colour_;  ///< subsampled for points2 (cloud_stride > 1)
  ros::Time last_stamp_;
  ros::WallTime last_sign_check_;
  bool looks_swapped_ = false;
};

}  // namespace bdis_stereo
