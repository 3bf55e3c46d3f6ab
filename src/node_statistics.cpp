#include "node_statistics.hpp"

#include <algorithm>
#include <sstream>

namespace bdis_stereo {

std::string noPairWarning(const InputStatus& input, bool approximate_sync, double timeout) {
  const InputCounts& n = input.since_pair;
  const uint64_t l = n.left_images, r = n.right_images, li = n.left_infos, ri = n.right_infos;
  if (!input.subscribed || !(input.seconds_since_pair > timeout) || std::max({l, r, li, ri}) < 3) {
    return "";
  }
  std::ostringstream os;
  os << "no synchronised stereo pair for " << static_cast<int>(input.seconds_since_pair) << " s, although "
     << l << " left images (" << input.topics[0] << "), " << r << " right images (" << input.topics[1]
     << "), " << li << " left camera_infos (" << input.topics[2] << ") and " << ri << " right camera_infos ("
     << input.topics[3] << ") arrived. Likely causes: ";
  // Each silent input by name: the others arrive, so this one is the cause.
  const uint64_t since_pair[] = {l, r, li, ri};
  const char* const names[] = {"left image", "right image", "left camera_info", "right camera_info"};
  for (int i = 0; i < 4; ++i) {
    if (since_pair[i] != 0) continue;
    os << "the " << names[i] << " (" << input.topics[i] << ") is silent"
       << (i < 2 ? " (check the topic names and remapping); "
                 : ": camera_info missing (is the driver publishing it? check the names); ");
  }
  if (l && r && li && ri) {
    os << (approximate_sync ? "stamps too far apart even for approximate_sync (check the driver clocks); "
                            : "the stamps differ (try approximate_sync:=true); ");
  }
  os << "see the README, Troubleshooting";
  return os.str();
}

NodeStatistics::NodeStatistics()
    : window_start_time_(ros::WallTime::now()), latencies_ms_(kLatencyWindow, 0.0) {}

void NodeStatistics::frameIn() {
  std::lock_guard<std::mutex> lock(mutex_);
  ++total_.frames_in;
}

void NodeStatistics::droppedBusy() {
  std::lock_guard<std::mutex> lock(mutex_);
  ++total_.dropped_busy;
}

bool NodeStatistics::rejected(const std::string& what) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++total_.rejected;
  last_error_ = what;
  const ros::WallTime now = ros::WallTime::now();
  if (reject_logged_.size() > 64) reject_logged_.clear();  // bounded
  auto it = reject_logged_.find(what);
  if (it != reject_logged_.end() && (now - it->second).toSec() < kRejectLogPeriod) return false;
  reject_logged_[what] = now;
  return true;
}

void NodeStatistics::error(const std::string& what) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++total_.errors;
  last_error_ = what;
}

void NodeStatistics::frameOut(double processing_ms, double latency_ms) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++total_.frames_out;
  processing_ms_sum_ += processing_ms;
  processing_ms_max_ = std::max(processing_ms_max_, processing_ms);
  ++processing_count_;
  latencies_ms_[latency_next_++ % kLatencyWindow] = latency_ms;
}

FrameCounters NodeStatistics::totals() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return total_;
}

void NodeStatistics::inputBlockGrid(const bdis::BlockArtefactCheck& check) {
  std::lock_guard<std::mutex> lock(mutex_);
  input_block_grid_ = check;
}

void NodeStatistics::diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat, const InputStatus& input,
                              const std::string& preset, double sync_warn_timeout) {
  std::lock_guard<std::mutex> lock(mutex_);
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
  const uint64_t images_since_pair = input.since_pair.left_images + input.since_pair.right_images;
  if (rejected + errors > 0) {
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::ERROR, "frames dropped for bad input: %s",
                  last_error_.c_str());
  } else if (input.subscribed && input.seconds_since_pair > sync_warn_timeout && images_since_pair > 0) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::WARN,
                 "images arrive but no synchronised pair forms (see the log)");
  } else if (dropped > 0) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, "dropping frames: processing slower than input");
  } else if (!input.subscribed) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "idle: no output subscribers");
  } else if (input_block_grid_.looksBlockCompressed()) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::WARN,
                 "input block-coded (JPEG-like): more wrong depths in dark and flat tissue (see the log)");
  } else {
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "ok");
  }
  stat.add("subscribed", input.subscribed);
  stat.add("frames_in", total_.frames_in);
  stat.add("frames_out", total_.frames_out);
  stat.add("dropped_busy", total_.dropped_busy);
  stat.add("rejected", total_.rejected);
  stat.add("errors", total_.errors);
  stat.add("time_jumps", input.total.time_jumps);
  stat.addf("input_rate_hz", "%.2f", in / window);
  stat.addf("output_rate_hz", "%.2f", out / window);
  stat.addf("processing_ms_mean", "%.2f", processing_count_ ? processing_ms_sum_ / processing_count_ : 0.0);
  stat.addf("processing_ms_max", "%.2f", processing_ms_max_);
  stat.addf("latency_ms_p50", "%.2f", p50);
  stat.addf("latency_ms_max", "%.2f", lat_max);
  stat.add("left_images", input.total.left_images);
  stat.add("left_images_lost", input.total.left_images_lost);
  stat.add("right_images", input.total.right_images);
  stat.add("left_camera_infos", input.total.left_infos);
  stat.add("right_camera_infos", input.total.right_infos);
  stat.addf("input_block_grid", "%.2f", input_block_grid_.grid_contrast);
  stat.add("last_error", last_error_);
  stat.add("preset", preset);
  window_start_ = total_;
  window_start_time_ = now;
  processing_ms_sum_ = processing_ms_max_ = 0.0;
  processing_count_ = 0;
}

}  // namespace bdis_stereo
