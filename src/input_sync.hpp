// The nodelet's inputs: four subscriptions (left/right image_rect,
// left/right camera_info), subscribed only while an output has a subscriber,
// synchronised by exact or approximate stamps, counted per topic. A jump back
// in time (a looping bag, a restarted driver) replaces the synchroniser, whose
// queues would otherwise hold stale messages that pair late or block new ones.
//
// The images come one of three ways (ImageSource): through image_transport
// (raw, or a plugin that decodes them); as sensor_msgs/CompressedImage on
// <image topic>/compressed when image_transport is "compressed" and its plugin
// is not installed (Debian 12 has none), decoded later by the frame pipeline;
// or, with rectify on, as the image_proc/rectify nodelets publish them in the
// same manager (RectifyFeed hands those nodelets the raw frames).
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
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>

#include "input_status.hpp"

namespace bdis_stereo {

/// A synchronised pair and when it formed. Each image is either a
/// sensor_msgs/Image (`left`, `right`) or, with the built-in decoding, the
/// CompressedImage it still has to be decoded from (`left_compressed`,
/// `right_compressed`): decoding waits for the worker, so that a frame
/// dropped while the worker is busy is never decoded.
struct StereoFrame {
  sensor_msgs::ImageConstPtr left, right;
  sensor_msgs::CompressedImageConstPtr left_compressed, right_compressed;
  sensor_msgs::CameraInfoConstPtr left_info, right_info;
  ros::WallTime arrival;

  const std_msgs::Header& leftHeader() const { return left ? left->header : left_compressed->header; }
};

/// How the nodelet receives left/image_rect and right/image_rect.
enum class ImageSource {
  Transport,          ///< through image_transport with the node's transport hints (raw, or a plugin)
  BuiltinCompressed,  ///< sensor_msgs/CompressedImage on <topic>/compressed, decoded by the frame pipeline
  Rectified,          ///< raw, from the image_proc/rectify nodelets in the same manager (rectify on)
};

class InputSync {
 public:
  using PairCallback = std::function<void(StereoFrame frame)>;

  /// `on_pair` runs for every synchronised pair, on the subscriber thread
  /// that completed it; `log_name` names the log lines (the nodelet's name).
  InputSync(std::string log_name, bool approximate_sync, int queue_size, ImageSource source,
            PairCallback on_pair);

  /// Subscribes to left/image_rect, right/image_rect (as `source` says; with
  /// ImageSource::Transport through `it` with `hints`), left/camera_info,
  /// right/camera_info (through `nh`); a no-op while subscribed.
  void subscribe(image_transport::ImageTransport& it, ros::NodeHandle& nh,
                 const image_transport::TransportHints& hints);
  /// A no-op while not subscribed.
  void unsubscribe();

  bool subscribed() const;
  InputStatus status() const;

 private:
  using Image = sensor_msgs::Image;
  using CompressedImage = sensor_msgs::CompressedImage;
  using CameraInfo = sensor_msgs::CameraInfo;

  /// Exact or approximate synchroniser of two images of type ImageMsg and
  /// the two camera_infos; only one of the two exists.
  template <class ImageMsg>
  struct Synchronisers {
    using Exact = message_filters::sync_policies::ExactTime<ImageMsg, ImageMsg, CameraInfo, CameraInfo>;
    using Approx = message_filters::sync_policies::ApproximateTime<ImageMsg, ImageMsg, CameraInfo, CameraInfo>;
    std::unique_ptr<message_filters::Synchronizer<Exact>> exact;
    std::unique_ptr<message_filters::Synchronizer<Approx>> approx;

    template <int I, class M>
    void add(const boost::shared_ptr<M const>& msg) {
      if (approx) approx->template add<I>(msg);
      if (exact) exact->template add<I>(msg);
    }
  };

  void createSync();
  template <int I, class M>
  void feed(const boost::shared_ptr<M const>& msg);
  void count(int input, const std_msgs::Header& header);
  void onImagePair(const sensor_msgs::ImageConstPtr& l, const sensor_msgs::ImageConstPtr& r,
                   const sensor_msgs::CameraInfoConstPtr& li, const sensor_msgs::CameraInfoConstPtr& ri);
  void onCompressedPair(const sensor_msgs::CompressedImageConstPtr& l, const sensor_msgs::CompressedImageConstPtr& r,
                        const sensor_msgs::CameraInfoConstPtr& li, const sensor_msgs::CameraInfoConstPtr& ri);
  void onPair(StereoFrame frame);
  std::array<std::string, 2> imageTopics() const;

  const std::string log_name_;
  const bool approximate_sync_;
  const int queue_size_;
  const ImageSource source_;
  const PairCallback on_pair_;

  // Subscriptions, under connection_mutex_: one pair of image subscribers
  // per ImageSource. Unsubscribing waits for running input callbacks, so no
  // input callback may take this mutex.
  mutable std::mutex connection_mutex_;
  bool subscribed_ = false;
  image_transport::SubscriberFilter left_transport_, right_transport_;
  message_filters::Subscriber<CompressedImage> left_compressed_, right_compressed_;
  message_filters::Subscriber<Image> left_rectified_, right_rectified_;
  message_filters::Subscriber<CameraInfo> left_info_, right_info_;

  // The inputs reach the synchroniser through feed(), under sync_mutex_, not
  // through message_filters connections, so that it can be replaced.
  mutable std::mutex sync_mutex_;
  Synchronisers<Image> image_sync_;
  Synchronisers<CompressedImage> compressed_sync_;
  std::array<ros::Time, 4> last_stamps_{};  ///< per input, since the last reset
  InputCounts counts_, at_last_pair_;
  ros::WallTime last_pair_time_;
  uint32_t last_left_seq_ = 0;
  bool have_left_seq_ = false;
};

}  // namespace bdis_stereo
