// Per-frame compute time of the matcher (each preset) against OpenCV's DIS
// fast preset on the same frames in the same process, single-threaded.
//
// Two modes:
//   bdis_bench [Google Benchmark flags]
//       Google Benchmark loops. Frames: the synthetic sequences of the shared
//       data folder ($BDIS_DATA_DIR or ../shared/data); without them, a
//       procedurally textured 640x480 pair. Image-size scaling (BM_Scaling*):
//       generated scenes (bdis::synth, the demo sample's configuration) at
//       320x240, 640x480, 1280x720 and 1920x1080, rendered once (about 15 s).
//   bdis_bench --table [--rounds N] [--no-sequences] [--no-scaling] [--set NAME=VALUE ...]
//       One markdown table (what scripts/bench.sh prints): per synthetic
//       sequence and per in-vivo sequence (real endoscope frames with a black
//       rectification frame, whose patches take the masked paths), the median
//       over all frames (each timed N times, methods
//       interleaved frame by frame) of the thread CPU time of one compute, for
//       bdis fast / balanced / balanced without the confidence (what a node
//       with no confidence subscriber computes) / accurate and DIS fast, and the ratio to DIS
//       fast; then the same for balanced (searched down to level 1, which
//       gives the kernels' scaling exponent, and with the finest level as
//       set, by default from the width) and DIS fast on generated scenes of
//       each size, the sizes taking turns round by round (6N rounds), once
//       back to back and once with the caches emptied before each frame. Thread
//       CPU time, not wall time: on a shared machine it does not count the
//       time other processes hold the core. --set changes the
//       balanced rows (to time a setting before making it the default).
//   bdis_bench --one-frame bdis_fast|bdis_balanced|bdis_accurate|dis_fast [--pair LEFT RIGHT]
//       Computes the first pair of the first sequence (or the pair of image
//       files given) twice and brackets the second compute with
//       CALLGRIND_START/STOP_INSTRUMENTATION, for
//       `valgrind --tool=callgrind --instr-atstart=no` (instructions per frame).
//       --set changes bdis_balanced here too.
// Pin to one core for stable numbers: taskset -c 1 bdis_bench ...
#include <benchmark/benchmark.h>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#if __has_include(<valgrind/callgrind.h>)
#include <valgrind/callgrind.h>
#else
#define CALLGRIND_START_INSTRUMENTATION
#define CALLGRIND_STOP_INSTRUMENTATION
#endif

#include "bdis_stereo/evaluation.hpp"
#include "bdis_stereo/geometry.hpp"
#include "bdis_stereo/matcher.hpp"
#include "bdis_stereo/synthetic_scene.hpp"

namespace {

using Pairs = std::vector<std::pair<cv::Mat, cv::Mat>>;  // BGR left, right

const char* const kSequences[] = {"synthetic_colon_diffuse", "synthetic_colon_specular"};
/// The table also times these (no ground truth needed to time them).
const char* const kInVivoSequences[] = {"invivo_hamlyn_a", "invivo_hamlyn_b"};

Pairs loadSequence(const std::string& dir) {
  Pairs out;
  const bdis::StereoSequence seq = bdis::StereoSequence::open(dir);
  for (size_t i = 0; i < seq.names.size(); ++i) out.emplace_back(seq.left(i), seq.right(i));
  return out;
}

/// Every frame of the shared synthetic sequences, or one textured pair without them.
const Pairs& frames() {
  static const Pairs f = [] {
    Pairs out;
    const std::string data = bdis::findDataDir();
    if (!data.empty()) {
      for (const char* name : kSequences) {
        const Pairs seq = loadSequence(data + "/" + name);
        out.insert(out.end(), seq.begin(), seq.end());
      }
    } else {
      cv::Mat noise(480, 700, CV_8UC3);
      cv::randu(noise, 20, 235);
      cv::GaussianBlur(noise, noise, cv::Size(0, 0), 2.0);
      out.emplace_back(noise(cv::Rect(30, 0, 640, 480)).clone(),
                       noise(cv::Rect(0, 0, 640, 480)).clone());
    }
    return out;
  }();
  return f;
}

/// Two frames (0 and 15) of the sample scene at width x height, focal length
/// scaled with the width (same field of view, so disparities scale too).
const Pairs& scaledFrames(int width, int height) {
  static std::map<std::pair<int, int>, Pairs> cache;
  auto& pairs = cache[{width, height}];
  if (pairs.empty()) {
    bdis::synth::SceneConfig cfg;  // the demo sample: tissue, specular, instrument
    cfg.width = width;
    cfg.height = height;
    const bdis::synth::SyntheticRenderer renderer(cfg);
    for (int i : {0, 15}) {
      const bdis::synth::SyntheticFrame f = renderer.render(i);
      pairs.emplace_back(f.left, f.right);
    }
  }
  return pairs;
}

/// One method on BGR pairs, its buffers kept between frames as in a video loop.
struct Method {
  std::string name;
  std::function<void(const cv::Mat& left, const cv::Mat& right)> compute;
};

Method bdisMethod(const std::string& name, const bdis::MatcherParams& params,
                  const bdis::MatchOutputs& outputs = bdis::MatchOutputs{}) {
  auto matcher = std::make_shared<bdis::Matcher>(params);
  auto result = std::make_shared<bdis::MatchResult>();
  return {name, [matcher, result, outputs](const cv::Mat& l, const cv::Mat& r) {
            matcher->compute(l, r, *result, outputs);
            benchmark::DoNotOptimize(result->disparity.data);
          }};
}

/// OpenCV's DIS fast preset. Its input is grey: the conversion is not timed
/// (the caller passes grey images), as DIS users would convert anyway.
Method disFastMethod() {
  auto dis = cv::DISOpticalFlow::create(cv::DISOpticalFlow::PRESET_FAST);
  auto flow = std::make_shared<cv::Mat>();
  return {"DIS fast", [dis, flow](const cv::Mat& l, const cv::Mat& r) {
            dis->calc(l, r, *flow);
            benchmark::DoNotOptimize(flow->data);
          }};
}

Pairs toGrey(const Pairs& pairs) {
  Pairs grey(pairs.size());
  for (size_t k = 0; k < pairs.size(); ++k) {
    cv::cvtColor(pairs[k].first, grey[k].first, cv::COLOR_BGR2GRAY);
    cv::cvtColor(pairs[k].second, grey[k].second, cv::COLOR_BGR2GRAY);
  }
  return grey;
}

// ---- Google Benchmark loops ---------------------------------------------------

/// Times `method` over `pairs` in turn, after one untimed frame that sizes its buffers.
void timeLoop(benchmark::State& state, const Method& method, const Pairs& pairs) {
  method.compute(pairs[0].first, pairs[0].second);
  size_t i = 0;
  for (auto _ : state) {
    const auto& p = pairs[i++ % pairs.size()];
    method.compute(p.first, p.second);
  }
}

void BM_Bdis(benchmark::State& state, const std::string& preset) {
  cv::setNumThreads(1);
  timeLoop(state, bdisMethod(preset, bdis::MatcherParams::preset(preset)), frames());
  state.SetItemsProcessed(state.iterations());
}

void BM_OpenCvDisFast(benchmark::State& state) {
  cv::setNumThreads(1);
  timeLoop(state, disFastMethod(), toGrey(frames()));
  state.SetItemsProcessed(state.iterations());
}

BENCHMARK(BM_OpenCvDisFast)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK_CAPTURE(BM_Bdis, fast, std::string("fast"))->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK_CAPTURE(BM_Bdis, balanced, std::string("balanced"))->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK_CAPTURE(BM_Bdis, accurate, std::string("accurate"))->Unit(benchmark::kMillisecond)->MinTime(2.0);

/// Frame size and time per megapixel (printed in seconds: "25m" = 25 ms/MPix).
void sizeCounters(benchmark::State& state, int width, int height) {
  const double mpix = width * height / 1e6;
  state.counters["MPix"] = mpix;
  state.counters["per_MPix"] =
      benchmark::Counter(mpix, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

/// Balanced searched down to level 1 at every size: how the kernels scale.
bdis::MatcherParams levelOne(bdis::MatcherParams p) {
  p.finest_level = 1;
  return p;
}

void BM_ScalingBdis(benchmark::State& state) {
  cv::setNumThreads(1);
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  timeLoop(state, bdisMethod("balanced", levelOne(bdis::MatcherParams{})), scaledFrames(w, h));
  sizeCounters(state, w, h);
}

/// Balanced as it runs by default: the finest level from the width.
void BM_ScalingBdisDefaultLevels(benchmark::State& state) {
  cv::setNumThreads(1);
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  timeLoop(state, bdisMethod("balanced", bdis::MatcherParams{}), scaledFrames(w, h));
  sizeCounters(state, w, h);
}

void BM_ScalingOpenCvDisFast(benchmark::State& state) {
  cv::setNumThreads(1);
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  timeLoop(state, disFastMethod(), toGrey(scaledFrames(w, h)));
  sizeCounters(state, w, h);
}

const std::pair<int, int> kScalingSizes[] = {{320, 240}, {640, 480}, {1280, 720}, {1920, 1080}};

void scalingSizes(benchmark::internal::Benchmark* b) {
  b->ArgNames({"w", "h"});
  for (const auto& s : kScalingSizes) b->Args({s.first, s.second});
  b->Unit(benchmark::kMillisecond)->MinTime(1.0);
}

BENCHMARK(BM_ScalingOpenCvDisFast)->Apply(scalingSizes);
BENCHMARK(BM_ScalingBdis)->Apply(scalingSizes);
BENCHMARK(BM_ScalingBdisDefaultLevels)->Apply(scalingSizes);

/// A disparity map of `width` x `height`: a ramp of 5-120 px with every 7th pixel unknown.
cv::Mat1f rampDisparity(int width, int height) {
  cv::Mat1f d(height, width);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      d(y, x) = (x + y) % 7 == 0 ? bdis::kNoDisparity : 5.f + 115.f * static_cast<float>(x) / static_cast<float>(width);
    }
  }
  return d;
}

/// Depth from disparity (the node's depth image, and points2's source), per frame size.
void BM_DisparityToDepth(benchmark::State& state) {
  const cv::Mat1f d = rampDisparity(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  const bdis::StereoCamera camera = bdis::StereoCamera::symmetric(520, 520, 320, 240, 0.005);
  cv::Mat depth;
  for (auto _ : state) {
    bdis::disparityToDepth(d, camera, depth);
    benchmark::DoNotOptimize(depth.data);
  }
  sizeCounters(state, d.cols, d.rows);
}

/// The reference for it: OpenCV's element-wise division alone (no unknowns handled).
void BM_OpenCvDivide(benchmark::State& state) {
  cv::setNumThreads(1);
  const cv::Mat1f d = rampDisparity(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  cv::Mat depth;
  for (auto _ : state) {
    cv::divide(520.0 * 0.005, d, depth);
    benchmark::DoNotOptimize(depth.data);
  }
  sizeCounters(state, d.cols, d.rows);
}

BENCHMARK(BM_OpenCvDivide)->Apply(scalingSizes);
BENCHMARK(BM_DisparityToDepth)->Apply(scalingSizes);

// ---- --table: one table of medians of thread CPU time -------------------------

double threadCpuMs() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) * 1e-6;
}

/// Least-squares slope of y over x.
double slope(const std::vector<double>& x, const std::vector<double>& y) {
  const double n = static_cast<double>(x.size());
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (size_t i = 0; i < x.size(); ++i) sx += x[i], sy += y[i], sxx += x[i] * x[i], sxy += x[i] * y[i];
  return (n * sxy - sx * sy) / (n * sxx - sx * sx);
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/// Size of cpu0's largest cache (the L3) from sysfs ("32768K"), 32 MB if
/// unknown. Not sysconf(_SC_LEVEL3_CACHE_SIZE): glibc reports the whole
/// package's L3 there on some CPUs (384 MB for a 32 MB L3 here).
size_t lastLevelCacheBytes() {
  size_t best = 0;
  for (int index = 0; index < 8; ++index) {
    std::ifstream in("/sys/devices/system/cpu/cpu0/cache/index" + std::to_string(index) + "/size");
    size_t kb = 0;
    if (in >> kb) best = std::max(best, kb << 10);  // the value ends in K
  }
  return best > 0 ? best : size_t{32} << 20;
}

/// Reads a buffer three times the size of the last-level cache, so that nothing of
/// the previous frame is cached: each frame then starts as in a node, where
/// the images arrive from memory and the work between frames (messages,
/// clouds, other nodes) has displaced the matcher's buffers. Reads, not
/// writes: no dirty lines are left to be written back during the next frame.
class CacheEvictor {
 public:
  CacheEvictor() {
    buffer_.assign(std::clamp(3 * lastLevelCacheBytes(), size_t{64} << 20, size_t{512} << 20), 1);
  }
  size_t bytes() const { return buffer_.size(); }
  void evict() {
    unsigned sum = 0;
    for (size_t i = 0; i < buffer_.size(); i += 64) sum += buffer_[i];
    benchmark::DoNotOptimize(sum);
  }

 private:
  std::vector<unsigned char> buffer_;
};

/// Methods timed on one set of frames, each warmed up on the first frame;
/// DIS gets the grey frames, bdis the BGR ones. With an evictor, the caches
/// are emptied (untimed) before each timed compute.
class TimedFrames {
 public:
  TimedFrames(const std::vector<Method>& methods, const Pairs& bgr, CacheEvictor* evictor = nullptr)
      : methods_(&methods), bgr_(bgr), grey_(toGrey(bgr)), times_(methods.size()), evictor_(evictor) {
    for (const Method& m : methods) run(m, 0);
  }
  /// One pass over the frames; the methods take turns frame by frame so a
  /// change of load on the machine hits all of them alike.
  void timePass() {
    for (size_t k = 0; k < bgr_.size(); ++k) {
      for (size_t i = 0; i < methods_->size(); ++i) {
        if (evictor_) evictor_->evict();
        const double t0 = threadCpuMs();
        run((*methods_)[i], k);
        times_[i].push_back(threadCpuMs() - t0);
      }
    }
  }
  /// Median per-frame time (ms) of each method.
  std::vector<double> medians() const { return medians(0, 1); }
  /// The same over share `part` of `parts` equal, consecutive shares of the
  /// frames timed so far (in the order they were timed).
  std::vector<double> medians(size_t part, size_t parts) const {
    std::vector<double> out;
    for (const auto& t : times_) {
      const auto first = t.begin() + static_cast<std::ptrdiff_t>(part * t.size() / parts);
      const auto last = t.begin() + static_cast<std::ptrdiff_t>((part + 1) * t.size() / parts);
      out.push_back(median(std::vector<double>(first, last)));
    }
    return out;
  }

 private:
  void run(const Method& m, size_t k) const {
    const auto& p = m.name == "DIS fast" ? grey_[k] : bgr_[k];
    m.compute(p.first, p.second);
  }
  const std::vector<Method>* methods_;
  Pairs bgr_, grey_;
  std::vector<std::vector<double>> times_;  ///< per method
  CacheEvictor* evictor_;
};

/// Median per-frame time (ms) of each method over `rounds` passes over the frames.
std::vector<double> medianTimes(const std::vector<Method>& methods, const Pairs& bgr, int rounds) {
  TimedFrames timed(methods, bgr);
  for (int r = 0; r < rounds; ++r) timed.timePass();
  return timed.medians();
}

/// The scaling rounds are also split into this many consecutive shares, each
/// timing every size: the exponent of each share shows how far the run's own
/// noise moves it.
constexpr size_t kScalingShares = 5;

struct ScalingTimes {
  std::vector<std::vector<double>> ms;  ///< per size, per method: median per-frame time
  std::vector<int> rounds;              ///< per size: timed passes over its frames
  /// per share of the rounds, per size, per method: median per-frame time
  std::vector<std::vector<std::vector<double>>> share_ms;
};

/// medianTimes for every scaling size at once: each round times every size
/// in turn (a smaller size more often, so that each gets about the same
/// time), so a change of the machine's speed during the run hits every size
/// alike instead of bending the scaling exponent.
ScalingTimes scalingMedianTimes(const std::vector<std::vector<Method>>& methods, int rounds,
                                CacheEvictor* evictor = nullptr) {
  const double largest = 1920.0 * 1080.0;
  std::vector<TimedFrames> sizes;
  std::vector<int> repeats;
  for (size_t i = 0; i < std::size(kScalingSizes); ++i) {
    const auto [w, h] = kScalingSizes[i];
    sizes.emplace_back(methods[i], scaledFrames(w, h), evictor);
    repeats.push_back(std::max(1, static_cast<int>(largest / (static_cast<double>(w) * h))));
  }
  for (int r = 0; r < rounds; ++r) {
    for (size_t i = 0; i < sizes.size(); ++i) {
      for (int rep = 0; rep < repeats[i]; ++rep) sizes[i].timePass();
    }
  }
  ScalingTimes out;
  out.share_ms.resize(kScalingShares);
  for (size_t i = 0; i < sizes.size(); ++i) {
    out.ms.push_back(sizes[i].medians());
    out.rounds.push_back(rounds * repeats[i]);
    for (size_t k = 0; k < kScalingShares; ++k) {
      out.share_ms[k].push_back(sizes[i].medians(k, kScalingShares));
    }
  }
  return out;
}

void printRows(const std::string& what, cv::Size size, size_t frames, int rounds,
               const std::vector<Method>& methods, const std::vector<double>& ms) {
  const double dis_ms = ms.back();  // DIS fast is always last
  const double mpix = size.area() / 1e6;
  for (size_t i = 0; i < methods.size(); ++i) {
    std::printf("| %s | %s | %dx%d | %zu x %d | %.2f ms | %.1f ms | %.2f |\n", what.c_str(),
                methods[i].name.c_str(), size.width, size.height, frames, rounds, ms[i],
                ms[i] / mpix, ms[i] / dis_ms);
  }
  std::fflush(stdout);
}

bdis::MatcherParams applySet(bdis::MatcherParams p, const std::string& assignment) {
  const size_t eq = assignment.find('=');
  if (eq == std::string::npos)
    throw std::invalid_argument("--set needs NAME=VALUE, got '" + assignment + "'");
  // The same rules as bdis_match's --set.
  bdis::bindParam(p, assignment.substr(0, eq), bdis::ParamValue::fromText(assignment.substr(eq + 1)),
                  "--set");
  p.validate();
  return p;
}

int runTable(int rounds, bool sequences, bool scaling, const bdis::MatcherParams& balanced) {
  cv::setNumThreads(1);
  const bool modified = bdis::toYaml(balanced) != bdis::toYaml(bdis::MatcherParams{});
  const std::string balanced_name = modified ? "bdis balanced (--set)" : "bdis balanced";
  auto allMethods = [&] {
    bdis::MatchOutputs disparity_only;
    disparity_only.confidence = disparity_only.variance = false;
    return std::vector<Method>{bdisMethod("bdis fast", bdis::MatcherParams::preset("fast")),
                               bdisMethod(balanced_name, balanced),
                               bdisMethod(balanced_name + ", no confidence", balanced, disparity_only),
                               bdisMethod("bdis accurate", bdis::MatcherParams::preset("accurate")),
                               disFastMethod()};
  };
  std::printf("| measurement | method | size | frames x rounds | per frame | per MPix | / DIS fast |\n");
  std::printf("|---|---|---|---|---|---|---|\n");
  const std::string data = sequences ? bdis::findDataDir() : std::string();
  if (sequences && data.empty()) {
    std::printf("| (shared data folder not found: set BDIS_DATA_DIR) | | | | | | |\n");
  } else if (sequences) {
    auto timeSequence = [&](const char* name) {
      const Pairs pairs = loadSequence(data + "/" + name);
      const std::vector<Method> methods = allMethods();
      printRows(std::string("time, ") + name, pairs[0].first.size(), pairs.size(), rounds, methods,
                medianTimes(methods, pairs, rounds));
    };
    for (const char* name : kSequences) timeSequence(name);
    for (const char* name : kInVivoSequences) timeSequence(name);
  }
  if (scaling) {
    // Twice: frames back to back, as the other rows (a small frame's buffers
    // stay cached from one frame to the next), and with the caches emptied
    // before each frame (every frame starts from memory, as in a node).
    CacheEvictor evictor;
    for (const bool evicted : {false, true}) {
      // Per size: balanced searched down to level 1 (how the kernels scale:
      // the exponent), balanced with its finest level (the default: from
      // the width), DIS fast.
      std::vector<std::vector<Method>> methods;
      for (size_t i = 0; i < std::size(kScalingSizes); ++i) {
        methods.push_back({bdisMethod(balanced_name + ", finest level 1", levelOne(balanced)),
                           bdisMethod(balanced_name + ", finest level as set", balanced), disFastMethod()});
      }
      // 30 rounds at the default 5: about 30 s in all (twice that with eviction).
      const ScalingTimes t = scalingMedianTimes(methods, 6 * rounds, evicted ? &evictor : nullptr);
      const std::string what =
          evicted ? "time, generated scene (scaling), caches emptied before each frame (" +
                        std::to_string(evictor.bytes() >> 20) + " MB read)"
                  : std::string("time, generated scene (scaling)");
      std::vector<double> log_pixels, log_ms[2];
      for (size_t i = 0; i < std::size(kScalingSizes); ++i) {
        const auto [w, h] = kScalingSizes[i];
        printRows(what, cv::Size(w, h), scaledFrames(w, h).size(), t.rounds[i], methods[i], t.ms[i]);
        log_pixels.push_back(std::log(static_cast<double>(w) * h));
        log_ms[0].push_back(std::log(t.ms[i].front()));
        log_ms[1].push_back(std::log(t.ms[i].back()));
      }
      // Time ~ pixels^e: e = 1 is linear; above 1 the time grows faster than the pixel count.
      const double e_bdis = slope(log_pixels, log_ms[0]), e_dis = slope(log_pixels, log_ms[1]);
      // The same fit per share of the rounds: the spread the run's noise gives.
      double share_min[2] = {1e9, 1e9}, share_max[2] = {-1e9, -1e9};
      for (const auto& share : t.share_ms) {
        for (size_t m = 0; m < 2; ++m) {
          std::vector<double> log_share;
          for (const auto& per_size : share) log_share.push_back(std::log(m == 0 ? per_size.front() : per_size.back()));
          const double e = slope(log_pixels, log_share);
          share_min[m] = std::min(share_min[m], e);
          share_max[m] = std::max(share_max[m], e);
        }
      }
      for (size_t m = 0; m < 2; ++m) {
        const double e = m == 0 ? e_bdis : e_dis;
        std::printf("| scaling exponent e, time ~ pixels^e (least squares over the sizes above%s; "
                    "in brackets e of each fifth of the rounds) | %s | 320x240 .. 1920x1080 | | "
                    "e = %.3f (%.3f-%.3f) | | %.2f |\n",
                    evicted ? ", caches emptied" : "",
                    m == 0 ? (balanced_name + ", finest level 1").c_str() : "DIS fast",
                    e, share_min[m], share_max[m], e / e_dis);
      }
      std::fflush(stdout);
    }
  }
  return 0;
}

// ---- --one-frame: instructions of one compute under callgrind -----------------

int runOneFrame(const std::string& which, const bdis::MatcherParams& balanced,
                const std::vector<std::string>& pair) {
  cv::setNumThreads(1);
  Pairs bgr;
  if (pair.empty()) {
    bgr.push_back(frames().front());
  } else {
    bgr.emplace_back(cv::imread(pair[0], cv::IMREAD_COLOR), cv::imread(pair[1], cv::IMREAD_COLOR));
    if (bgr[0].first.empty() || bgr[0].second.empty()) {
      throw std::invalid_argument("--pair: cannot read " + pair[0] + " or " + pair[1]);
    }
  }
  Method method;
  Pairs input = bgr;
  if (which == "dis_fast") {
    method = disFastMethod();
    input = toGrey(bgr);
  } else if (which.rfind("bdis_", 0) == 0) {
    const std::string preset = which.substr(5);
    method = bdisMethod(which, preset == "balanced" ? balanced : bdis::MatcherParams::preset(preset));
  } else {
    throw std::invalid_argument("--one-frame takes bdis_fast, bdis_balanced, bdis_accurate or dis_fast");
  }
  method.compute(input[0].first, input[0].second);  // sizes the buffers
  CALLGRIND_START_INSTRUMENTATION;
  method.compute(input[0].first, input[0].second);
  CALLGRIND_STOP_INSTRUMENTATION;
  return 0;
}

/// OpenCV's DIS allocates scratch images in every calc(). glibc gives freed memory at the heap's
/// top back to the OS, so whether each call pays for fresh pages (about 500 page faults, several
/// ms on a virtual machine) depended on where earlier allocations happened to sit: the first
/// sequence timed paid them, the second did not. Keeping freed memory in the process gives every
/// method its steady-state time, whatever ran before it.
void keepFreedMemory() {
#if defined(__GLIBC__)
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  mallopt(M_MMAP_THRESHOLD, 32 << 20);  // glibc's upper limit on 64-bit
#endif
}

}  // namespace

int main(int argc, char** argv) {
  keepFreedMemory();
  try {
    bool table = false, sequences = true, scaling = true;
    int rounds = 5;
    std::string one_frame;
    std::vector<std::string> pair;
    bdis::MatcherParams balanced;
    std::vector<char*> rest{argv[0]};
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      const bool has_value = i + 1 < argc;
      if (a == "--table") {
        table = true;
      } else if (a == "--no-scaling") {
        scaling = false;
      } else if (a == "--no-sequences") {
        sequences = false;
      } else if (a == "--rounds" && has_value) {
        rounds = std::max(1, std::stoi(argv[++i]));
      } else if (a == "--set" && has_value) {
        balanced = applySet(balanced, argv[++i]);
      } else if (a == "--one-frame" && has_value) {
        one_frame = argv[++i];
      } else if (a == "--pair" && i + 2 < argc) {
        pair = {argv[i + 1], argv[i + 2]};
        i += 2;
      } else {
        rest.push_back(argv[i]);
      }
    }
    if (!one_frame.empty()) return runOneFrame(one_frame, balanced, pair);
    if (table) return runTable(rounds, sequences, scaling, balanced);
    int bench_argc = static_cast<int>(rest.size());
    benchmark::Initialize(&bench_argc, rest.data());
    if (benchmark::ReportUnrecognizedArguments(bench_argc, rest.data())) return 1;
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bdis_bench: error: %s\n", e.what());
    return 1;
  }
}
