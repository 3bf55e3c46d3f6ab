// The nodelet's statistics: frame counters, the latency ring, the throttling
// of rejection messages, the diagnostics status and the watchdog's warning.
// Thread-safe; needs no master (test_ros_frame checks the texts offline).
#pragma once

#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include <diagnostic_updater/DiagnosticStatusWrapper.h>
#include <ros/time.h>

#include "bdis_stereo/pair_check.hpp"
#include "input_status.hpp"

namespace bdis_stereo {

/// What happened to the synchronised pairs: frames_in = frames_out +
/// dropped_busy + rejected + errors once the worker is idle.
struct FrameCounters {
  uint64_t frames_in = 0;     ///< synchronised pairs received
  uint64_t frames_out = 0;    ///< pairs processed and published
  uint64_t dropped_busy = 0;  ///< replaced in the mailbox while the worker was busy
  uint64_t rejected = 0;      ///< failed validation (bad input)
  uint64_t errors = 0;        ///< exception while processing
};

/// The warning the watchdog logs when inputs arrive but no synchronised pair
/// forms for longer than `timeout` s (at least 3 messages on some topic since
/// the last pair, not the stragglers of a bag's last frame), with the likely
/// causes; "" when there is nothing to warn about.
std::string noPairWarning(const InputStatus& input, bool approximate_sync, double timeout);

class NodeStatistics {
 public:
  static constexpr std::size_t kLatencyWindow = 512;  ///< frames in the latency percentiles
  static constexpr double kRejectLogPeriod = 5.0;     ///< s between two logs of the same rejection

  NodeStatistics();

  void frameIn();
  void droppedBusy();
  /// Counts a rejected frame and keeps `what` as the last error. True when
  /// `what` should be logged now: a new problem at once, the same one at most
  /// every kRejectLogPeriod.
  bool rejected(const std::string& what);
  /// Counts a frame lost to an exception.
  void error(const std::string& what);
  /// Counts a published frame: its processing time and its latency (pair
  /// formed to outputs published).
  void frameOut(double processing_ms, double latency_ms);
  /// The left image's block codec grid as last checked (bdis::checkBlockArtefacts).
  void inputBlockGrid(const bdis::BlockArtefactCheck& check);

  FrameCounters totals() const;

  /// Fills the diagnostics status: the summary (bad input, no pairs forming,
  /// dropping frames, idle or ok) and the key-values the README lists. Rates
  /// and processing times are over the window since the previous call.
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat, const InputStatus& input,
                const std::string& preset, double sync_warn_timeout);

 private:
  mutable std::mutex mutex_;
  FrameCounters total_, window_start_;
  ros::WallTime window_start_time_;
  double processing_ms_sum_ = 0.0, processing_ms_max_ = 0.0;
  uint64_t processing_count_ = 0;
  std::vector<double> latencies_ms_;  ///< ring of the last kLatencyWindow frames
  std::size_t latency_next_ = 0;
  std::string last_error_;
  bdis::BlockArtefactCheck input_block_grid_;
  std::map<std::string, ros::WallTime> reject_logged_;
};

}  // namespace bdis_stereo
