// bdis_eval: scores sequences with ground truth exactly as the data README
// defines, for this matcher and, in the same run on the same frames, for
// OpenCV's DIS (fast, medium) and SGBM, so every report carries its baselines.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "bdis_stereo/evaluation.hpp"
#include "bdis_stereo/matcher.hpp"
#include "tool_common.hpp"

namespace {

using namespace bdis;
using namespace bdis::tools;

constexpr const char* kUsage = R"(usage: bdis_eval SEQUENCE_DIR [SEQUENCE_DIR ...] [options]

Scores each sequence (left/, right/, gt_disparity/) for this matcher and, in the
same run, OpenCV DIS fast, DIS medium and SGBM. Single-threaded; per-method time
is the median over frames, each method warmed up once on the first frame.

options:
  --preset NAME        fast | balanced (default) | accurate
  --params FILE.yaml   parameter file on top of the preset
  --set NAME=VALUE     override one matcher parameter (repeatable)
  --methods LIST       comma-separated subset of bdis,dis_fast,dis_medium,sgbm (default: all)
  --frames N           use at most N frames per sequence
  --json FILE          also write the results as JSON
  --dump-dir DIR       write every disparity as DIR/<sequence>/<method>/<frame>.png (16-bit, d*256)
  --predictions DIR    score disparities computed elsewhere (DIR/<frame>.png, 16-bit, d*256,
                       0 = none; e.g. recorded from the nodelet) as method 'predictions'; one
                       sequence only; frames without a file are skipped for every method;
                       other methods run only when --methods names them
                       and bdis confidence as conf_<frame>.png (16-bit, c*65535)
)";

/// A disparity method under test: fills CV_32FC1 disparity, negative = none,
/// and its confidence in [0, 1] where the method has one (else leaves it empty).
struct Method {
  std::string name;
  std::function<void(const cv::Mat& left, const cv::Mat& right, cv::Mat& disparity)> run;
  std::function<cv::Mat()> confidence = [] { return cv::Mat(); };
};

Method makeBdis(const MatcherParams& params) {
  auto matcher = std::make_shared<Matcher>(params);
  auto result = std::make_shared<MatchResult>();
  return {"bdis",
          [matcher, result](const cv::Mat& l, const cv::Mat& r, cv::Mat& d) {
            matcher->compute(l, r, *result);
            d = result->disparity;
          },
          [result] { return result->confidence; }};
}

void toGrey(const cv::Mat& image, cv::Mat& grey) {
  if (image.channels() == 1) grey = image;
  else cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
}

// OpenCV DIS optical flow from left to right; disparity = -flow_x, negative
// disparities (physically impossible) count as no estimate.
Method makeDis(const std::string& name, int preset) {
  auto dis = cv::DISOpticalFlow::create(preset);
  auto grey = std::make_shared<std::pair<cv::Mat, cv::Mat>>();
  auto flow = std::make_shared<cv::Mat>();
  return {name, [dis, grey, flow](const cv::Mat& l, const cv::Mat& r, cv::Mat& d) {
            toGrey(l, grey->first);
            toGrey(r, grey->second);
            dis->calc(grey->first, grey->second, *flow);
            d.create(l.size(), CV_32FC1);
            for (int y = 0; y < d.rows; ++y) {
              const cv::Vec2f* f = flow->ptr<cv::Vec2f>(y);
              float* o = d.ptr<float>(y);
              for (int x = 0; x < d.cols; ++x) o[x] = -f[x][0] >= 0.f ? -f[x][0] : -1.f;
            }
          }};
}

// SGBM with the usual textbook settings for 640x480 endoscopy (128 levels).
Method makeSgbm() {
  const int block = 5;
  auto sgbm = cv::StereoSGBM::create(0, 128, block, 8 * block * block, 32 * block * block, 1, 63,
                                     10, 100, 2, cv::StereoSGBM::MODE_SGBM);
  auto raw = std::make_shared<cv::Mat>();
  return {"sgbm", [sgbm, raw](const cv::Mat& l, const cv::Mat& r, cv::Mat& d) {
            sgbm->compute(l, r, *raw);
            raw->convertTo(d, CV_32FC1, 1.0 / 16.0);
            cv::threshold(d, d, -0.5, 0, cv::THRESH_TOZERO);  // keeps d >= 0 ...
            // ... and marks SGBM's invalid (negative) pixels as no estimate.
            for (int y = 0; y < d.rows; ++y) {
              const int16_t* s = raw->ptr<int16_t>(y);
              float* o = d.ptr<float>(y);
              for (int x = 0; x < d.cols; ++x) if (s[x] < 0) o[x] = -1.f;
            }
          }};
}

// Disparities computed elsewhere, one 16-bit PNG per frame name.
Method makePredictions(const std::string& dir, const std::string* const* current_name) {
  return {"predictions", [dir, current_name](const cv::Mat&, const cv::Mat&, cv::Mat& d) {
            d = readDisparityPng((std::filesystem::path(dir) / **current_name).string());
          }};
}

struct Row {
  std::string sequence, method;
  size_t frames = 0;
  double median_ms = 0;
  DisparityScore score;
};

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, sep);) if (!item.empty()) out.push_back(item);
  return out;
}

int run(int argc, char** argv) {
  std::vector<std::string> sequences;
  std::string preset = "balanced", params_file, json_path, dump_dir, predictions_dir;
  bool methods_given = false;
  std::vector<std::string> overrides;
  std::vector<std::string> method_names = {"bdis", "dis_fast", "dis_medium", "sgbm"};
  size_t max_frames = 0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() { return optionValue(i, argc, argv); };
    if (a == "-h" || a == "--help") {
      std::cout << kUsage;
      return 0;
    } else if (a == "--preset") {
      preset = value();
    } else if (a == "--params") {
      params_file = value();
    } else if (a == "--set") {
      overrides.push_back(value());
    } else if (a == "--methods") {
      method_names = split(value(), ',');
      methods_given = true;
    } else if (a == "--frames") {
      max_frames = static_cast<size_t>(std::stoul(value()));
    } else if (a == "--dump-dir") {
      dump_dir = value();
    } else if (a == "--predictions") {
      predictions_dir = value();
    } else if (a == "--json") {
      json_path = value();
    } else if (!a.empty() && a[0] == '-') {
      throw UsageError("unknown option " + a);
    } else {
      sequences.push_back(a);
    }
  }
  if (sequences.empty()) throw UsageError(std::string("no sequence given\n") + kUsage);
  if (!predictions_dir.empty()) {
    if (sequences.size() != 1) throw UsageError("--predictions scores one sequence");
    if (!std::filesystem::is_directory(predictions_dir))
      throw std::runtime_error("--predictions " + predictions_dir + " is not a directory");
    if (!methods_given) method_names.clear();
  }
  MatcherParams params = resolveParams(preset, params_file);
  for (const std::string& o : overrides) params = applyOverride(params, o);
  params.validate();

  cv::setNumThreads(1);  // every method single-threaded, as the matcher is
  std::vector<Method> methods;
  const std::string* frame_name = nullptr;  // the frame being scored, for makePredictions
  if (!predictions_dir.empty()) methods.push_back(makePredictions(predictions_dir, &frame_name));
  const auto listed = std::remove(method_names.begin(), method_names.end(), "predictions");
  if (listed != method_names.end() && predictions_dir.empty())
    throw UsageError("method predictions needs --predictions DIR");
  method_names.erase(listed, method_names.end());  // added above when the directory is given
  for (const std::string& m : method_names) {
    if (m == "bdis") methods.push_back(makeBdis(params));
    else if (m == "dis_fast") methods.push_back(makeDis(m, cv::DISOpticalFlow::PRESET_FAST));
    else if (m == "dis_medium") methods.push_back(makeDis(m, cv::DISOpticalFlow::PRESET_MEDIUM));
    else if (m == "sgbm") methods.push_back(makeSgbm());
    else throw UsageError("unknown method " + m + " (bdis, dis_fast, dis_medium, sgbm)");
  }

  std::vector<Row> rows;
  for (const std::string& root : sequences) {
    const StereoSequence seq = StereoSequence::open(root);
    if (!seq.has_ground_truth) throw std::runtime_error("sequence " + root + " has no gt_disparity/");
    const size_t n = max_frames ? std::min(max_frames, seq.names.size()) : seq.names.size();
    std::vector<Row> seq_rows(methods.size());
    std::vector<std::vector<double>> times(methods.size());
    ProgressBar bar(n, root);
    cv::Mat disparity;
    size_t scored = 0;
    for (size_t f = 0; f < n; ++f) {
      frame_name = &seq.names[f];
      if (!predictions_dir.empty() &&
          !std::filesystem::exists(std::filesystem::path(predictions_dir) / seq.names[f])) {
        bar.update(f + 1);
        continue;
      }
      ++scored;
      const cv::Mat left = seq.left(f), right = seq.right(f), gt = seq.groundTruth(f);
      for (size_t m = 0; m < methods.size(); ++m) {
        if (scored == 1) methods[m].run(left, right, disparity);  // untimed warm-up
        const double t0 = nowMs();
        methods[m].run(left, right, disparity);
        times[m].push_back(nowMs() - t0);
        seq_rows[m].score.add(scoreDisparity(disparity, gt, left));
        if (!dump_dir.empty()) {
          const std::filesystem::path dir =
              std::filesystem::path(dump_dir) / std::filesystem::path(root).filename() / methods[m].name;
          std::filesystem::create_directories(dir);
          writeDisparityPng((dir / seq.names[f]).string(), disparity);
          const cv::Mat conf = methods[m].confidence();
          if (!conf.empty()) {
            cv::Mat conf16;
            conf.convertTo(conf16, CV_16UC1, 65535.0);
            writeImage((dir / ("conf_" + seq.names[f])).string(), conf16);
          }
        }
      }
      bar.update(f + 1);
    }
    bar.finish();
    if (scored == 0) throw std::runtime_error("no frame of " + root + " has a file in " + predictions_dir);
    if (scored < n) std::printf("%s: %zu of %zu frames have predictions; scored those\n", root.c_str(), scored, n);
    for (size_t m = 0; m < methods.size(); ++m) {
      seq_rows[m].sequence = seq.root.substr(seq.root.find_last_of('/') + 1);
      if (seq_rows[m].sequence.empty()) seq_rows[m].sequence = seq.root;
      seq_rows[m].method = methods[m].name;
      seq_rows[m].frames = scored;
      seq_rows[m].median_ms = median(times[m]);
      rows.push_back(std::move(seq_rows[m]));
    }
  }

  std::printf("%-28s %-11s %7s %9s %8s %8s %8s %8s %13s\n", "sequence", "method", "frames",
              "ms/frame", "density", "median", "mean", "bad2", "miss_or_bad2");
  for (const Row& r : rows) {
    char ms[32] = "        -";  // predictions were computed elsewhere: no time here
    if (r.method != "predictions") std::snprintf(ms, sizeof ms, "%9.2f", r.median_ms);
    std::printf("%-28s %-11s %7zu %s %8.3f %8.3f %8.3f %7.1f%% %12.1f%%\n", r.sequence.c_str(),
                r.method.c_str(), r.frames, ms, r.score.density(), r.score.medianError(),
                r.score.meanError(), 100 * r.score.bad2Rate(), 100 * r.score.missOrBad2Rate());
  }
  if (!json_path.empty()) {
    std::ofstream js(json_path);
    if (!js) throw std::runtime_error("cannot write " + json_path);
    js << std::setprecision(6) << "{\n  \"params\": {";
    bool first = true;
    for (const ParamField& f : paramFields()) {
      js << (first ? "" : ", ") << "\"" << f.name << "\": " << f.get(params);
      first = false;
    }
    js << "},\n  \"results\": [\n";
    for (size_t i = 0; i < rows.size(); ++i) {
      const Row& r = rows[i];
      js << "    {\"sequence\": \"" << r.sequence << "\", \"method\": \"" << r.method
         << "\", \"frames\": " << r.frames << ", \"median_ms\": " << r.median_ms
         << ", \"density\": " << r.score.density() << ", \"median_error\": " << r.score.medianError()
         << ", \"mean_error\": " << r.score.meanError() << ", \"bad2\": " << r.score.bad2Rate()
         << ", \"miss_or_bad2\": " << r.score.missOrBad2Rate() << "}"
         << (i + 1 < rows.size() ? ",\n" : "\n");
    }
    js << "  ]\n}\n";
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return runGuarded("bdis_eval", [&] { return run(argc, argv); }); }
