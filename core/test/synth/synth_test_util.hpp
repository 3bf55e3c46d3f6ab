// Helpers shared by the synthetic-scene tests: a process-wide cache of
// rendered frames (several tests score the same frames), warping by ground
// truth, OpenCV DIS as a baseline and small image statistics.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "bdis_stereo/evaluation.hpp"
#include "bdis_stereo/synthetic_scene.hpp"

namespace synth_test {

using bdis::synth::SceneConfig;
using bdis::synth::SyntheticFrame;
using bdis::synth::SyntheticRenderer;

/// Every field that changes a render, as a key.
inline std::string configKey(const SceneConfig& c) {
  std::ostringstream k;
  k << static_cast<int>(c.scene) << '/' << static_cast<int>(c.lighting) << '/' << c.width << 'x' << c.height << '/'
    << c.focal << '/' << c.baseline << '/' << c.noise << '/' << c.seed << '/' << c.instrument << c.black_borders
    << c.textureless_patch << '/' << c.light_spot << '/' << c.exposure << '/' << c.right_gain << '/' << c.motion << '/' << c.supersampling << '/'
    << c.jpeg_quality;
  return k.str();
}

/// Frame `index` of `config`, rendered once per test process.
inline const SyntheticFrame& cachedFrame(const SceneConfig& config, int index) {
  static std::map<std::string, std::unique_ptr<SyntheticRenderer>> renderers;
  static std::map<std::string, SyntheticFrame> frames;
  const std::string key = configKey(config);
  const std::string fkey = key + "#" + std::to_string(index);
  auto it = frames.find(fkey);
  if (it != frames.end()) return it->second;
  auto& r = renderers[key];
  if (!r) r = std::make_unique<SyntheticRenderer>(config);
  return frames[fkey] = r->render(index);
}

/// The variant, optionally without noise.
inline SceneConfig variant(const std::string& name, double noise = -1.0) {
  SceneConfig c = SceneConfig::variant(name);
  if (noise >= 0) c.noise = noise;
  return c;
}

/// Right image sampled at (x - gt, y), bilinear; CV_8UC3 (or as the input).
inline cv::Mat warpRightToLeft(const cv::Mat& right, const cv::Mat& gt, float extra_shift = 0.f) {
  cv::Mat mapx(gt.size(), CV_32FC1), mapy(gt.size(), CV_32FC1);
  for (int y = 0; y < gt.rows; ++y) {
    for (int x = 0; x < gt.cols; ++x) {
      mapx.at<float>(y, x) = static_cast<float>(x) - gt.at<float>(y, x) - extra_shift;
      mapy.at<float>(y, x) = static_cast<float>(y);
    }
  }
  cv::Mat out;
  cv::remap(right, out, mapx, mapy, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
  return out;
}

inline cv::Mat grey(const cv::Mat& bgr) {
  cv::Mat g;
  cv::cvtColor(bgr, g, cv::COLOR_BGR2GRAY);
  return g;
}

/// |grey(left) - grey(warped right)| per pixel, CV_32FC1.
inline cv::Mat photometricError(const SyntheticFrame& f, float extra_shift = 0.f) {
  cv::Mat l, w, e;
  grey(f.left).convertTo(l, CV_32F);
  grey(warpRightToLeft(f.right, f.gt, extra_shift)).convertTo(w, CV_32F);
  cv::absdiff(l, w, e);
  return e;
}

/// Values of a CV_32FC1 image where mask != 0.
inline std::vector<float> valuesWhere(const cv::Mat& m, const cv::Mat& mask) {
  std::vector<float> v;
  for (int y = 0; y < m.rows; ++y) {
    for (int x = 0; x < m.cols; ++x) {
      if (mask.at<uchar>(y, x)) v.push_back(m.at<float>(y, x));
    }
  }
  return v;
}

inline double mean(const std::vector<float>& v) {
  double s = 0;
  for (float x : v) s += x;
  return v.empty() ? 0.0 : s / static_cast<double>(v.size());
}

/// q-quantile (0..1), nearest rank; 0 for an empty vector.
inline double quantile(std::vector<float> v, double q) {
  if (v.empty()) return 0.0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + static_cast<long>(k), v.end());
  return v[k];
}

inline double shareAbove(const std::vector<float>& v, float t) {
  if (v.empty()) return 0.0;
  return static_cast<double>(std::count_if(v.begin(), v.end(), [t](float x) { return x > t; })) /
         static_cast<double>(v.size());
}

/// Pixels with ground truth (gt > 0), CV_8UC1 255/0.
inline cv::Mat knownMask(const SyntheticFrame& f) { return f.gt > 0.f; }

/// Pixels not within `radius` px of an edge of `mask`.
inline cv::Mat awayFromEdges(const cv::Mat& labels, int radius) {
  cv::Mat edges(labels.size(), CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < labels.rows; ++y) {
    for (int x = 0; x < labels.cols; ++x) {
      const uchar v = labels.at<uchar>(y, x);
      if ((x + 1 < labels.cols && labels.at<uchar>(y, x + 1) != v) ||
          (y + 1 < labels.rows && labels.at<uchar>(y + 1, x) != v)) {
        edges.at<uchar>(y, x) = 255;
      }
    }
  }
  cv::dilate(edges, edges, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * radius + 1, 2 * radius + 1)));
  return edges == 0;
}

/// OpenCV DIS (fast preset, one thread) from left to right; disparity =
/// -flow_x, negative (impossible) disparities count as no estimate. As
/// bdis_eval runs it.
inline cv::Mat disFastDisparity(const cv::Mat& left, const cv::Mat& right) {
  cv::setNumThreads(1);
  static cv::Ptr<cv::DISOpticalFlow> dis = cv::DISOpticalFlow::create(cv::DISOpticalFlow::PRESET_FAST);
  cv::Mat flow;
  dis->calc(grey(left), grey(right), flow);
  cv::Mat d(left.size(), CV_32FC1);
  for (int y = 0; y < d.rows; ++y) {
    for (int x = 0; x < d.cols; ++x) {
      const float v = -flow.at<cv::Vec2f>(y, x)[0];
      d.at<float>(y, x) = v >= 0.f ? v : -1.f;
    }
  }
  return d;
}

/// `gt` with everything outside `mask` set to unknown (0), to score a region.
inline cv::Mat restrictGt(const cv::Mat& gt, const cv::Mat& mask) {
  cv::Mat g = gt.clone();
  g.setTo(0.f, mask == 0);
  return g;
}

inline void printScore(const char* what, const bdis::DisparityScore& s) {
  std::printf("  %-34s density %.3f  median %.3f  mean %.3f  bad2 %5.1f%%  miss_or_bad2 %5.1f%%\n", what,
              s.density(), s.medianError(), s.meanError(), 100 * s.bad2Rate(), 100 * s.missOrBad2Rate());
}

}  // namespace synth_test
