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
#include "input_sync.hpp"
#include "matcher_reconfigure.hpp"
#include "node_params.hpp"
#include "node_statistics.hpp"
#include "outputs.hpp"

namespace bdis_stereo {

class FramePipeline {
 public:
  /// Listens to tf in `nh` when params.target_frame is set.
  FramePipeline(std::string log_name, const NodeParams& params, const bdis::MatcherParams& matcher_params,
                ros::NodeHandle& nh, Outputs& outputs, NodeStatistics& statistics,
                MatcherReconfigure& reconfigure);

  /// The frame's outputs that have a subscriber; nothing when none has one.
  /// Compressed images are decoded first (into buffers kept from frame to
  /// frame); one that cannot be is a rejected frame like any bad input.
  /// Throws only for what cannot happen with validated input (the worker
  /// counts it as an error).
  void process(const StereoFrame& frame);

 private:
  /// The frame's two images as sensor_msgs/Image: its own, or decoded here.
  struct InputImages {
    const sensor_msgs::Image* left = nullptr;
    const sensor_msgs::Image* right = nullptr;
  };

  /// The images the matcher takes: grey or BGR views, both the same kind.
  struct MatcherInput {
    cv::Mat left, right;
    cv::Mat left_colour;  ///< BGR left image for the cloud's colour; empty for mono
  };

  void noteStamp(const ros::Time& stamp);
  std::string inputImages(const StereoFrame& frame, InputImages& images);
  std::string validate(const InputImages& images, const StereoFrame& frame, bdis::StereoCamera& camera) const;
  MatcherInput matcherInput(const InputImages& images);
  bool camerasLookSwapped(const MatcherInput& input, ros::WallTime now);
  void checkInputCoding(const cv::Mat& left, ros::WallTime now);
  void publish(const std_msgs::Header& header, const sensor_msgs::CameraInfo& left_info,
               const bdis::StereoCamera& camera, const MatcherInput& input, const WantedOutputs& wanted);
  void publishPoints(const std_msgs::Header& header, cv::Mat depth, const bdis::StereoCamera& camera,
                     const cv::Mat& left_colour);
  bool cloudTransform(const std_msgs::Header& header, RigidTransform& transform) const;
  void reject(const std::string& what);

  /// s between two checks of the input (swapped cameras, a block codec's grid)
  static constexpr double kInputCheckPeriod = 1.0;

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
  sensor_msgs::Image decoded_left_, decoded_right_;  ///< built-in decoding of compressed frames
  cv::Mat cloud_disparity_, cloud_colour_;  ///< subsampled for points2 (cloud_stride > 1)
  ros::Time last_stamp_;
  ros::WallTime last_sign_check_;
  bool looks_swapped_ = false;
  ros::WallTime last_coding_check_;
  bool block_coded_ = false;
};

}  // namespace bdis_stereo
