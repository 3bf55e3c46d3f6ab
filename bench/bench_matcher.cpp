// Per-frame compute time of the matcher (each preset) against OpenCV's DIS
// fast preset on the same frames in the same process, single-threaded.
// Frames: the synthetic sequences of the shared data folder ($BDIS_DATA_DIR or
// ../shared/data); without them, a procedurally textured 640x480 pair.
// Image-size scaling (BM_Scaling*): generated scenes (bdis::synth, the demo
// sample's configuration) at 320x240, 640x480, 1280x720 and 1920x1080,
// rendered once at start-up (about 15 s).
// Pin to one core for stable numbers: taskset -c 1 bdis_bench
#include <benchmark/benchmark.h>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include <map>

#include "bdis_stereo/evaluation.hpp"
#include "bdis_stereo/matcher.hpp"
#include "bdis_stereo/synthetic_scene.hpp"

namespace {

using Pairs = std::vector<std::pair<cv::Mat, cv::Mat>>;  // BGR left, right

struct Frames {
  Pairs pairs;
};

const Frames& frames() {
  static const Frames f = [] {
    Frames out;
    const std::string data = bdis::findDataDir();
    if (!data.empty()) {
      for (const char* name : {"synthetic_colon_diffuse", "synthetic_colon_specular"}) {
        const bdis::StereoSequence seq = bdis::StereoSequence::open(data + "/" + name);
        for (size_t i = 0; i < seq.names.size(); ++i) out.pairs.emplace_back(seq.left(i), seq.right(i));
      }
    } else {
      cv::Mat noise(480, 700, CV_8UC3);
      cv::randu(noise, 20, 235);
      cv::GaussianBlur(noise, noise, cv::Size(0, 0), 2.0);
      out.pairs.emplace_back(noise(cv::Rect(30, 0, 640, 480)).clone(),
                             noise(cv::Rect(0, 0, 640, 480)).clone());
    }
    return out;
  }();
  return f;
}

/// Times the matcher over `pairs` in turn, after one untimed frame that sizes its buffers.
void timeBdis(benchmark::State& state, const std::string& preset, const Pairs& pairs) {
  cv::setNumThreads(1);
  bdis::Matcher matcher(bdis::MatcherParams::preset(preset));
  bdis::MatchResult result;
  matcher.compute(pairs[0].first, pairs[0].second, result);
  size_t i = 0;
  for (auto _ : state) {
    const auto& p = pairs[i++ % pairs.size()];
    matcher.compute(p.first, p.second, result);
    benchmark::DoNotOptimize(result.disparity.data);
  }
}

/// The same for OpenCV's DIS fast preset on the grey pairs (converted untimed).
void timeOpenCvDisFast(benchmark::State& state, const Pairs& pairs) {
  cv::setNumThreads(1);
  auto dis = cv::DISOpticalFlow::create(cv::DISOpticalFlow::PRESET_FAST);
  Pairs grey(pairs.size());
  for (size_t k = 0; k < pairs.size(); ++k) {
    cv::cvtColor(pairs[k].first, grey[k].first, cv::COLOR_BGR2GRAY);
    cv::cvtColor(pairs[k].second, grey[k].second, cv::COLOR_BGR2GRAY);
  }
  cv::Mat flow;
  dis->calc(grey[0].first, grey[0].second, flow);
  size_t i = 0;
  for (auto _ : state) {
    const auto& p = grey[i++ % grey.size()];
    dis->calc(p.first, p.second, flow);
    benchmark::DoNotOptimize(flow.data);
  }
}

void BM_Bdis(benchmark::State& state, const std::string& preset) {
  timeBdis(state, preset, frames().pairs);
  state.SetItemsProcessed(state.iterations());
}

void BM_OpenCvDisFast(benchmark::State& state) {
  timeOpenCvDisFast(state, frames().pairs);
  state.SetItemsProcessed(state.iterations());
}

BENCHMARK(BM_OpenCvDisFast)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK_CAPTURE(BM_Bdis, fast, std::string("fast"))->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK_CAPTURE(BM_Bdis, balanced, std::string("balanced"))->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK_CAPTURE(BM_Bdis, accurate, std::string("accurate"))->Unit(benchmark::kMillisecond)->MinTime(2.0);

// ---- Image-size scaling on generated scenes -------------------------------

/// Two frames (0 and 15) of the sample scene at width x height, focal length
/// scaled with the width (same field of view, so disparities scale too).
const Pairs& scaledFrames(int width, int height) {
  static std::map<std::pair<int, int>, Pairs> cache;
  auto& frames = cache[{width, height}];
  if (frames.empty()) {
    bdis::synth::SceneConfig cfg;  // the demo sample: tissue, specular, instrument
    cfg.width = width;
    cfg.height = height;
    const bdis::synth::SyntheticRenderer renderer(cfg);
    for (int i : {0, 15}) {
      const bdis::synth::SyntheticFrame f = renderer.render(i);
      frames.emplace_back(f.left, f.right);
    }
  }
  return frames;
}

/// Frame size and time per megapixel (printed in seconds: "25m" = 25 ms/MPix).
void sizeCounters(benchmark::State& state, int width, int height) {
  const double mpix = width * height / 1e6;
  state.counters["MPix"] = mpix;
  state.counters["per_MPix"] =
      benchmark::Counter(mpix, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

void BM_ScalingBdis(benchmark::State& state) {
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  timeBdis(state, "balanced", scaledFrames(w, h));
  sizeCounters(state, w, h);
}

void BM_ScalingOpenCvDisFast(benchmark::State& state) {
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  timeOpenCvDisFast(state, scaledFrames(w, h));
  sizeCounters(state, w, h);
}

void scalingSizes(benchmark::internal::Benchmark* b) {
  b->ArgNames({"w", "h"});
  for (const auto& s : {std::pair<int, int>{320, 240}, {640, 480}, {1280, 720}, {1920, 1080}}) {
    b->Args({s.first, s.second});
  }
  b->Unit(benchmark::kMillisecond)->MinTime(1.0);
}

BENCHMARK(BM_ScalingOpenCvDisFast)->Apply(scalingSizes);
BENCHMARK(BM_ScalingBdis)->Apply(scalingSizes);

}  // namespace

BENCHMARK_MAIN();
