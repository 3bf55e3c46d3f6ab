#include "input_sync.hpp"

#include <type_traits>
#include <utility>

namespace bdis_stereo {
namespace {
const char* const kInputNames[] = {"left image", "right image", "left camera_info", "right camera_info"};
}  // namespace

InputSync::InputSync(std::string log_name, bool approximate_sync, int queue_size, ImageSource source,
                     PairCallback on_pair)
    : log_name_(std::move(log_name)),
      approximate_sync_(approximate_sync),
      queue_size_(queue_size),
      source_(source),
      on_pair_(std::move(on_pair)),
      last_pair_time_(ros::WallTime::now()) {
  createSync();
  using ImageCallback = boost::function<void(const sensor_msgs::ImageConstPtr&)>;
  using CompressedCallback = boost::function<void(const sensor_msgs::CompressedImageConstPtr&)>;
  left_transport_.registerCallback(ImageCallback([this](const sensor_msgs::ImageConstPtr& m) { feed<0>(m); }));
  right_transport_.registerCallback(ImageCallback([this](const sensor_msgs::ImageConstPtr& m) { feed<1>(m); }));
  left_rectified_.registerCallback(ImageCallback([this](const sensor_msgs::ImageConstPtr& m) { feed<0>(m); }));
  right_rectified_.registerCallback(ImageCallback([this](const sensor_msgs::ImageConstPtr& m) { feed<1>(m); }));
  left_compressed_.registerCallback(
      CompressedCallback([this](const sensor_msgs::CompressedImageConstPtr& m) { feed<0>(m); }));
  right_compressed_.registerCallback(
      CompressedCallback([this](const sensor_msgs::CompressedImageConstPtr& m) { feed<1>(m); }));
  left_info_.registerCallback(boost::function<void(const sensor_msgs::CameraInfoConstPtr&)>(
      [this](const sensor_msgs::CameraInfoConstPtr& m) { feed<2>(m); }));
  right_info_.registerCallback(boost::function<void(const sensor_msgs::CameraInfoConstPtr&)>(
      [this](const sensor_msgs::CameraInfoConstPtr& m) { feed<3>(m); }));
}

void InputSync::subscribe(image_transport::ImageTransport& it, ros::NodeHandle& nh,
                          const image_transport::TransportHints& hints) {
  std::lock_guard<std::mutex> lock(connection_mutex_);
  if (subscribed_) return;
  switch (source_) {
    case ImageSource::Transport:
      left_transport_.subscribe(it, "left/image_rect", queue_size_, hints);
      right_transport_.subscribe(it, "right/image_rect", queue_size_, hints);
      break;
    case ImageSource::BuiltinCompressed:
      left_compressed_.subscribe(nh, "left/image_rect/compressed", queue_size_);
      right_compressed_.subscribe(nh, "right/image_rect/compressed", queue_size_);
      break;
    case ImageSource::Rectified:
      left_rectified_.subscribe(nh, "left/image_rect", queue_size_);
      right_rectified_.subscribe(nh, "right/image_rect", queue_size_);
      break;
  }
  left_info_.subscribe(nh, "left/camera_info", queue_size_);
  right_info_.subscribe(nh, "right/camera_info", queue_size_);
  subscribed_ = true;
  {
    // The "no pair" clock starts now, not at the last pair of an earlier subscription.
    std::lock_guard<std::mutex> sync(sync_mutex_);
    last_pair_time_ = ros::WallTime::now();
    at_last_pair_ = counts_;
  }
  const std::array<std::string, 2> images = imageTopics();
  ROS_DEBUG_NAMED(log_name_, "output subscribed: subscribing to %s, %s, %s, %s", images[0].c_str(),
                  images[1].c_str(), left_info_.getTopic().c_str(), right_info_.getTopic().c_str());
}

void InputSync::unsubscribe() {
  std::lock_guard<std::mutex> lock(connection_mutex_);
  if (!subscribed_) return;
  left_transport_.unsubscribe();
  right_transport_.unsubscribe();
  left_compressed_.unsubscribe();
  right_compressed_.unsubscribe();
  left_rectified_.unsubscribe();
  right_rectified_.unsubscribe();
  left_info_.unsubscribe();
  right_info_.unsubscribe();
  subscribed_ = false;
  ROS_DEBUG_NAMED(log_name_, "no output subscribers: unsubscribed from the inputs");
}

// Called with connection_mutex_ held.
std::array<std::string, 2> InputSync::imageTopics() const {
  switch (source_) {
    case ImageSource::BuiltinCompressed:
      return {left_compressed_.getTopic(), right_compressed_.getTopic()};
    case ImageSource::Rectified:
      return {left_rectified_.getTopic(), right_rectified_.getTopic()};
    default:
      return {left_transport_.getTopic(), right_transport_.getTopic()};
  }
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
    const std::array<std::string, 2> images = imageTopics();
    s.topics = {images[0], images[1], left_info_.getTopic(), right_info_.getTopic()};
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

namespace {
template <class Sync, class Callback>
std::unique_ptr<message_filters::Synchronizer<Sync>> makeSynchroniser(int queue_size, const Callback& callback) {
  std::unique_ptr<message_filters::Synchronizer<Sync>> sync(new message_filters::Synchronizer<Sync>(Sync(queue_size)));
  sync->registerCallback(callback);
  return sync;
}
}  // namespace

void InputSync::createSync() {
  using boost::placeholders::_1;
  using boost::placeholders::_2;
  using boost::placeholders::_3;
  using boost::placeholders::_4;
  image_sync_ = Synchronisers<Image>();
  compressed_sync_ = Synchronisers<CompressedImage>();
  if (source_ == ImageSource::BuiltinCompressed) {
    const auto cb = boost::bind(&InputSync::onCompressedPair, this, _1, _2, _3, _4);
    if (approximate_sync_) {
      compressed_sync_.approx = makeSynchroniser<Synchronisers<CompressedImage>::Approx>(queue_size_, cb);
    } else {
      compressed_sync_.exact = makeSynchroniser<Synchronisers<CompressedImage>::Exact>(queue_size_, cb);
    }
  } else {
    const auto cb = boost::bind(&InputSync::onImagePair, this, _1, _2, _3, _4);
    if (approximate_sync_) {
      image_sync_.approx = makeSynchroniser<Synchronisers<Image>::Approx>(queue_size_, cb);
    } else {
      image_sync_.exact = makeSynchroniser<Synchronisers<Image>::Exact>(queue_size_, cb);
    }
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
  if constexpr (std::is_same<M, CompressedImage>::value) {
    compressed_sync_.add<I>(msg);
  } else if constexpr (std::is_same<M, Image>::value) {
    image_sync_.add<I>(msg);
  } else if (source_ == ImageSource::BuiltinCompressed) {  // a camera_info
    compressed_sync_.add<I>(msg);
  } else {
    image_sync_.add<I>(msg);
  }
}

// Called from feed(), with sync_mutex_ held.
void InputSync::onImagePair(const sensor_msgs::ImageConstPtr& l, const sensor_msgs::ImageConstPtr& r,
                            const sensor_msgs::CameraInfoConstPtr& li, const sensor_msgs::CameraInfoConstPtr& ri) {
  StereoFrame frame;
  frame.left = l;
  frame.right = r;
  frame.left_info = li;
  frame.right_info = ri;
  onPair(std::move(frame));
}

void InputSync::onCompressedPair(const sensor_msgs::CompressedImageConstPtr& l,
                                 const sensor_msgs::CompressedImageConstPtr& r,
                                 const sensor_msgs::CameraInfoConstPtr& li, const sensor_msgs::CameraInfoConstPtr& ri) {
  StereoFrame frame;
  frame.left_compressed = l;
  frame.right_compressed = r;
  frame.left_info = li;
  frame.right_info = ri;
  onPair(std::move(frame));
}

void InputSync::onPair(StereoFrame frame) {
  last_pair_time_ = ros::WallTime::now();
  frame.arrival = last_pair_time_;
  at_last_pair_ = counts_;
  on_pair_(std::move(frame));
}

}  // namespace bdis_stereo
