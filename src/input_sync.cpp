#include "input_sync.hpp"

#include <utility>

namespace bdis_stereo {
namespace {
const char* const kInputNames[] = {"left image", "right image", "left camera_info", "right camera_info"};
}  // namespace

InputSync::InputSync(std::string log_name, bool approximate_sync, int queue_size, PairCallback on_pair)
    : log_name_(std::move(log_name)),
      approximate_sync_(approximate_sync),
      queue_size_(queue_size),
      on_pair_(std::move(on_pair)),
      last_pair_time_(ros::WallTime::now()) {
  createSync();
  left_image_.registerCallback(boost::function<void(const sensor_msgs::ImageConstPtr&)>(
      [this](const sensor_msgs::ImageConstPtr& m) { feed<0>(m); }));
  right_image_.registerCallback(boost::function<void(const sensor_msgs::ImageConstPtr&)>(
      [this](const sensor_msgs::ImageConstPtr& m) { feed<1>(m); }));
  left_info_.registerCallback(boost::function<void(const sensor_msgs::CameraInfoConstPtr&)>(
      [this](const sensor_msgs::CameraInfoConstPtr& m) { feed<2>(m); }));
  right_info_.registerCallback(boost::function<void(const sensor_msgs::CameraInfoConstPtr&)>(
      [this](const sensor_msgs::CameraInfoConstPtr& m) { feed<3>(m); }));
}

void InputSync::subscribe(image_transport::ImageTransport& it, ros::NodeHandle& nh,
                          const image_transport::TransportHints& hints) {
  std::lock_guard<std::mutex> lock(connection_mutex_);
  if (subscribed_) return;
  left_image_.subscribe(it, "left/image_rect", queue_size_, hints);
  right_image_.subscribe(it, "right/image_rect", queue_size_, hints);
  left_info_.subscribe(nh, "left/camera_info", queue_size_);
  right_info_.subscribe(nh, "right/camera_info", queue_size_);
  subscribed_ = true;
  {
    // The "no pair" clock starts now, not at the last pair of an earlier subscription.
    std::lock_guard<std::mutex> sync(sync_mutex_);
    last_pair_time_ = ros::WallTime::now();
    at_last_pair_ = counts_;
  }
  ROS_DEBUG_NAMED(log_name_, "output subscribed: subscribing to %s, %s, %s, %s",
                  left_image_.getTopic().c_str(), right_image_.getTopic().c_str(),
                  left_info_.getTopic().c_str(), right_info_.getTopic().c_str());
}

void InputSync::unsubscribe() {
  std::lock_guard<std::mutex> lock(connection_mutex_);
  if (!subscribed_) return;
  left_image_.unsubscribe();
  right_image_.unsubscribe();
  left_info_.unsubscribe();
  right_info_.unsubscribe();
  subscribed_ = false;
  ROS_DEBUG_NAMED(log_name_, "no output subscribers: unsubscribed from the inputs");
}

bool InputSync::subscribed() const {
  std::lock_guard<std::mutex> lock(connection_mutex_);
  return subscribed_;
}

InputStatus InputSync::status() const {
  InputStatus s;
  {
    std::lock_guard<std::mutex> lock(connection_mutex_);
    s.subscribed = subscribed_;
    s.topics = {left_image_.getTopic(), right_image_.getTopic(), left_info_.getTopic(),
                right_info_.getTopic()};
  }
  std::lock_guard<std::mutex> lock(sync_mutex_);
  s.seconds_since_pair = (ros::WallTime::now() - last_pair_time_).toSec();
  s.total = counts_;
  s.since_pair.left_images = counts_.left_images - at_last_pair_.left_images;
  s.since_pair.left_images_lost = counts_.left_images_lost - at_last_pair_.left_images_lost;
  s.since_pair.right_images = counts_.right_images - at_last_pair_.right_images;
  s.since_pair.left_infos = counts_.left_infos - at_last_pair_.left_infos;
  s.since_pair.right_infos = counts_.right_infos - at_last_pair_.right_infos;
  s.since_pair.time_jumps = counts_.time_jumps - at_last_pair_.time_jumps;
  return s;
}

void InputSync::createSync() {
  const auto cb = boost::bind(&InputSync::onPair, this, boost::placeholders::_1, boost::placeholders::_2,
                              boost::placeholders::_3, boost::placeholders::_4);
  if (approximate_sync_) {
    approx_sync_.reset(new message_filters::Synchronizer<ApproxPolicy>(ApproxPolicy(queue_size_)));
    approx_sync_->registerCallback(cb);
  } else {
    exact_sync_.reset(new message_filters::Synchronizer<ExactPolicy>(ExactPolicy(queue_size_)));
    exact_sync_->registerCallback(cb);
  }
  last_stamps_.fill(ros::Time());
}

// Called with sync_mutex_ held.
void InputSync::count(int input, const std_msgs::Header& header) {
  switch (input) {
    case 0: {
      ++counts_.left_images;
      // A full subscriber queue drops the oldest message without a word:
      // count the gaps of the publisher's sequence number. A seq that does
      // not advance (drivers that leave it 0) or goes back (a new publisher,
      // a bag loop) only restarts the count.
      const uint32_t seq = header.seq;
      if (have_left_seq_ && seq > last_left_seq_ && seq - last_left_seq_ < 1000000u)
        counts_.left_images_lost += seq - last_left_seq_ - 1;
      last_left_seq_ = seq;
      have_left_seq_ = true;
      break;
    }
    case 1:
      ++counts_.right_images;
      break;
    case 2:
      ++counts_.left_infos;
      break;
    default:
      ++counts_.right_infos;
      break;
  }
}

template <int I, class M>
void InputSync::feed(const boost::shared_ptr<M const>& msg) {
  std::lock_guard<std::mutex> lock(sync_mutex_);
  count(I, msg->header);
  const ros::Time stamp = msg->header.stamp;
  ros::Time& last = last_stamps_[I];
  if (!last.isZero() && stamp < last) {
    // The first input to show the jump resets; the others then start afresh.
    ROS_WARN_NAMED(log_name_,
                   "%s stamp jumped back from %.3f to %.3f (bag loop or restart): synchroniser reset",
                   kInputNames[I], last.toSec(), stamp.toSec());
    createSync();
    ++counts_.time_jumps;
  }
  last = stamp;
  if (approx_sync_) {
    approx_sync_->add<I>(msg);
  } else {
    exact_sync_->add<I>(msg);
  }
}

// Called from feed(), with sync_mutex_ held.
void InputSync::onPair(const sensor_msgs::ImageConstPtr& l, const sensor_msgs::ImageConstPtr& r,
                       const sensor_msgs::CameraInfoConstPtr& li, const sensor_msgs::CameraInfoConstPtr& ri) {
  last_pair_time_ = ros::WallTime::now();
  at_last_pair_ = counts_;
  on_pair_(l, r, li, ri);
}

}  // namespace bdis_stereo
