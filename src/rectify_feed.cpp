#include "rectify_feed.hpp"

#include <algorithm>
#include <utility>

#include <boost/make_shared.hpp>

#include "ros_frame.hpp"

namespace bdis_stereo {
namespace {

// The message of `queue` with `stamp`, removed with every message that came
// before it (a camera's stamps increase, so those will find no partner);
// null if there is none.
template <class Ptr>
Ptr takeMatch(std::deque<Ptr>& queue, const ros::Time& stamp) {
  const auto it = std::find_if(queue.begin(), queue.end(), [&stamp](const Ptr& m) { return m->header.stamp == stamp; });
  if (it == queue.end()) return Ptr();
  Ptr match = *it;
  queue.erase(queue.begin(), it + 1);
  return match;
}

// Keeps `msg` waiting for its partner. The oldest arrivals go first, so
// after a jump back in time (a looping bag) the stale ones leave soon.
template <class Ptr>
void keep(std::deque<Ptr>& queue, const Ptr& msg, std::size_t queue_size) {
  queue.push_back(msg);
  while (queue.size() > queue_size) queue.pop_front();
}

}  // namespace

RectifyFeed::RectifyFeed(std::string log_name, int queue_size, std::size_t max_image_pixels, bool builtin_compressed,
                         RejectCallback on_reject)
    : log_name_(std::move(log_name)),
      queue_size_(static_cast<std::size_t>(std::max(queue_size, 1))),
      max_image_pixels_(max_image_pixels),
      builtin_compressed_(builtin_compressed),
      on_reject_(std::move(on_reject)) {
  sides_[0].name = "left";
  sides_[1].name = "right";
}

void RectifyFeed::advertise(ros::NodeHandle& nh) {
  for (Side& side : sides_) {
    const std::string ns = std::string(side.name) + "/rectify_input/";
    side.image_pub = nh.advertise<sensor_msgs::Image>(ns + "image", queue_size_);
    side.info_pub = nh.advertise<sensor_msgs::CameraInfo>(ns + "camera_info", queue_size_);
  }
}

void RectifyFeed::subscribe(image_transport::ImageTransport& it, ros::NodeHandle& nh,
                            const image_transport::TransportHints& hints) {
  std::lock_guard<std::mutex> lock(connection_mutex_);
  if (subscribed_) return;
  for (Side& side : sides_) {
    const std::string ns(side.name);
    Side* s = &side;
    if (builtin_compressed_) {
      side.compressed_sub = nh.subscribe<sensor_msgs::CompressedImage>(
          ns + "/image_raw/compressed", queue_size_,
          boost::function<void(const sensor_msgs::CompressedImageConstPtr&)>(
              [this, s](const sensor_msgs::CompressedImageConstPtr& m) { onCompressed(*s, m); }));
    } else {
      side.image_sub = it.subscribe(
          ns + "/image_raw", queue_size_,
          boost::function<void(const sensor_msgs::ImageConstPtr&)>(
              [this, s](const sensor_msgs::ImageConstPtr& m) { onImage(*s, m); }),
          ros::VoidPtr(), hints);
    }
    side.info_sub = nh.subscribe<sensor_msgs::CameraInfo>(
        ns + "/camera_info", queue_size_,
        boost::function<void(const sensor_msgs::CameraInfoConstPtr&)>(
            [this, s](const sensor_msgs::CameraInfoConstPtr& m) { onInfo(*s, m); }));
  }
  subscribed_ = true;
}

void RectifyFeed::unsubscribe() {
  std::lock_guard<std::mutex> lock(connection_mutex_);
  if (!subscribed_) return;
  for (Side& side : sides_) {
    side.image_sub.shutdown();
    side.compressed_sub.shutdown();
    side.info_sub.shutdown();
    std::lock_guard<std::mutex> waiting(side.mutex);
    side.images.clear();
    side.infos.clear();
  }
  subscribed_ = false;
}

// Nothing may throw out of the callbacks below (it would end the manager).
void RectifyFeed::onImage(Side& side, const sensor_msgs::ImageConstPtr& image) {
  try {
    sensor_msgs::CameraInfoConstPtr info;
    {
      std::lock_guard<std::mutex> lock(side.mutex);
      info = takeMatch(side.infos, image->header.stamp);
      if (!info) keep(side.images, image, queue_size_);
    }
    if (info) forward(side, image, info);
  } catch (const std::exception& e) {
    ROS_ERROR_THROTTLE_NAMED(5.0, log_name_, "%s raw image dropped: %s", side.name, e.what());
  }
}

// Decoded into a new message: it is handed on to image_proc/rectify, which
// keeps it as long as it wants.
void RectifyFeed::onCompressed(Side& side, const sensor_msgs::CompressedImageConstPtr& msg) {
  try {
    const boost::shared_ptr<sensor_msgs::Image> image = boost::make_shared<sensor_msgs::Image>();
    const std::string error = decodeCompressedImage(*msg, side.name, max_image_pixels_, *image);
    if (!error.empty()) {
      reject(msg->header.stamp, error);
      return;
    }
    onImage(side, image);
  } catch (const std::exception& e) {
    ROS_ERROR_THROTTLE_NAMED(5.0, log_name_, "%s raw image dropped: %s", side.name, e.what());
  }
}

void RectifyFeed::onInfo(Side& side, const sensor_msgs::CameraInfoConstPtr& info) {
  try {
    sensor_msgs::ImageConstPtr image;
    {
      std::lock_guard<std::mutex> lock(side.mutex);
      image = takeMatch(side.images, info->header.stamp);
      if (!image) keep(side.infos, info, queue_size_);
    }
    if (image) forward(side, image, info);
  } catch (const std::exception& e) {
    ROS_ERROR_THROTTLE_NAMED(5.0, log_name_, "%s raw camera_info dropped: %s", side.name, e.what());
  }
}

void RectifyFeed::forward(Side& side, const sensor_msgs::ImageConstPtr& image,
                          const sensor_msgs::CameraInfoConstPtr& info) {
  const std::string error = checkRawFrame(*image, *info, side.name, max_image_pixels_);
  if (!error.empty()) {
    reject(image->header.stamp, error);
    return;
  }
  side.info_pub.publish(info);
  side.image_pub.publish(image);
}

// Both sides of a frame may fail: the frame is reported (and counted) once,
// with the first side's reason.
void RectifyFeed::reject(const ros::Time& stamp, const std::string& what) {
  {
    std::lock_guard<std::mutex> lock(reject_mutex_);
    if (stamp == last_rejected_stamp_ && !stamp.isZero()) return;
    last_rejected_stamp_ = stamp;
  }
  on_reject_(what);
}

}  // namespace bdis_stereo
