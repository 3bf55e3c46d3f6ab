#include "bdis_stereo_nodelet.hpp"

#include <algorithm>
#include <string>
#include <utility>
#include <vector>

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
  const bool builtin = builtinDecoding();
  const ImageSource source =
      params_.rectify ? ImageSource::Rectified : builtin ? ImageSource::BuiltinCompressed : ImageSource::Transport;
  inputs_.reset(new InputSync(getName(), params_.approximate_sync, params_.queue_size, source,
                              [this](StereoFrame frame) { pairCb(std::move(frame)); }));
  if (params_.rectify) {
    rectify_feed_.reset(new RectifyFeed(getName(), params_.queue_size,
                                        static_cast<std::size_t>(params_.max_image_pixels), builtin,
                                        [this](const std::string& what) { rawFrameRejected(what); }));
    rectify_feed_->advertise(nh);
    NODELET_INFO("bdis_stereo: rectify on: %s/{left,right}/image_raw%s and camera_info, checked, to image_proc/rectify "
                 "(%s/{left,right}/rectify_input); matching their image_rect",
                 nh.getNamespace().c_str(), builtin ? "/compressed" : "", nh.getNamespace().c_str());
  }

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

// image_transport "compressed" without its plugin (Debian 12 packages none):
// the nodelet subscribes to the CompressedImage topics and decodes them
// itself. Said once, whichever way it goes.
bool BdisStereoNodelet::builtinDecoding() {
  if (params_.image_transport == "raw") return false;
  std::vector<std::string> loadable;
  try {
    loadable = it_->getLoadableTransports();  // "image_transport/raw", "image_transport/compressed", ...
  } catch (const std::exception& e) {
    NODELET_WARN("cannot list the image_transport plugins: %s", e.what());
  }
  const bool plugin =
      std::find(loadable.begin(), loadable.end(), "image_transport/" + params_.image_transport) != loadable.end();
  if (params_.image_transport != "compressed") {
    if (!plugin) {
      NODELET_ERROR("image_transport '%s': its plugin is not installed; the images cannot be received",
                    params_.image_transport.c_str());
    }
    return false;
  }
  if (plugin) {
    NODELET_INFO("image_transport 'compressed': decoding through the compressed_image_transport plugin");
  } else {
    NODELET_INFO("image_transport 'compressed': the compressed_image_transport plugin is not installed; "
                 "subscribing to <image topic>/compressed (sensor_msgs/CompressedImage) and decoding JPEG and PNG "
                 "with OpenCV (built-in decoding)");
  }
  return !plugin;
}

// Lazy subscription: the inputs only while some output has a subscriber.
void BdisStereoNodelet::connectCb() {
  try {
    std::lock_guard<std::mutex> lock(connect_mutex_);
    if (!outputs_.wanted().any()) {
      inputs_->unsubscribe();
      if (rectify_feed_) rectify_feed_->unsubscribe();
    } else if (!inputs_->subscribed()) {
      const image_transport::TransportHints hints(params_.image_transport, ros::TransportHints(),
                                                  getPrivateNodeHandle());
      if (rectify_feed_) rectify_feed_->subscribe(*it_, getNodeHandle(), hints);
      inputs_->subscribe(*it_, getNodeHandle(), hints);
    }
  } catch (const std::exception& e) {  // e.g. an image_transport plugin that is not installed
    NODELET_ERROR("cannot (un)subscribe the inputs: %s", e.what());
  }
}

void BdisStereoNodelet::pairCb(StereoFrame frame) {
  statistics_.frameIn();
  if (mailbox_.post(std::move(frame))) statistics_.droppedBusy();
}

// A raw frame that never reached image_proc/rectify: a frame in, rejected,
// with a message as the pipeline's.
void BdisStereoNodelet::rawFrameRejected(const std::string& what) {
  statistics_.frameIn();
  if (statistics_.rejected(what)) NODELET_ERROR("frame dropped: %s", what.c_str());
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
