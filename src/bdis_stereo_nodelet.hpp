// The bdis_stereo nodelet: synchronised rectified stereo in; disparity, depth,
// confidence, variance and PointCloud2 out. Thin: validation and message
// conversion live in ros_frame.hpp, the matcher in the ROS-free core.
//
// Threads: subscriber callbacks (the manager's queue) only hand the latest
// synchronised frame to one worker thread (a one-slot mailbox); a frame that
// is still waiting when a newer one arrives is dropped and counted, so latency
// never grows with load. Nothing throws out of a callback.
#pragma once

#include <atomic>
#include <array>
#include <condition_variable>
#include <map>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <boost/thread/recursive_mutex.hpp>
#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <image_transport/image_transport.h>
#include <image_transport/subscriber_filter.h>
#include <message_filters/subscriber.h>
#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/sync_policies/exact_time.h>
#include <message_filters/synchronizer.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <stereo_msgs/DisparityImage.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include "bdis_stereo/BdisStereoConfig.h"
#include "bdis_stereo/matcher.hpp"
#include "ros_frame.hpp"

namespace bdis_stereo {

class BdisStereoNodelet : public nodelet::Nodelet {
 public:
  BdisStereoNodelet();
  ~BdisStereoNodelet() override;

 private:
  using Image = sensor_msgs::Image;
  using CameraInfo = sensor_msgs::CameraInfo;
  using ExactPolicy = message_filters::sync_policies::ExactTime<Image, Image, CameraInfo, CameraInfo>;
  using ApproxPolicy =
      message_filters::sync_policies::ApproximateTime<Image, Image, CameraInfo, CameraInfo>;
  using ExactSync = message_filters::Synchronizer<ExactPolicy>;
  using ApproxSync = message_filters::Synchronizer<ApproxPolicy>;

  struct Frame {
    sensor_msgs::ImageConstPtr left, right;
    sensor_msgs::CameraInfoConstPtr left_info, right_info;
    ros::WallTime arrival;
  };

  void onInit() override;
  void loadStartupParams(ros::NodeHandle& pnh);
  void connectCb();
  void frameCb(const sensor_msgs::ImageConstPtr& l, const sensor_msgs::ImageConstPtr& r,
               const sensor_msgs::CameraInfoConstPtr& li, const sensor_msgs::CameraInfoConstPtr& ri);
  void workerLoop();
  void process(const Frame& frame);
  void reject(const std::string& what);
  void reconfigureCb(BdisStereoConfig& config, uint32_t level);
  void watchdogCb(const ros::WallTimerEvent&);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat);

  // Parameters fixed at start-up.
  bool approximate_sync_ = false;
  int queue_size_ = 5;
  bool organized_cloud_ = true;
  std::string target_frame_;
  double tf_timeout_ = 0.01;
  std::size_t max_image_pixels_ = kDefaultMaxImagePixels;
  double sync_warn_timeout_ = 3.0;

  // Subscriptions (lazy: only while an output has a subscriber).
  std::mutex connect_mutex_;
  bool subscribed_ = false;
  std::shared_ptr<image_transport::ImageTransport> it_;
  image_transport::SubscriberFilter sub_l_image_, sub_r_image_;
  message_filters::Subscriber<CameraInfo> sub_l_info_, sub_r_info_;
  // The inputs reach the synchroniser through feedSync, under sync_mutex_, not
  // through message_filters connections: a jump back in time (a looping bag, a
  // restarted driver) replaces the synchroniser, whose queues would otherwise
  // hold stale messages that pair late or block new ones.
  std::mutex sync_mutex_;
  std::unique_ptr<ExactSync> exact_sync_;
  std::unique_ptr<ApproxSync> approx_sync_;
  std::array<ros::Time, 4> last_input_stamps_{};  // per input, since the last reset
  void createSync();
  template <int I, class M>
  void feedSync(const boost::shared_ptr<M const>& msg);

  // Outputs.
  ros::Publisher pub_disparity_, pub_points_;
  image_transport::CameraPublisher pub_depth_;
  image_transport::Publisher pub_confidence_, pub_variance_, pub_disparity_image_;

  // Matcher parameters: dynamic_reconfigure writes, the worker applies.
  boost::recursive_mutex config_mutex_;
  std::unique_ptr<dynamic_reconfigure::Server<BdisStereoConfig>> reconfigure_server_;
  std::string preset_ = "balanced";
  bdis::MatcherParams params_;  // current (validated)
  std::mutex params_mutex_;
  bool params_changed_ = false;
  bdis::MatcherParams pending_params_;

  // Worker.
  std::thread worker_;
  std::mutex frame_mutex_;
  std::condition_variable frame_cv_;
  bool has_pending_ = false;
  bool stop_ = false;
  Frame pending_;
  bdis::Matcher matcher_;
  bdis::MatchResult result_;
  cv::Mat left_buffer_, right_buffer_, grey_buffer_;
  cv::Mat depth_buffer_;  ///< depth for points2 while depth/image_rect has no subscriber
  // Output messages, reused once every subscriber has let go of them.
  stereo_msgs::DisparityImagePtr disparity_msg_;
  sensor_msgs::ImagePtr disparity_image_msg_, depth_msg_, confidence_msg_, variance_msg_;
  sensor_msgs::PointCloud2Ptr points_msg_;
  ros::Time last_stamp_;

  // tf (only when target_frame is set).
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;

  // Statistics (diagnostics; counters read by scripts).
  std::mutex stats_mutex_;
  struct Counters {
    uint64_t left_images = 0, right_images = 0, left_infos = 0, right_infos = 0;
    uint64_t left_images_lost = 0;  // gaps in the left image's header.seq: lost before this nodelet
    uint64_t frames_in = 0;       // synchronised pairs received
    uint64_t frames_out = 0;      // pairs processed and published
    uint64_t dropped_busy = 0;    // replaced in the mailbox while the worker was busy
    uint64_t rejected = 0;        // failed validation (bad input)
    uint64_t errors = 0;          // exception while processing
    uint64_t time_jumps = 0;      // input stamps went back: synchroniser and tf buffer reset
  };
  Counters total_, window_start_;
  static constexpr double kSignCheckPeriod = 1.0;  // s between checks for swapped cameras
  ros::WallTime last_sign_check_;
  bool looks_swapped_ = false;
  uint32_t last_left_seq_ = 0;
  bool have_left_seq_ = false;
  ros::WallTime window_start_time_;
  double proc_ms_sum_ = 0.0, proc_ms_max_ = 0.0;
  uint64_t proc_count_ = 0;
  std::vector<double> latencies_ms_;  // ring buffer of recent latencies
  std::size_t latency_next_ = 0;
  std::string last_error_;
  std::map<std::string, ros::WallTime> reject_logged_;
  ros::WallTime last_pair_time_;
  Counters at_last_pair_;
  std::unique_ptr<diagnostic_updater::Updater> updater_;
  ros::WallTimer watchdog_timer_;
};

}  // namespace bdis_stereo
