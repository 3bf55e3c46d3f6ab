// bdis_node_bench: replays a stereo bag (made by bdis_make_bag) at a fixed
// rate into a running stereo node, restamping every frame with the time it is
// published, and measures which frames come out and when: latency = arrival
// of the frame's last subscribed output here (roscpp's receipt time: its last
// byte read from the socket, before this process deserialises it and queues
// the callback) minus its stamp (= its publish time). The time the callback
// ran is kept too (last column, "cb p99"): it adds this process's own work.
// Works for any node with the stereo_image_proc interface (inputs
// NS/{left,right}/{image_rect,camera_info}), so the same run measures
// bdis_stereo and stereo_image_proc. Also reports the median of the node's
// own processing_ms_mean from /diagnostics (bdis_stereo only: decoding to
// publishing, without the transport). With --node-core, the share of the
// time that core was busy while the measured frames were sent (/proc/stat:
// user, system, interrupts; everything the node and the kernel did for it).
// Prints one table row; --json appends.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <diagnostic_msgs/DiagnosticArray.h>
#include <ros/ros.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <stereo_msgs/DisparityImage.h>

namespace {

constexpr const char* kUsage = R"(usage: bdis_node_bench --bag FILE --label NAME [options]
  --ns NS            stereo namespace of the node under test (default /stereo)
  --bag-ns NS        namespace of the topics in the bag (default /stereo)
  --rate HZ          frames per second (default 60)
  --seconds S        measured duration (default 20), after --warmup seconds (default 3)
  --frames N         send exactly N frames instead (after the warm-up), e.g. for a soak test
  --outputs LIST     subscribed outputs, relative to NS (default disparity,depth/image_rect,points2)
  --node-core N      report how busy CPU core N (the node's) was while measuring (Linux)
  --json FILE        append the result as one JSON line
  --latencies FILE   write one line per measured frame: its send time (ms after the
                     first), then each output's latency in ms (-1: never came)
)";

struct Frame {
  sensor_msgs::Image left, right;
  sensor_msgs::CameraInfo left_info, right_info;
};

struct Options {
  std::string bag, label, ns = "/stereo", bag_ns = "/stereo", json, latencies;
  double rate = 60, seconds = 20, warmup = 3;
  size_t frames = 0;  // 0: seconds * rate
  int node_core = -1;  // -1: not reported
  std::vector<std::string> outputs = {"disparity", "depth/image_rect", "points2"};
};

/// Busy and total jiffies of one core from /proc/stat; total 0 where it
/// cannot be read (not Linux, no such core).
struct CoreTimes {
  unsigned long long busy = 0, total = 0;
};

CoreTimes readCoreTimes(int core) {
  CoreTimes t;
  std::ifstream stat("/proc/stat");
  const std::string name = "cpu" + std::to_string(core);
  for (std::string line; std::getline(stat, line);) {
    std::istringstream fields(line);
    std::string label;
    fields >> label;
    if (label != name) continue;
    // user nice system idle iowait irq softirq steal (guest is within user)
    unsigned long long v[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    for (unsigned long long& x : v) fields >> x;
    t.total = v[0] + v[1] + v[2] + v[3] + v[4] + v[5] + v[6] + v[7];
    t.busy = t.total - v[3] - v[4];
    break;
  }
  return t;
}

/// Busy share of the core between two readings; negative if unknown.
double busyShare(const CoreTimes& from, const CoreTimes& to) {
  if (from.total == 0 || to.total <= from.total) return -1;
  return static_cast<double>(to.busy - from.busy) / static_cast<double>(to.total - from.total);
}

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ',');) if (!item.empty()) out.push_back(item);
  return out;
}

std::vector<Frame> loadBag(const Options& o) {
  rosbag::Bag bag(o.bag, rosbag::bagmode::Read);
  const std::string li = o.bag_ns + "/left/image_rect", ri = o.bag_ns + "/right/image_rect";
  const std::string lc = o.bag_ns + "/left/camera_info", rc = o.bag_ns + "/right/camera_info";
  std::map<ros::Time, Frame> by_stamp;
  std::map<ros::Time, int> parts;
  rosbag::View view(bag, rosbag::TopicQuery({li, ri, lc, rc}));
  for (const rosbag::MessageInstance& m : view) {
    if (auto img = m.instantiate<sensor_msgs::Image>()) {
      Frame& f = by_stamp[img->header.stamp];
      (m.getTopic() == li ? f.left : f.right) = *img;
      ++parts[img->header.stamp];
    } else if (auto info = m.instantiate<sensor_msgs::CameraInfo>()) {
      Frame& f = by_stamp[info->header.stamp];
      (m.getTopic() == lc ? f.left_info : f.right_info) = *info;
      ++parts[info->header.stamp];
    }
  }
  std::vector<Frame> frames;
  for (auto& [stamp, f] : by_stamp) if (parts[stamp] == 4) frames.push_back(std::move(f));
  return frames;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const double pos = q / 100.0 * static_cast<double>(v.size() - 1);
  const size_t i = static_cast<size_t>(pos);
  const double frac = pos - static_cast<double>(i);
  return i + 1 < v.size() ? v[i] * (1 - frac) + v[i + 1] * frac : v[i];
}

/// The nodelet's own processing time per frame (decoding to publishing), as
/// its diagnostics give it: one mean per diagnostics period. stereo_image_proc
/// publishes none.
class NodeProcessing {
 public:
  void record(const diagnostic_msgs::DiagnosticArrayConstPtr& array) {
    const ros::WallTime now = ros::WallTime::now();
    for (const diagnostic_msgs::DiagnosticStatus& status : array->status) {
      if (status.name.find("bdis_stereo") == std::string::npos) continue;
      for (const diagnostic_msgs::KeyValue& kv : status.values) {
        if (kv.key != "processing_ms_mean") continue;
        std::lock_guard<std::mutex> lock(mutex_);
        means_.emplace_back(now, std::stod(kv.value));
      }
    }
  }
  /// Median of the means received in [from, to] over periods with frames; -1 if none.
  double median(ros::WallTime from, ros::WallTime to) const {
    std::vector<double> in;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      for (const auto& [at, mean] : means_) if (at >= from && at <= to && mean > 0) in.push_back(mean);
    }
    return in.empty() ? -1.0 : percentile(in, 50);
  }

 private:
  mutable std::mutex mutex_;
  std::vector<std::pair<ros::WallTime, double>> means_;
};

/// Arrival times of every output per stamp (nanoseconds of ros::Time): when
/// roscpp received it and when its callback ran here.
class Arrivals {
 public:
  explicit Arrivals(size_t topics) : topics_(topics) {}
  void record(const ros::Time& stamp, size_t topic, const ros::Time& received) {
    const ros::Time now = ros::Time::now();
    std::lock_guard<std::mutex> lock(mutex_);
    Slot& slot = arrivals_[stamp.toNSec()];
    if (slot.received.empty()) {
      slot.received.assign(topics_, 0);
      slot.handled.assign(topics_, 0);
    }
    if (slot.received[topic] == 0) {
      slot.received[topic] = received.toNSec();
      slot.handled[topic] = now.toNSec();
    }
    ++received_[topic];
  }
  size_t received(size_t topic) const {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = received_.find(topic);
    return it == received_.end() ? 0 : it->second;
  }
  /// When roscpp received each topic's message of `stamp` (0: never).
  std::vector<uint64_t> receivedAt(uint64_t stamp) const {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = arrivals_.find(stamp);
    return it == arrivals_.end() ? std::vector<uint64_t>(topics_, 0) : it->second.received;
  }
  /// Latest arrival of all topics (received, or handled), or 0 if one never came.
  uint64_t complete(uint64_t stamp, bool handled = false) const {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = arrivals_.find(stamp);
    if (it == arrivals_.end()) return 0;
    uint64_t last = 0;
    for (uint64_t t : handled ? it->second.handled : it->second.received) {
      if (t == 0) return 0;
      last = std::max(last, t);
    }
    return last;
  }

 private:
  struct Slot {
    std::vector<uint64_t> received, handled;
  };
  size_t topics_;
  mutable std::mutex mutex_;
  std::map<uint64_t, Slot> arrivals_;
  std::map<size_t, size_t> received_;  // messages per topic, warm-up included
};

template <typename M>
ros::Subscriber subscribeArrivals(ros::NodeHandle& nh, const std::string& topic, const ros::TransportHints& hints,
                                  Arrivals& arrivals, size_t k) {
  const boost::function<void(const ros::MessageEvent<M const>&)> callback =
      [&arrivals, k](const ros::MessageEvent<M const>& event) {
        arrivals.record(event.getMessage()->header.stamp, k, event.getReceiptTime());
      };
  return nh.subscribe<M>(topic, 5, callback, ros::VoidConstPtr(), hints);
}

/// One line per measured frame: send time after the first, each output's latency (ms).
void writeLatencies(const std::string& path, const std::vector<std::string>& outputs,
                    const std::vector<uint64_t>& stamps, size_t first_measured, const Arrivals& arrivals) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot write " + path);
  out << "# sent_ms";
  for (const std::string& name : outputs) out << " " << name;
  out << "\n";
  for (size_t k = first_measured; k < stamps.size(); ++k) {
    if (stamps[k] == 0) continue;
    out << 1e-6 * static_cast<double>(stamps[k] - stamps[first_measured]);
    for (uint64_t t : arrivals.receivedAt(stamps[k])) out << " " << (t ? 1e-6 * static_cast<double>(t - stamps[k]) : -1.0);
    out << "\n";
  }
}

int run(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
      return argv[++i];
    };
    if (a == "--bag") o.bag = value();
    else if (a == "--label") o.label = value();
    else if (a == "--ns") o.ns = value();
    else if (a == "--bag-ns") o.bag_ns = value();
    else if (a == "--rate") o.rate = std::stod(value());
    else if (a == "--seconds") o.seconds = std::stod(value());
    else if (a == "--warmup") o.warmup = std::stod(value());
    else if (a == "--frames") o.frames = std::stoul(value());
    else if (a == "--outputs") o.outputs = split(value());
    else if (a == "--node-core") o.node_core = std::stoi(value());
    else if (a == "--json") o.json = value();
    else if (a == "--latencies") o.latencies = value();
    else if (a == "-h" || a == "--help") { std::fputs(kUsage, stdout); return 0; }
    else throw std::invalid_argument("unknown option " + a);
  }
  if (o.bag.empty() || o.label.empty() || !(o.rate > 0) || o.outputs.empty())
    throw std::invalid_argument(std::string("--bag, --label, a rate > 0 and outputs are needed\n") + kUsage);

  const std::vector<Frame> frames = loadBag(o);
  if (frames.empty()) throw std::runtime_error("no complete stereo frame under " + o.bag_ns + " in " + o.bag);

  ros::NodeHandle nh;
  const ros::TransportHints hints = ros::TransportHints().tcpNoDelay();
  ros::Publisher pub_l = nh.advertise<sensor_msgs::Image>(o.ns + "/left/image_rect", 1);
  ros::Publisher pub_r = nh.advertise<sensor_msgs::Image>(o.ns + "/right/image_rect", 1);
  ros::Publisher pub_li = nh.advertise<sensor_msgs::CameraInfo>(o.ns + "/left/camera_info", 1);
  ros::Publisher pub_ri = nh.advertise<sensor_msgs::CameraInfo>(o.ns + "/right/camera_info", 1);

  Arrivals arrivals(o.outputs.size());
  std::vector<ros::Subscriber> subs;
  for (size_t k = 0; k < o.outputs.size(); ++k) {
    const std::string topic = o.ns + "/" + o.outputs[k];
    const std::string& name = o.outputs[k];
    if (name == "disparity") {
      subs.push_back(subscribeArrivals<stereo_msgs::DisparityImage>(nh, topic, hints, arrivals, k));
    } else if (name.find("points") != std::string::npos) {
      subs.push_back(subscribeArrivals<sensor_msgs::PointCloud2>(nh, topic, hints, arrivals, k));
    } else {
      subs.push_back(subscribeArrivals<sensor_msgs::Image>(nh, topic, hints, arrivals, k));
    }
  }
  NodeProcessing processing;
  // Not among the outputs waited for: stereo_image_proc publishes no diagnostics.
  const ros::Subscriber diagnostics = nh.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 10, [&processing](const diagnostic_msgs::DiagnosticArrayConstPtr& m) { processing.record(m); });
  ros::AsyncSpinner spinner(2);
  spinner.start();

  // The node subscribes lazily: wait until it takes the inputs and offers the outputs.
  const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(60);
  auto connected = [&] {
    if (pub_l.getNumSubscribers() == 0 || pub_r.getNumSubscribers() == 0 ||
        pub_li.getNumSubscribers() == 0 || pub_ri.getNumSubscribers() == 0)
      return false;
    for (const ros::Subscriber& s : subs) if (s.getNumPublishers() == 0) return false;
    return true;
  };
  while (ros::ok() && !connected()) {
    if (ros::WallTime::now() > give_up) throw std::runtime_error("the node under " + o.ns + " never connected");
    ros::WallDuration(0.05).sleep();
  }

  // Fixed-rate replay: frame k leaves at t0 + k / rate (steady clock), stamped now.
  using Clock = std::chrono::steady_clock;
  const size_t first_measured = static_cast<size_t>(o.warmup * o.rate);
  const size_t total = first_measured + (o.frames ? o.frames : static_cast<size_t>(o.seconds * o.rate));
  std::vector<uint64_t> stamps(total, 0);
  const Clock::time_point t0 = Clock::now() + std::chrono::milliseconds(200);
  size_t late = 0;
  ros::WallTime measuring_from;
  CoreTimes core_from;
  for (size_t k = 0; k < total && ros::ok(); ++k) {
    const auto due = t0 + std::chrono::nanoseconds(static_cast<int64_t>(1e9 * static_cast<double>(k) / o.rate));
    // The frame's messages are copied before it is due, so that its latency
    // starts when it is published, not while this process copies 12 MB (HD).
    const Frame& f = frames[k % frames.size()];
    sensor_msgs::ImagePtr l(new sensor_msgs::Image(f.left)), r(new sensor_msgs::Image(f.right));
    sensor_msgs::CameraInfoPtr li(new sensor_msgs::CameraInfo(f.left_info)), ri(new sensor_msgs::CameraInfo(f.right_info));
    if (Clock::now() > due + std::chrono::milliseconds(2)) ++late;
    std::this_thread::sleep_until(due);
    const ros::Time stamp = ros::Time::now();
    l->header.stamp = r->header.stamp = li->header.stamp = ri->header.stamp = stamp;
    l->header.seq = r->header.seq = li->header.seq = ri->header.seq = static_cast<uint32_t>(k);
    pub_li.publish(li);
    pub_ri.publish(ri);
    pub_l.publish(l);
    pub_r.publish(r);
    stamps[k] = stamp.toNSec();
    if (k == first_measured) {
      measuring_from = ros::WallTime::now();
      if (o.node_core >= 0) core_from = readCoreTimes(o.node_core);
    }
  }
  const double core_busy = o.node_core >= 0 ? busyShare(core_from, readCoreTimes(o.node_core)) : -1;
  char core_text[16] = "-";
  if (core_busy >= 0) std::snprintf(core_text, sizeof core_text, "%.0f%%", 100 * core_busy);
  ros::WallDuration(1.0).sleep();  // the last frames are still in the pipeline
  // A diagnostics period that began before the measured frames is left out.
  const double processing_ms = processing.median(measuring_from + ros::WallDuration(1.0), ros::WallTime::now());
  char processing_text[16] = "-";
  if (processing_ms >= 0) std::snprintf(processing_text, sizeof processing_text, "%.1f", processing_ms);

  std::vector<double> latency_ms, handled_ms;
  uint64_t first_out = 0, last_out = 0;
  const size_t measured = total - first_measured;
  for (size_t k = first_measured; k < total; ++k) {
    const uint64_t done = arrivals.complete(stamps[k]);
    if (done == 0) continue;
    latency_ms.push_back(1e-6 * static_cast<double>(done - stamps[k]));
    handled_ms.push_back(1e-6 * static_cast<double>(arrivals.complete(stamps[k], true) - stamps[k]));
    first_out = first_out ? std::min(first_out, done) : done;
    last_out = std::max(last_out, done);
  }
  const size_t out = latency_ms.size();
  const double out_rate = out > 1 ? 1e9 * static_cast<double>(out - 1) / static_cast<double>(last_out - first_out) : 0;
  std::printf("%-34s %6.0f Hz %6zu %6zu %6.1f%% %8.1f Hz %7.1f %7.1f %7.1f %7.1f %7s %7.1f %6s\n", o.label.c_str(), o.rate,
              measured, out, 100.0 * static_cast<double>(out) / static_cast<double>(measured), out_rate,
              percentile(latency_ms, 50), percentile(latency_ms, 95), percentile(latency_ms, 99),
              latency_ms.empty() ? 0.0 : *std::max_element(latency_ms.begin(), latency_ms.end()), processing_text,
              percentile(handled_ms, 99), core_text);
  if (!o.latencies.empty()) writeLatencies(o.latencies, o.outputs, stamps, first_measured, arrivals);
  if (late > total / 20) std::fprintf(stderr, "bdis_node_bench: %zu of %zu frames left late (> 2 ms)\n", late, total);
  if (!o.json.empty()) {
    std::ofstream js(o.json, std::ios::app);
    js << "{\"label\": \"" << o.label << "\", \"rate_hz\": " << o.rate << ", \"frames_sent\": " << measured
       << ", \"frames_out\": " << out << ", \"output_rate_hz\": " << out_rate
       << ", \"latency_ms_p50\": " << percentile(latency_ms, 50) << ", \"latency_ms_p95\": " << percentile(latency_ms, 95)
       << ", \"latency_ms_p99\": " << percentile(latency_ms, 99) << ", \"handled_latency_ms_p50\": "
       << percentile(handled_ms, 50) << ", \"handled_latency_ms_p99\": " << percentile(handled_ms, 99)
       << ", \"late_sends\": " << late
       << ", \"node_processing_ms\": " << (processing_ms >= 0 ? std::to_string(processing_ms) : "null")
       << ", \"node_core_busy\": " << (core_busy >= 0 ? std::to_string(core_busy) : "null")
       << ", \"frames_sent_total\": " << total << ", \"received_total\": {";
    for (size_t k = 0; k < o.outputs.size(); ++k)
      js << (k ? ", " : "") << "\"" << o.outputs[k] << "\": " << arrivals.received(k);
    js << "}}\n";
  }
  spinner.stop();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "bdis_node_bench", ros::init_options::AnonymousName);
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bdis_node_bench: %s\n", e.what());
    return 1;
  }
}
