#include "bdis_stereo_nodelet.hpp"

#include <pluginlib/class_list_macros.hpp>

namespace bdis_stereo {

BdisStereoNodelet::~BdisStereoNodelet() {
  mailbox_.stop();
  if (worker_.joinable()) worker_.join();
  const FrameCounters t = statistics_.totals();
  NODELET_INFO("bdis_stereo: frames_in=%lu frames_out=%lu dropped_busy=%lu rejected=%lu errors=%lu",
               static_cast<unsigned long>(t.frames_in), static_cast<unsigned long>(t.frames_out),
               static_cast<unsigned long>(t.dropped_busy), static_cast<unsigned long>(t.rejected),
               static_cast<unsigned long>(t.errors));
}

void BdisStereoNodelet::onInit() {
  ros::NodeHandle& nh = getNodeHandle();
  ros::NodeHandle& pnh = getPrivateNodeHandle();
  const StartupParams startup = loadStartupParams();
  params_ = startup.node;

  reconfigure_.reset(new MatcherReconfigure(getName(), params_.preset, startup.matcher));
  {
    // The server offers set_parameters as soon as it is constructed; until the
    // callback is set a request would be taken unvalidated (seen under ASan:
    // sigma_r = NaN accepted). The server takes this mutex for every request.
    boost::recursive_mutex::scoped_lock lock(config_mutex_);
    reconfigure_server_.reset(new dynamic_reconfigure::Server<BdisStereoConfig>(config_mutex_, pnh));
    reconfigure_server_->setCallback(
        [this](BdisStereoConfig& config, uint32_t /*level*/) { reconfigure_->reconfigure(config); });
  }

  pipeline_.reset(
      new FramePipeline(getName(), params_, startup.matcher, nh, outputs_, statistics_, *reconfigure_));
  worker_ = std::thread(&BdisStereoNodelet::workerLoop, this);

  it_.reset(new image_transport::ImageTransport(nh));
  inputs_.reset(new InputSync(getName(), params_.approximate_sync, params_.queue_size,
                              [this](const sensor_msgs::ImageConstPtr& l, const sensor_msgs::ImageConstPtr& r,
                                     const sensor_msgs::CameraInfoConstPtr& li,
                                     const sensor_msgs::CameraInfoConstPtr& ri) { pairCb(l, r, li, ri); }));

  updater_.reset(new diagnostic_updater::Updater(nh, pnh, getName()));
  updater_->setHardwareID("none");
  updater_->add("bdis_stereo " + getName(), this, &BdisStereoNodelet::diagnose);

  {
    // Held while advertising, so connectCb cannot run half-way.
    std::lock_guard<std::mutex> lock(connect_mutex_);
    outputs_.advertise(nh, *it_, [this] { connectCb(); });
  }
  watchdog_timer_ = nh.createWallTimer(ros::WallDuration(0.5), &BdisStereoNodelet::watchdogCb, this);
  NODELET_INFO("bdis_stereo: %s sync, queue %d, %s cloud%s%s, preset %s",
               params_.approximate_sync ? "approximate" : "exact", params_.queue_size,
               params_.organized_cloud ? "organised" : "dense", params_.target_frame.empty() ? "" : " in ",
               params_.target_frame.c_str(), params_.preset.c_str());
}

// A bad value is logged and replaced (node_params); the effective values are
// written back so that `rosparam get` and dynamic_reconfigure show them.
StartupParams BdisStereoNodelet::loadStartupParams() {
  ros::NodeHandle& pnh = getPrivateNodeHandle();
  const StartupParams params = readStartupParams(
      [&pnh](const std::string& name, XmlRpc::XmlRpcValue& value) { return pnh.getParam(name, value); },
      "parameter server " + pnh.getNamespace(),
      [this](const std::string& message) { NODELET_ERROR("%s", message.c_str()); });
  for (const auto& [name, value] : effectiveParams(params)) pnh.setParam(name, value);
  return params;
}

// Lazy subscription: the inputs only while some output has a subscriber.
void BdisStereoNodelet::connectCb() {
  try {
    std::lock_guard<std::mutex> lock(connect_mutex_);
    if (!outputs_.wanted().any()) {
      inputs_->unsubscribe();
    } else if (!inputs_->subscribed()) {
      const image_transport::TransportHints hints(params_.image_transport, ros::TransportHints(),
                                                  getPrivateNodeHandle());
      inputs_->subscribe(*it_, getNodeHandle(), hints);
    }
  } catch (const std::exception& e) {  // e.g. an image_transport plugin that is not installed
    NODELET_ERROR("cannot (un)subscribe the inputs: %s", e.what());
  }
}

void BdisStereoNodelet::pairCb(const sensor_msgs::ImageConstPtr& left,
                               const sensor_msgs::ImageConstPtr& right,
                               const sensor_msgs::CameraInfoConstPtr& left_info,
                               const sensor_msgs::CameraInfoConstPtr& right_info) {
  const ros::WallTime now = ros::WallTime::now();
  statistics_.frameIn();
  if (mailbox_.post(StereoFrame{left, right, left_info, right_info, now})) statistics_.droppedBusy();
}

void BdisStereoNodelet::workerLoop() {
  for (;;) {
    StereoFrame frame;  // released before the next wait
    if (!mailbox_.take(frame)) return;
    try {
      pipeline_->process(frame);
    } catch (const cv::Exception& e) {
      statistics_.error(std::string("OpenCV: ") + e.what());
      NODELET_ERROR_THROTTLE(5.0, "frame dropped: OpenCV error: %s", e.what());
    } catch (const std::exception& e) {
      statistics_.error(e.what());
      NODELET_ERROR_THROTTLE(5.0, "frame dropped: %s", e.what());
    } catch (...) {
      statistics_.error("unknown exception");
      NODELET_ERROR_THROTTLE(5.0, "frame dropped: unknown exception");
    }
  }
}

void BdisStereoNodelet::watchdogCb(const ros::WallTimerEvent&) {
  try {
    const std::string warning =
        noPairWarning(inputs_->status(), params_.approximate_sync, params_.sync_warn_timeout);
    if (!warning.empty()) NODELET_WARN_THROTTLE(params_.sync_warn_timeout, "%s", warning.c_str());
    updater_->update();
  } catch (const std::exception& e) {
    NODELET_ERROR_THROTTLE(5.0, "watchdog: %s", e.what());
  }
}

void BdisStereoNodelet::diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  statistics_.diagnose(stat, inputs_->status(), reconfigure_->preset(), params_.sync_warn_timeout);
}

}  // namespace bdis_stereo

PLUGINLIB_EXPORT_CLASS(bdis_stereo::BdisStereoNodelet, nodelet::Nodelet)
