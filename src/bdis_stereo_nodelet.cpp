#include "bdis_stereo_nodelet.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <boost/make_shared.hpp>
#include <dynamic_reconfigure/Config.h>
#include <geometry_msgs/TransformStamped.h>
#include <opencv2/imgproc.hpp>
#include <pluginlib/class_list_macros.hpp>
#include <tf2/LinearMath/Matrix3x3.h>
#include <tf2/LinearMath/Quaternion.h>

#include "bdis_stereo/pair_check.hpp"
#include <sensor_msgs/PointCloud2.h>
#include <stereo_msgs/DisparityImage.h>

namespace bdis_stereo {
namespace {

constexpr std::size_t kLatencyWindow = 512;
constexpr double kRejectLogPeriod = 5.0;  // s

// Matcher parameters <-> dynamic_reconfigure config, generically through the
// config message so that every bdis::paramFields() entry maps by name.
bdis::MatcherParams paramsFromConfig(const BdisStereoConfig& config) {
  dynamic_reconfigure::Config msg;
  config.__toMessage__(msg);
  bdis::MatcherParams p;
  for (const auto& v : msg.ints) {
    if (const bdis::ParamField* f = bdis::findParamField(v.name)) f->set(p, v.value);
  }
  for (const auto& v : msg.doubles) {
    if (const bdis::ParamField* f = bdis::findParamField(v.name)) f->set(p, v.value);
  }
  for (const auto& v : msg.bools) {
    if (const bdis::ParamField* f = bdis::findParamField(v.name)) f->set(p, v.value ? 1.0 : 0.0);
  }
  return p;
}

void paramsToConfig(const bdis::MatcherParams& p, BdisStereoConfig& config) {
  dynamic_reconfigure::Config msg;
  config.__toMessage__(msg);
  for (auto& v : msg.ints) {
    if (const bdis::ParamField* f = bdis::findParamField(v.name)) v.value = static_cast<int>(f->get(p));
  }
  for (auto& v : msg.doubles) {
    // Through float, as the core stores it, so the config shows e.g. 0.6 not 0.60000002.
    if (const bdis::ParamField* f = bdis::findParamField(v.name)) {
      v.value = std::stod(std::to_string(static_cast<float>(f->get(p))));
    }
  }
  for (auto& v : msg.bools) {
    if (const bdis::ParamField* f = bdis::findParamField(v.name)) v.value = f->get(p) != 0.0;
  }
  config.__fromMessage__(msg);
}

// The message in `slot` when nobody else holds it any more (roscpp has
// serialised it for every TCP subscriber and no intraprocess subscriber or
// queue keeps it), else a new one that takes the slot. Rewriting a reused
// message skips the zero-fill and page faults of fresh multi-megabyte
// buffers every frame; a message someone still holds is never touched.
template <typename M>
boost::shared_ptr<M> reusableMessage(boost::shared_ptr<M>& slot) {
  if (!slot || slot.use_count() != 1) slot = boost::make_shared<M>();
  return slot;
}

std::string describeValue(const XmlRpc::XmlRpcValue& v) {
  XmlRpc::XmlRpcValue copy = v;
  return copy.toXml();
}

}  // namespace

BdisStereoNodelet::BdisStereoNodelet() : latencies_ms_(kLatencyWindow, 0.0) {}

BdisStereoNodelet::~BdisStereoNodelet() {
  {
    std::lock_guard<std::mutex> lock(frame_mutex_);
    stop_ = true;
  }
  frame_cv_.notify_all();
  if (worker_.joinable()) worker_.join();
  std::lock_guard<std::mutex> lock(stats_mutex_);
  NODELET_INFO("bdis_stereo: frames_in=%lu frames_out=%lu dropped_busy=%lu rejected=%lu errors=%lu",
               static_cast<unsigned long>(total_.frames_in),
               static_cast<unsigned long>(total_.frames_out),
               static_cast<unsigned long>(total_.dropped_busy),
               static_cast<unsigned long>(total_.rejected), static_cast<unsigned long>(total_.errors));
}

// ---- Parameters -------------------------------------------------------------

void BdisStereoNodelet::loadStartupParams(ros::NodeHandle& pnh) {
  pnh.param("approximate_sync", approximate_sync_, false);
  pnh.param("queue_size", queue_size_, 5);
  if (queue_size_ < 1) {
    NODELET_ERROR("queue_size = %d must be >= 1; using 5", queue_size_);
    queue_size_ = 5;
  }
  pnh.param("organized_cloud", organized_cloud_, true);
  pnh.param("target_frame", target_frame_, std::string());
  pnh.param("tf_timeout", tf_timeout_, 0.01);
  if (!(tf_timeout_ >= 0.0 && tf_timeout_ <= 1.0)) {
    NODELET_ERROR("tf_timeout = %g s must be in [0, 1]; using 0.01", tf_timeout_);
    tf_timeout_ = 0.01;
  }
  int max_pixels = static_cast<int>(kDefaultMaxImagePixels);
  pnh.param("max_image_pixels", max_pixels, max_pixels);
  if (max_pixels < bdis::kMinImageSide * bdis::kMinImageSide) {
    NODELET_ERROR("max_image_pixels = %d is too small; using %zu", max_pixels, kDefaultMaxImagePixels);
    max_pixels = static_cast<int>(kDefaultMaxImagePixels);
  }
  max_image_pixels_ = static_cast<std::size_t>(max_pixels);
  pnh.param("sync_warn_timeout", sync_warn_timeout_, 3.0);
  if (!(sync_warn_timeout_ > 0.0)) sync_warn_timeout_ = 3.0;

  // Matcher: preset first, then every field given explicitly. A bad value is
  // rejected (the preset's value stays) and logged; the effective values are
  // written back so that `rosparam get` and dynamic_reconfigure show them.
  std::string preset = "balanced";
  pnh.param("preset", preset, preset);
  bdis::MatcherParams p;
  try {
    p = bdis::MatcherParams::preset(preset);
  } catch (const std::invalid_argument& e) {
    NODELET_ERROR("parameter preset: %s; using balanced", e.what());
    preset = "balanced";
    p = bdis::MatcherParams::preset(preset);
  }
  const bdis::MatcherParams base = p;
  for (const bdis::ParamField& f : bdis::paramFields()) {
    XmlRpc::XmlRpcValue v;
    if (!pnh.getParam(f.name, v)) continue;
    double value = 0.0;
    bool ok = true;
    switch (v.getType()) {
      case XmlRpc::XmlRpcValue::TypeBoolean:
        ok = f.type == bdis::ParamField::Type::Bool;
        value = static_cast<bool>(v) ? 1.0 : 0.0;
        break;
      case XmlRpc::XmlRpcValue::TypeInt:
        ok = f.type != bdis::ParamField::Type::Bool;
        value = static_cast<int>(v);
        break;
      case XmlRpc::XmlRpcValue::TypeDouble:
        value = static_cast<double>(v);
        ok = f.type == bdis::ParamField::Type::Float ||
             (f.type == bdis::ParamField::Type::Int && value == std::floor(value));
        break;
      default:
        ok = false;
    }
    if (!ok) {
      NODELET_ERROR("parameter %s = %s has the wrong type (expected %s); using %g", f.name,
                    describeValue(v).c_str(),
                    f.type == bdis::ParamField::Type::Bool  ? "true/false"
                    : f.type == bdis::ParamField::Type::Int ? "an integer"
                                                            : "a number",
                    f.get(base));
      continue;
    }
    if (!std::isfinite(value) || value < f.min_value || value > f.max_value) {
      NODELET_ERROR("parameter %s = %g is out of range [%g, %g] (%s); using %g", f.name, value,
                    f.min_value, f.max_value, f.description, f.get(base));
      continue;
    }
    f.set(p, value);
  }
  try {
    p.validate();
  } catch (const std::invalid_argument& e) {
    NODELET_ERROR("%s; using the %s preset's pyramid levels", e.what(), preset.c_str());
    p.coarsest_level = base.coarsest_level;
    p.finest_level = base.finest_level;
  }
  params_ = p;
  preset_ = preset;
  pnh.setParam("preset", preset);
  for (const bdis::ParamField& f : bdis::paramFields()) {
    const double v = f.get(p);
    switch (f.type) {
      case bdis::ParamField::Type::Bool: pnh.setParam(f.name, v != 0.0); break;
      case bdis::ParamField::Type::Int: pnh.setParam(f.name, static_cast<int>(v)); break;
      case bdis::ParamField::Type::Float:
        pnh.setParam(f.name, std::stod(std::to_string(static_cast<float>(v))));
        break;
    }
  }
}

void BdisStereoNodelet::reconfigureCb(BdisStereoConfig& config, uint32_t /*level*/) {
  try {
    const bool preset_changed = config.preset != preset_;
    if (preset_changed) {
      bdis::MatcherParams p;
      try {
        p = bdis::MatcherParams::preset(config.preset);
      } catch (const std::invalid_argument& e) {
        NODELET_ERROR("dynamic_reconfigure: %s; keeping preset %s", e.what(), preset_.c_str());
        config.preset = preset_;
        paramsToConfig(params_, config);
        return;
      }
      NODELET_INFO("dynamic_reconfigure: preset %s", config.preset.c_str());
      preset_ = config.preset;
      paramsToConfig(p, config);
    }
    bdis::MatcherParams p = paramsFromConfig(config);
    try {
      p.validate();
    } catch (const std::invalid_argument& e) {
      NODELET_ERROR("dynamic_reconfigure: rejected (%s); keeping the previous parameters", e.what());
      paramsToConfig(params_, config);
      return;
    }
    if (!preset_changed) {
      // dynamic_reconfigure clamps a request outside a field's range to the
      // range's end before this callback sees it: a field that moved onto an
      // end may have been clamped, so say so.
      // Compared as the core stores them (float): 0.1 is not 0.1f.
      auto same = [](double a, double b) { return static_cast<float>(a) == static_cast<float>(b); };
      for (const bdis::ParamField& f : bdis::paramFields()) {
        const double v = f.get(p);
        if (f.type == bdis::ParamField::Type::Bool || same(v, f.get(params_))) continue;
        if (same(v, f.min_value) || same(v, f.max_value)) {
          NODELET_WARN("dynamic_reconfigure: %s = %g, the %s end of its range [%g, %g] (requests "
                       "outside the range are clamped to it)",
                       f.name, v, same(v, f.min_value) ? "lower" : "upper", f.min_value, f.max_value);
        }
      }
    }
    params_ = p;
    std::lock_guard<std::mutex> lock(params_mutex_);
    pending_params_ = p;
    params_changed_ = true;
  } catch (const std::exception& e) {
    NODELET_ERROR("dynamic_reconfigure: %s", e.what());
  }
}

// ---- Set-up -----------------------------------------------------------------

void BdisStereoNodelet::onInit() {
  ros::NodeHandle& nh = getNodeHandle();
  ros::NodeHandle& pnh = getPrivateNodeHandle();
  loadStartupParams(pnh);
  try {
    matcher_.setParams(params_);
  } catch (const std::exception& e) {  // cannot happen: params_ is validated
    NODELET_ERROR("matcher parameters: %s", e.what());
  }

  if (!target_frame_.empty()) {
    tf_buffer_.reset(new tf2_ros::Buffer(ros::Duration(10.0)));
    tf_listener_.reset(new tf2_ros::TransformListener(*tf_buffer_, nh));
  }

  {
    // The server offers set_parameters as soon as it is constructed; until the
    // callback is set a request would be taken unvalidated (seen under ASan:
    // sigma_r = NaN accepted). The server takes this mutex for every request.
    boost::recursive_mutex::scoped_lock lock(config_mutex_);
    reconfigure_server_.reset(new dynamic_reconfigure::Server<BdisStereoConfig>(config_mutex_, pnh));
    reconfigure_server_->setCallback(boost::bind(&BdisStereoNodelet::reconfigureCb, this,
                                                 boost::placeholders::_1, boost::placeholders::_2));
  }

  updater_.reset(new diagnostic_updater::Updater(nh, pnh, getName()));
  updater_->setHardwareID("none");
  updater_->add("bdis_stereo " + getName(), this, &BdisStereoNodelet::diagnose);

  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    window_start_time_ = last_pair_time_ = ros::WallTime::now();
  }
  worker_ = std::thread(&BdisStereoNodelet::workerLoop, this);

  it_.reset(new image_transport::ImageTransport(nh));
  // Hold connect_mutex_ while advertising so connectCb cannot run half-way.
  std::lock_guard<std::mutex> lock(connect_mutex_);
  createSync();
  // Per-topic counters, for the "no synchronised pair" warning and diagnostics.
  sub_l_image_.registerCallback(boost::function<void(const sensor_msgs::ImageConstPtr&)>(
      [this](const sensor_msgs::ImageConstPtr& image) {
        std::lock_guard<std::mutex> l(stats_mutex_);
        ++total_.left_images;
        // A full subscriber queue drops the oldest message without a word:
        // count the gaps of the publisher's sequence number. A seq that does
        // not advance (drivers that leave it 0) or goes back (a new publisher,
        // a bag loop) only restarts the count.
        const uint32_t seq = image->header.seq;
        if (have_left_seq_ && seq > last_left_seq_ && seq - last_left_seq_ < 1000000u)
          total_.left_images_lost += seq - last_left_seq_ - 1;
        last_left_seq_ = seq;
        have_left_seq_ = true;
      }));
  sub_l_image_.registerCallback(boost::function<void(const sensor_msgs::ImageConstPtr&)>(
      [this](const sensor_msgs::ImageConstPtr& m) { feedSync<0>(m); }));
  sub_r_image_.registerCallback(boost::function<void(const sensor_msgs::ImageConstPtr&)>(
      [this](const sensor_msgs::ImageConstPtr& m) { feedSync<1>(m); }));
  sub_l_info_.registerCallback(boost::function<void(const sensor_msgs::CameraInfoConstPtr&)>(
      [this](const sensor_msgs::CameraInfoConstPtr& m) { feedSync<2>(m); }));
  sub_r_info_.registerCallback(boost::function<void(const sensor_msgs::CameraInfoConstPtr&)>(
      [this](const sensor_msgs::CameraInfoConstPtr& m) { feedSync<3>(m); }));
  sub_r_image_.registerCallback(boost::function<void(const sensor_msgs::ImageConstPtr&)>(
      [this](const sensor_msgs::ImageConstPtr&) {
        std::lock_guard<std::mutex> l(stats_mutex_);
        ++total_.right_images;
      }));
  sub_l_info_.registerCallback(boost::function<void(const sensor_msgs::CameraInfoConstPtr&)>(
      [this](const sensor_msgs::CameraInfoConstPtr&) {
        std::lock_guard<std::mutex> l(stats_mutex_);
        ++total_.left_infos;
      }));
  sub_r_info_.registerCallback(boost::function<void(const sensor_msgs::CameraInfoConstPtr&)>(
      [this](const sensor_msgs::CameraInfoConstPtr&) {
        std::lock_guard<std::mutex> l(stats_mutex_);
        ++total_.right_infos;
      }));

  const auto ros_cb = boost::bind(&BdisStereoNodelet::connectCb, this);
  const auto it_cb = [this](const image_transport::SingleSubscriberPublisher&) { connectCb(); };
  pub_disparity_ = nh.advertise<stereo_msgs::DisparityImage>("disparity", 1, ros_cb, ros_cb);
  pub_points_ = nh.advertise<sensor_msgs::PointCloud2>("points2", 1, ros_cb, ros_cb);
  pub_depth_ = it_->advertiseCamera("depth/image_rect", 1, it_cb, it_cb, ros_cb, ros_cb);
  pub_confidence_ = it_->advertise("confidence", 1, it_cb, it_cb);
  pub_variance_ = it_->advertise("variance", 1, it_cb, it_cb);
  // The disparity of `disparity` as a plain image, for viewers (rviz) that cannot show stereo_msgs.
  pub_disparity_image_ = it_->advertise("disparity_image", 1, it_cb, it_cb);

  watchdog_timer_ = nh.createWallTimer(ros::WallDuration(0.5), &BdisStereoNodelet::watchdogCb, this);
  NODELET_INFO("bdis_stereo: %s sync, queue %d, %s cloud%s%s, preset %s", approximate_sync_ ? "approximate" : "exact",
               queue_size_, organized_cloud_ ? "organised" : "dense",
               target_frame_.empty() ? "" : " in ", target_frame_.c_str(), preset_.c_str());
}

void BdisStereoNodelet::createSync() {
  const auto cb = boost::bind(&BdisStereoNodelet::frameCb, this, boost::placeholders::_1,
                              boost::placeholders::_2, boost::placeholders::_3, boost::placeholders::_4);
  if (approximate_sync_) {
    approx_sync_.reset(new ApproxSync(ApproxPolicy(queue_size_)));
    approx_sync_->registerCallback(cb);
  } else {
    exact_sync_.reset(new ExactSync(ExactPolicy(queue_size_)));
    exact_sync_->registerCallback(cb);
  }
  last_input_stamps_.fill(ros::Time());
}

template <int I, class M>
void BdisStereoNodelet::feedSync(const boost::shared_ptr<M const>& msg) {
  static const char* const kInputNames[] = {"left image", "right image", "left camera_info",
                                            "right camera_info"};
  std::lock_guard<std::mutex> lock(sync_mutex_);
  const ros::Time stamp = msg->header.stamp;
  ros::Time& last = last_input_stamps_[I];
  if (!last.isZero() && stamp < last) {
    // The first input to show the jump resets; the others then start afresh.
    NODELET_WARN("%s stamp jumped back from %.3f to %.3f (bag loop or restart): synchroniser reset",
                 kInputNames[I], last.toSec(), stamp.toSec());
    createSync();
    std::lock_guard<std::mutex> stats(stats_mutex_);
    ++total_.time_jumps;
  }
  last = stamp;
  if (approx_sync_) {
    approx_sync_->add<I>(msg);
  } else {
    exact_sync_->add<I>(msg);
  }
}

void BdisStereoNodelet::connectCb() {
  std::lock_guard<std::mutex> lock(connect_mutex_);
  const bool wanted = pub_disparity_.getNumSubscribers() > 0 || pub_points_.getNumSubscribers() > 0 ||
                      pub_depth_.getNumSubscribers() > 0 || pub_confidence_.getNumSubscribers() > 0 ||
                      pub_variance_.getNumSubscribers() > 0 || pub_disparity_image_.getNumSubscribers() > 0;
  if (!wanted && subscribed_) {
    sub_l_image_.unsubscribe();
    sub_r_image_.unsubscribe();
    sub_l_info_.unsubscribe();
    sub_r_info_.unsubscribe();
    subscribed_ = false;
    NODELET_DEBUG("no output subscribers: unsubscribed from the inputs");
  } else if (wanted && !subscribed_) {
    ros::NodeHandle& nh = getNodeHandle();
    const image_transport::TransportHints hints("raw", ros::TransportHints(), getPrivateNodeHandle());
    sub_l_image_.subscribe(*it_, "left/image_rect", queue_size_, hints);
    sub_r_image_.subscribe(*it_, "right/image_rect", queue_size_, hints);
    sub_l_info_.subscribe(nh, "left/camera_info", queue_size_);
    sub_r_info_.subscribe(nh, "right/camera_info", queue_size_);
    subscribed_ = true;
    std::lock_guard<std::mutex> stats(stats_mutex_);
    last_pair_time_ = ros::WallTime::now();
    at_last_pair_ = total_;
    NODELET_DEBUG("output subscribed: subscribing to %s, %s, %s, %s", sub_l_image_.getTopic().c_str(),
                  sub_r_image_.getTopic().c_str(), sub_l_info_.getTopic().c_str(),
                  sub_r_info_.getTopic().c_str());
  }
}

// ---- Frames -----------------------------------------------------------------

void BdisStereoNodelet::frameCb(const sensor_msgs::ImageConstPtr& l, const sensor_msgs::ImageConstPtr& r,
                                const sensor_msgs::CameraInfoConstPtr& li,
                                const sensor_msgs::CameraInfoConstPtr& ri) {
  const ros::WallTime now = ros::WallTime::now();
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++total_.frames_in;
    last_pair_time_ = now;
    at_last_pair_ = total_;
  }
  bool dropped = false;
  {
    std::lock_guard<std::mutex> lock(frame_mutex_);
    dropped = has_pending_;
    pending_ = Frame{l, r, li, ri, now};
    has_pending_ = true;
  }
  frame_cv_.notify_one();
  if (dropped) {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++total_.dropped_busy;
  }
}

void BdisStereoNodelet::workerLoop() {
  for (;;) {
    Frame frame;
    {
      std::unique_lock<std::mutex> lock(frame_mutex_);
      frame_cv_.wait(lock, [this] { return stop_ || has_pending_; });
      if (stop_) return;
      frame = std::move(pending_);
      pending_ = Frame();
      has_pending_ = false;
    }
    try {
      process(frame);
    } catch (const cv::Exception& e) {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++total_.errors;
      last_error_ = std::string("OpenCV: ") + e.what();
      NODELET_ERROR_THROTTLE(5.0, "frame dropped: OpenCV error: %s", e.what());
    } catch (const std::exception& e) {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++total_.errors;
      last_error_ = e.what();
      NODELET_ERROR_THROTTLE(5.0, "frame dropped: %s", e.what());
    } catch (...) {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++total_.errors;
      last_error_ = "unknown exception";
      NODELET_ERROR_THROTTLE(5.0, "frame dropped: unknown exception");
    }
  }
}

void BdisStereoNodelet::reject(const std::string& what) {
  bool log = false;
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++total_.rejected;
    last_error_ = what;
    // Throttled per message: a second, different problem is reported at once,
    // the same one at most every kRejectLogPeriod.
    const ros::WallTime now = ros::WallTime::now();
    if (reject_logged_.size() > 64) reject_logged_.clear();  // bounded
    auto it = reject_logged_.find(what);
    if (it == reject_logged_.end() || (now - it->second).toSec() >= kRejectLogPeriod) {
      reject_logged_[what] = now;
      log = true;
    }
  }
  if (log) NODELET_ERROR("frame dropped: %s", what.c_str());
}

void BdisStereoNodelet::process(const Frame& frame) {
  const Image& left = *frame.left;
  const Image& right = *frame.right;
  const ros::Time stamp = left.header.stamp;
  if (!last_stamp_.isZero() && stamp < last_stamp_) {
    // Time went back (feedSync has said so): transforms stamped in the
    // "future" would serve the new frames wrongly, and the new stream (another
    // bag?) gets its cameras checked at once.
    if (tf_buffer_) tf_buffer_->clear();
    last_sign_check_ = ros::WallTime();
  }
  last_stamp_ = stamp;

  // Validate before anything that asserts or throws sees the frame.
  std::string err = checkImage(left, "left", max_image_pixels_);
  if (err.empty()) err = checkImage(right, "right", max_image_pixels_);
  if (err.empty()) err = checkImagePair(left, right);
  bdis::StereoCamera camera;
  if (err.empty()) {
    err = stereoCameraFromInfo(*frame.left_info, *frame.right_info, static_cast<int>(left.width),
                               static_cast<int>(left.height), camera);
  }
  if (!err.empty()) {
    reject(err);
    return;
  }

  // What is wanted: compute only that.
  const bool want_disparity = pub_disparity_.getNumSubscribers() > 0;
  const bool want_points = pub_points_.getNumSubscribers() > 0;
  const bool want_depth = pub_depth_.getNumSubscribers() > 0;
  const bool want_confidence = pub_confidence_.getNumSubscribers() > 0;
  const bool want_variance = pub_variance_.getNumSubscribers() > 0;
  const bool want_disparity_image = pub_disparity_image_.getNumSubscribers() > 0;
  if (!(want_disparity || want_points || want_depth || want_confidence || want_variance ||
        want_disparity_image)) {
    return;
  }

  {
    std::lock_guard<std::mutex> lock(params_mutex_);
    if (params_changed_) {
      matcher_.setParams(pending_params_);  // validated in reconfigureCb
      params_changed_ = false;
    }
  }

  const ros::WallTime start = ros::WallTime::now();
  cv::Mat lv = matcherView(left, left_buffer_);
  cv::Mat rv = matcherView(right, right_buffer_);
  const cv::Mat left_colour = lv.channels() == 3 ? lv : cv::Mat();
  if (lv.channels() != rv.channels()) {  // one mono, one colour: match in grey
    if (lv.channels() == 3) {
      cv::cvtColor(lv, grey_buffer_, cv::COLOR_BGR2GRAY);
      lv = grey_buffer_;
    } else {
      cv::cvtColor(rv, grey_buffer_, cv::COLOR_BGR2GRAY);
      rv = grey_buffer_;
    }
  }
  // Swapped cameras with correct camera_infos pass every check above; the
  // matcher (d >= 0 only) would publish garbage. A coarse search of both signs
  // tells (about 2 ms at 640x480): on the first frame, then once a second (a
  // swap is a setup error, there from the start) and on every frame while it fails.
  if (looks_swapped_ || (start - last_sign_check_).toSec() >= kSignCheckPeriod) {
    const bdis::DisparitySignCheck sign = bdis::checkDisparitySign(lv, rv);
    last_sign_check_ = start;
    looks_swapped_ = sign.looksSwapped();
    if (looks_swapped_) {
      std::ostringstream os;
      os << sign.negative << " of " << sign.distinct_patches
         << " distinct matches lie at negative disparity (the scene is further right in the left image "
            "than in the right one): are the cameras swapped? Check the left/right topic remaps";
      reject(os.str());
      return;
    }
  }
  matcher_.compute(lv, rv, result_);

  std_msgs::Header header = left.header;  // outputs: left image's stamp and frame
  if (want_disparity || want_disparity_image) {
    const stereo_msgs::DisparityImagePtr msg = reusableMessage(disparity_msg_);
    msg->header = header;
    msg->image.header = header;
    fillDisparityImage(result_.disparity, camera, *msg);
    if (want_disparity_image) {
      const sensor_msgs::ImagePtr image = reusableMessage(disparity_image_msg_);
      *image = msg->image;
      pub_disparity_image_.publish(image);
    }
    if (want_disparity) pub_disparity_.publish(msg);
  }
  // The depth image: in the depth message when that is published, else in a
  // scratch buffer when points2 needs it.
  cv::Mat depth;
  if (want_depth) {
    const sensor_msgs::ImagePtr msg = reusableMessage(depth_msg_);
    msg->header = header;
    fillDepthImage(result_.disparity, camera, *msg);
    depth = cv::Mat(static_cast<int>(msg->height), static_cast<int>(msg->width), CV_32FC1,
                    msg->data.data(), msg->step);
    sensor_msgs::CameraInfoPtr info(new sensor_msgs::CameraInfo(*frame.left_info));
    info->header = header;
    pub_depth_.publish(msg, info);  // read below while subscribers read it too: never written
  }
  if (want_confidence) {
    const sensor_msgs::ImagePtr msg = reusableMessage(confidence_msg_);
    msg->header = header;
    fillFloatImage(result_.confidence, *msg);
    pub_confidence_.publish(msg);
  }
  if (want_variance && !result_.variance.empty()) {
    const sensor_msgs::ImagePtr msg = reusableMessage(variance_msg_);
    msg->header = header;
    fillFloatImage(result_.variance, *msg);
    pub_variance_.publish(msg);
  }
  if (want_points) {
    const sensor_msgs::PointCloud2Ptr msg = reusableMessage(points_msg_);
    msg->header = header;
    RigidTransform transform;
    bool transformed = false;
    if (!target_frame_.empty() && target_frame_ != header.frame_id) {
      try {
        const geometry_msgs::TransformStamped t = tf_buffer_->lookupTransform(
            target_frame_, header.frame_id, stamp, ros::Duration(tf_timeout_));
        const auto& q = t.transform.rotation;
        const tf2::Quaternion rotation(q.x, q.y, q.z, q.w);
        const double n = rotation.length();
        if (!(n > 0.0) || !std::isfinite(n)) throw tf2::TransformException("invalid rotation");
        const tf2::Matrix3x3 r(rotation / n);
        for (int row = 0; row < 3; ++row) {
          for (int col = 0; col < 3; ++col) transform.r[3 * row + col] = r[row][col];
        }
        transform.t[0] = t.transform.translation.x;
        transform.t[1] = t.transform.translation.y;
        transform.t[2] = t.transform.translation.z;
        transformed = true;
        msg->header.frame_id = target_frame_;
      } catch (const tf2::TransformException& e) {
        NODELET_WARN_THROTTLE(5.0, "no transform %s <- %s at %.3f (%s): publishing points2 in %s",
                              target_frame_.c_str(), header.frame_id.c_str(), stamp.toSec(), e.what(),
                              header.frame_id.c_str());
      }
    }
    if (depth.empty()) {
      bdis::disparityToDepth(result_.disparity, camera, depth_buffer_);
      depth = depth_buffer_;
    }
    fillPointCloudFromDepth(depth, camera, left_colour, organized_cloud_,
                            transformed ? &transform : nullptr, *msg);
    pub_points_.publish(msg);
  }

  const ros::WallTime end = ros::WallTime::now();
  std::lock_guard<std::mutex> lock(stats_mutex_);
  ++total_.frames_out;
  const double proc_ms = (end - start).toSec() * 1e3;
  proc_ms_sum_ += proc_ms;
  proc_ms_max_ = std::max(proc_ms_max_, proc_ms);
  ++proc_count_;
  latencies_ms_[latency_next_++ % kLatencyWindow] = (end - frame.arrival).toSec() * 1e3;
}

// ---- Watchdog and diagnostics -------------------------------------------------

void BdisStereoNodelet::watchdogCb(const ros::WallTimerEvent&) {
  try {
    std::string warning;
    {
      std::lock_guard<std::mutex> lock(connect_mutex_);
      std::lock_guard<std::mutex> stats(stats_mutex_);
      const double quiet = (ros::WallTime::now() - last_pair_time_).toSec();
      const uint64_t l = total_.left_images - at_last_pair_.left_images;
      const uint64_t r = total_.right_images - at_last_pair_.right_images;
      const uint64_t li = total_.left_infos - at_last_pair_.left_infos;
      const uint64_t ri = total_.right_infos - at_last_pair_.right_infos;
      // A few messages per topic, not the stragglers of the last frame of a bag.
      if (subscribed_ && quiet > sync_warn_timeout_ && std::max({l, r, li, ri}) >= 3) {
        std::ostringstream os;
        os << "no synchronised stereo pair for " << static_cast<int>(quiet) << " s, although "
           << l << " left images (" << sub_l_image_.getTopic() << "), " << r << " right images ("
           << sub_r_image_.getTopic() << "), " << li << " left camera_infos (" << sub_l_info_.getTopic()
           << ") and " << ri << " right camera_infos (" << sub_r_info_.getTopic()
           << ") arrived. Likely causes: ";
        if (l == 0 || r == 0) os << "an image topic is silent (check the topic names and remapping); ";
        if (li == 0 || ri == 0) os << "camera_info missing (is the driver publishing it? check the names); ";
        if (l && r && li && ri) {
          os << (approximate_sync_ ? "stamps too far apart even for approximate_sync (check the driver clocks); "
                                   : "the stamps differ (try approximate_sync:=true); ");
        }
        os << "see the README, Troubleshooting";
        warning = os.str();
      }
    }
    if (!warning.empty()) NODELET_WARN_THROTTLE(sync_warn_timeout_, "%s", warning.c_str());
    updater_->update();
  } catch (const std::exception& e) {
    NODELET_ERROR_THROTTLE(5.0, "watchdog: %s", e.what());
  }
}

void BdisStereoNodelet::diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  const ros::WallTime now = ros::WallTime::now();
  const double window = std::max(1e-6, (now - window_start_time_).toSec());
  const uint64_t in = total_.frames_in - window_start_.frames_in;
  const uint64_t out = total_.frames_out - window_start_.frames_out;
  const uint64_t dropped = total_.dropped_busy - window_start_.dropped_busy;
  const uint64_t rejected = total_.rejected - window_start_.rejected;
  const uint64_t errors = total_.errors - window_start_.errors;
  const std::size_t n_lat = std::min<std::size_t>(latency_next_, kLatencyWindow);
  std::vector<double> lat(latencies_ms_.begin(), latencies_ms_.begin() + n_lat);
  double p50 = 0.0, lat_max = 0.0;
  if (!lat.empty()) {
    std::nth_element(lat.begin(), lat.begin() + lat.size() / 2, lat.end());
    p50 = lat[lat.size() / 2];
    lat_max = *std::max_element(lat.begin(), lat.end());
  }
  const double quiet = (now - last_pair_time_).toSec();
  if (rejected + errors > 0) {
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::ERROR, "frames dropped for bad input: %s",
                  last_error_.c_str());
  } else if (subscribed_ && quiet > sync_warn_timeout_ &&
             total_.left_images + total_.right_images > at_last_pair_.left_images + at_last_pair_.right_images) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::WARN,
                 "images arrive but no synchronised pair forms (see the log)");
  } else if (dropped > 0) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, "dropping frames: processing slower than input");
  } else if (!subscribed_) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "idle: no output subscribers");
  } else {
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "ok");
  }
  stat.add("subscribed", subscribed_);
  stat.add("frames_in", total_.frames_in);
  stat.add("frames_out", total_.frames_out);
  stat.add("dropped_busy", total_.dropped_busy);
  stat.add("rejected", total_.rejected);
  stat.add("errors", total_.errors);
  stat.add("time_jumps", total_.time_jumps);
  stat.addf("input_rate_hz", "%.2f", in / window);
  stat.addf("output_rate_hz", "%.2f", out / window);
  stat.addf("processing_ms_mean", "%.2f", proc_count_ ? proc_ms_sum_ / proc_count_ : 0.0);
  stat.addf("processing_ms_max", "%.2f", proc_ms_max_);
  stat.addf("latency_ms_p50", "%.2f", p50);
  stat.addf("latency_ms_max", "%.2f", lat_max);
  stat.add("left_images", total_.left_images);
  stat.add("left_images_lost", total_.left_images_lost);
  stat.add("right_images", total_.right_images);
  stat.add("left_camera_infos", total_.left_infos);
  stat.add("right_camera_infos", total_.right_infos);
  stat.add("last_error", last_error_);
  stat.add("preset", preset_);
  window_start_ = total_;
  window_start_time_ = now;
  proc_ms_sum_ = proc_ms_max_ = 0.0;
  proc_count_ = 0;
}

}  // namespace bdis_stereo

PLUGINLIB_EXPORT_CLASS(bdis_stereo::BdisStereoNodelet, nodelet::Nodelet)
