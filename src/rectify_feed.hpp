// With rectify on, the nodelet's inputs are raw: left/image_raw and
// right/image_raw as the camera driver publishes them (through the node's
// image transport, or compressed and decoded here) and the calibrator's
// camera_infos (D, K, R, P). Two image_proc/rectify nodelets in the same
// manager (bdis_stereo.launch rectify:=true loads them) undistort them into
// left/image_rect and right/image_rect, which InputSync matches.
//
// They read the raw frames from here (<side>/rectify_input/image and
// <side>/rectify_input/camera_info), not from the raw topics, because
// image_proc/rectify cannot be given bad input: for a distortion model
// image_geometry does not know, or a number of coefficients OpenCV does not
// take, it throws out of its callback and the manager ends; a raw image of
// another size than its camera_info it remaps to the camera_info's size
// without a word. So each side's image and camera_info are paired by stamp
// and checked (checkRawFrame) first; a frame that fails is dropped here and
// reported once per stamp. A good one is passed on as the same shared
// messages: no copy inside the manager.
#pragma once

#include <array>
#include <cstddef>
#include <deque>
#include <functional>
#include <mutex>
#include <string>

#include <image_transport/image_transport.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>

namespace bdis_stereo {

class RectifyFeed {
 public:
  /// Receives what is wrong with a dropped raw frame, once per stamp.
  using RejectCallback = std::function<void(const std::string& what)>;

  /// `builtin_compressed`: subscribe to <side>/image_raw/compressed and
  /// decode here (no image_transport plugin for it).
  RectifyFeed(std::string log_name, int queue_size, std::size_t max_image_pixels, bool builtin_compressed,
              RejectCallback on_reject);

  /// Advertises what the image_proc/rectify nodelets read.
  void advertise(ros::NodeHandle& nh);
  /// Subscribes to left/image_raw, right/image_raw (through `it` with
  /// `hints`, or their /compressed topics), left/camera_info and
  /// right/camera_info; a no-op while subscribed.
  void subscribe(image_transport::ImageTransport& it, ros::NodeHandle& nh,
                 const image_transport::TransportHints& hints);
  void unsubscribe();

 private:
  /// One camera: its subscriptions, the messages waiting for their partner
  /// of the same stamp (oldest first, at most queue_size each), its publishers.
  struct Side {
    const char* name = "";
    std::mutex mutex;  ///< the waiting messages
    std::deque<sensor_msgs::ImageConstPtr> images;
    std::deque<sensor_msgs::CameraInfoConstPtr> infos;
    image_transport::Subscriber image_sub;
    ros::Subscriber compressed_sub, info_sub;
    ros::Publisher image_pub, info_pub;
  };

  void onImage(Side& side, const sensor_msgs::ImageConstPtr& image);
  void onCompressed(Side& side, const sensor_msgs::CompressedImageConstPtr& msg);
  void onInfo(Side& side, const sensor_msgs::CameraInfoConstPtr& info);
  void forward(Side& side, const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfoConstPtr& info);
  void reject(const ros::Time& stamp, const std::string& what);

  const std::string log_name_;
  const std::size_t queue_size_;
  const std::size_t max_image_pixels_;
  const bool builtin_compressed_;
  const RejectCallback on_reject_;

  std::mutex connection_mutex_;  ///< subscribe / unsubscribe
  bool subscribed_ = false;
  std::array<Side, 2> sides_;

  std::mutex reject_mutex_;
  ros::Time last_rejected_stamp_;
};

}  // namespace bdis_stereo
