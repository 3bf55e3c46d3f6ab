// The bdis_stereo nodelet: synchronised rectified stereo in; disparity, depth,
// confidence, variance and PointCloud2 out. Thin, in the manner of
// stereo_image_proc: it wires the units together.
//   node_params        the start-up parameters (one table, the core's binder)
//   input_sync         lazy subscription, synchronisation, per-topic counts
//   rectify_feed       with rectify on: raw frames checked, to image_proc/rectify
//   frame_mailbox      the latest synchronised frame for the worker
//   frame_pipeline     validate -> compute -> publish, on the worker thread
//   outputs            one publisher and one function per output
//   matcher_reconfigure  dynamic_reconfigure of the matcher parameters
//   node_statistics    counters, latencies, diagnostics, the watchdog's text
//
// Threads: subscriber callbacks (the manager's queue) only hand the latest
// synchronised frame to one worker thread; a frame that is still waiting when
// a newer one arrives is dropped and counted. Nothing throws out of a callback.
#pragma once

#include <memory>
#include <mutex>
#include <thread>

#include <boost/thread/recursive_mutex.hpp>
#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <image_transport/image_transport.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>

#include "bdis_stereo/BdisStereoConfig.h"
#include "frame_mailbox.hpp"
#include "frame_pipeline.hpp"
#include "input_sync.hpp"
#include "matcher_reconfigure.hpp"
#include "node_params.hpp"
#include "node_statistics.hpp"
#include "outputs.hpp"
#include "rectify_feed.hpp"

namespace bdis_stereo {

class BdisStereoNodelet : public nodelet::Nodelet {
 public:
  ~BdisStereoNodelet() override;

 private:
  void onInit() override;
  StartupParams loadStartupParams();
  bool builtinDecoding();
  void connectCb();
  void pairCb(StereoFrame frame);
  void rawFrameRejected(const std::string& what);
  void workerLoop();
  void watchdogCb(const ros::WallTimerEvent&);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat);

  // Declared so that what a callback uses outlives what calls it: the
  // inputs (which call pairCb) go first, the statistics last.
  NodeParams params_;
  NodeStatistics statistics_;
  std::unique_ptr<MatcherReconfigure> reconfigure_;
  boost::recursive_mutex config_mutex_;
  std::unique_ptr<dynamic_reconfigure::Server<BdisStereoConfig>> reconfigure_server_;

  std::shared_ptr<image_transport::ImageTransport> it_;
  std::mutex connect_mutex_;  ///< outputs advertised and inputs (un)subscribed as one step
  Outputs outputs_;

  FrameMailbox<StereoFrame> mailbox_;
  std::unique_ptr<FramePipeline> pipeline_;
  std::thread worker_;
  std::unique_ptr<InputSync> inputs_;
  std::unique_ptr<RectifyFeed> rectify_feed_;  ///< with rectify on

  std::unique_ptr<diagnostic_updater::Updater> updater_;
  ros::WallTimer watchdog_timer_;
};

}  // namespace bdis_stereo
