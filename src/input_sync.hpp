// The nodelet's inputs: four subscriptions (left/right image_rect through
// image_transport, left/right camera_info), subscribed only while an output
// has a subscriber, synchronised by exact or approximate stamps, counted per
// topic. A jump back in time (a looping bag, a restarted driver) replaces the
// synchroniser, whose queues would otherwise hold stale messages that pair
// late or block new ones.
#pragma once

#include <array>
#include <functional>
#include <memory>
#include <mutex>
#include <string>

#include <image_transport/image_transport.h>
#include <image_transport/subscriber_filter.h>
#include <message_filters/subscriber.h>
#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/sync_policies/exact_time.h>
#include <message_filters/synchronizer.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include "input_status.hpp"

namespace bdis_stereo {

class InputSync {
 public:
  using PairCallback = std::function<void(
      const sensor_msgs::ImageConstPtr& left, const sensor_msgs::ImageConstPtr& right,
      const sensor_msgs::CameraInfoConstPtr& left_info, const sensor_msgs::CameraInfoConstPtr& right_info)>;

  /// `on_pair` runs for every synchronised pair, on the subscriber thread
  /// that completed it; `log_name` names the log lines (the nodelet's name).
  InputSync(std::string log_name, bool approximate_sync, int queue_size, PairCallback on_pair);

  /// Subscribes to left/image_rect, right/image_rect (through `it`, with
  /// `hints`), left/camera_info, right/camera_info (through `nh`); a no-op
  /// while subscribed.
  void subscribe(image_transport::ImageTransport& it, ros::NodeHandle& nh,
                 const image_transport::TransportHints& hints);
  /// A no-op while not subscribed.
  void unsubscribe();

  bool subscribed() const;
  InputStatus status() const;

 private:
  using Image = sensor_msgs::Image;
  using CameraInfo = sensor_msgs::CameraInfo;
  using ExactPolicy = message_filters::sync_policies::ExactTime<Image, Image, CameraInfo, CameraInfo>;
  using ApproxPolicy = message_filters::sync_policies::ApproximateTime<Image, Image, CameraInfo, CameraInfo>;

  void createSync();
  template <int I, class M>
  void feed(const boost::shared_ptr<M const>& msg);
  void count(int input, const std_msgs::Header& header);
  void onPair(const sensor_msgs::ImageConstPtr& l, const sensor_msgs::ImageConstPtr& r,
              const sensor_msgs::CameraInfoConstPtr& li, const sensor_msgs::CameraInfoConstPtr& ri);

  const std::string log_name_;
  const bool approximate_sync_;
  const int queue_size_;
  const PairCallback on_pair_;

  // Subscriptions, under connection_mutex_. Unsubscribing waits for running
  // input callbacks, so no input callback may take this mutex.
  mutable std::mutex connection_mutex_;
  bool subscribed_ = false;
  image_transport::SubscriberFilter left_image_, right_image_;
  message_filters::Subscriber<CameraInfo> left_info_, right_info_;

  // The inputs reach the synchroniser through feed(), under sync_mutex_, not
  // through message_filters connections, so that it can be replaced.
  mutable std::mutex sync_mutex_;
  std::unique_ptr<message_filters::Synchronizer<ExactPolicy>> exact_sync_;
  std::unique_ptr<message_filters::Synchronizer<ApproxPolicy>> approx_sync_;
  std::array<ros::Time, 4> last_stamps_{};  ///< per input, since the last reset
  InputCounts counts_, at_last_pair_;
  ros::WallTime last_pair_time_;
  uint32_t last_left_seq_ = 0;
  bool have_left_seq_ = false;
};

}  // namespace bdis_stereo
