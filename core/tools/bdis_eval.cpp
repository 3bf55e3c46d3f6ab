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
#include <utility>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "bdis_stereo/error_analysis.hpp"
#include "bdis_stereo/evaluation.hpp"
#include "bdis_stereo/matcher.hpp"
#include "bdis_stereo/pair_check.hpp"
#include "tool_common.hpp"

namespace {

using namespace bdis;
using namespace bdis::tools;

constexpr const char* kUsage = R"(usage: bdis_eval SEQUENCE_DIR [SEQUENCE_DIR ...] [options]

Scores each sequence (left/, right/, gt_disparity/) for this matcher and, in the
same run, OpenCV DIS fast, DIS medium and SGBM. Single-threaded; per-method time
is the median over frames, each method warmed up once on the first frame.
Besides the summary table it prints, per sequence and method:
  - the scorable pixels split by what the ground truth says (out of the right
    view, occluded in it, dark, near a depth edge, the rest): share, density
    and bad2 of each;
  - for sequences with labels/ (bdis_synth writes them: the surface each left
    pixel sees), the tissue within 12 px of the instrument and the
    instrument's 12 px rim: share, density, bad2, the estimates off by more
    than 2 px with confidence >= 0.5 as a share of the band, and the band's
    mean confidence against its share within 2 px;
  - for methods with a confidence (bdis; predictions with conf_ files): its
    sparsification area against the oracle's, bad2 of the 25 % and 50 % most
    confident estimates, bad2 per confidence decile, and the density and bad2
    left by confidence thresholds; for a calibrated confidence (the default;
    --set calibrated_confidence=false: the cues' raw product, thresholds in
    decades), per confidence bin the share of estimates within 2 px against
    their mean confidence, and the expected calibration error;
  - with compute_variance: the share of errors within 1 and 2 sigma, and
    the sparsification ratio of sigma as a ranking of the errors;
  - for sequences without gt_disparity/: density over the valid pixels and
    the outliers in the strips along the rectification border;
  - per sequence, the contrast of a block codec's 8 x 8 grid in its views
    (checkBlockArtefacts: about 1 uncompressed, >= 1.2 block-coded).

options:
  --preset NAME        fast | balanced (default) | accurate
  --params FILE.yaml   parameter file on top of the preset
  --set NAME=VALUE     override one matcher parameter (repeatable)
  --methods LIST       comma-separated subset of bdis,dis_fast,dis_medium,sgbm (default: all)
  --frames N           use at most N (>= 1) frames per sequence
  --reference-width W  count errors in pixels of a W px wide frame (error x W / width), so
                       that frame sizes compare; the summary table only
  --json FILE          also write the results as JSON
  --dump-dir DIR       write every disparity as DIR/<sequence>/<method>/<frame>.png (16-bit, d*256)
                       and a confidence beside it as conf_<stem>.tiff (32-bit float, exact)
  --predictions DIR    score disparities computed elsewhere (DIR/<frame>.png, 16-bit, d*256,
                       0 = none; e.g. recorded from the nodelet) as method 'predictions'; one
                       sequence only; frames without a file are skipped for every method;
                       other methods run only when --methods names them; a confidence
                       DIR/conf_<stem>.tiff (32-bit float; what --dump-dir writes) or
                       DIR/conf_<frame>.png (16-bit, c*65535) is scored with it (for every
                       frame or none)
  --max-image-pixels N refuse images (left, right, ground truth, predictions) of
                       more than N pixels (default 16777216 = 4096x4096, as the
                       nodelet's max_image_pixels); read from the file's header
                       before decoding (PNG, JPEG, BMP, PNM), after decoding
                       for other formats
)";

/// A disparity method under test: fills CV_32FC1 disparity, negative = none,
/// and its confidence in [0, 1] and variance (px^2) where the method has them
/// (else they are empty).
struct Method {
  std::string name;
  std::function<void(const cv::Mat& left, const cv::Mat& right, cv::Mat& disparity)> run;
  std::function<cv::Mat()> confidence = [] { return cv::Mat(); };
  std::function<cv::Mat()> variance = [] { return cv::Mat(); };
};

Method makeBdis(const MatcherParams& params) {
  auto matcher = std::make_shared<Matcher>(params);
  auto result = std::make_shared<MatchResult>();
  return {"bdis",
          [matcher, result](const cv::Mat& l, const cv::Mat& r, cv::Mat& d) {
            matcher->compute(l, r, *result);
            d = result->disparity;
          },
          [result] { return result->confidence; }, [result] { return result->variance; }};
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

/// The exact confidence file of frame `name` beside its disparity: what
/// --dump-dir writes and --predictions reads first.
std::string confidenceTiffName(const std::string& name) {
  return "conf_" + std::filesystem::path(name).stem().string() + ".tiff";
}

// Disparities computed elsewhere, one 16-bit PNG per frame name, and their
// confidence where a conf_<stem>.tiff (32-bit float) or conf_<frame>.png
// (16-bit, c * 65535) is there too.
Method makePredictions(const std::string& dir, const std::string* const* current_name,
                       std::size_t max_image_pixels) {
  auto confidence = std::make_shared<cv::Mat>();
  // Every scored frame has a confidence file or none does: frames without
  // one would enter the ranking as the least confident.
  auto first_had_confidence = std::make_shared<int>(-1);
  return {"predictions",
          [dir, current_name, confidence, first_had_confidence, max_image_pixels](const cv::Mat&, const cv::Mat&,
                                                                                 cv::Mat& d) {
            const std::filesystem::path root(dir);
            const std::string prediction = (root / **current_name).string();
            checkImagePixels(prediction, max_image_pixels);
            d = readDisparityPng(prediction);
            confidence->release();
            std::filesystem::path conf = root / confidenceTiffName(**current_name);
            if (!std::filesystem::exists(conf)) conf = root / ("conf_" + **current_name);
            const int has = std::filesystem::exists(conf) ? 1 : 0;
            if (*first_had_confidence < 0) *first_had_confidence = has;
            if (has != *first_had_confidence) {
              throw std::runtime_error("--predictions: " + **current_name + (has ? " has" : " has no") +
                                       " confidence file, the first frame " + (has ? "had none" : "had one") +
                                       ": give every frame a conf_ file or none");
            }
            if (!has) return;
            checkImagePixels(conf.string(), max_image_pixels);
            *confidence = readConfidence(conf.string());
            if (confidence->size() != d.size()) {
              throw std::runtime_error(conf.string() + " is not a confidence of the disparity's size");
            }
          },
          [confidence] { return *confidence; }};
}

struct Row {
  std::string sequence, method;
  size_t frames = 0;
  double median_ms = 0;
  bool has_ground_truth = true;
  DisparityScore score;
  RegionScore regions;
  InstrumentBandScore instrument;  ///< sequences with labels/ only
  EstimateSamples samples;  ///< per estimate: confidence, error, sigma
  bool has_confidence = false, has_variance = false;
  double grid_contrast_sum = 0;  ///< the views' block codec grid (checkBlockArtefacts), summed over frames
  double gridContrast() const { return frames ? grid_contrast_sum / (2.0 * static_cast<double>(frames)) : 1.0; }
  // Without ground truth:
  double valid_pixels_density_sum = 0;
  BorderStripScore border;
};

// The calibrated confidence is a probability of being within 2 px, and most
// estimates lie near 1: the steps are finer at the top.
const std::vector<float> kProbabilityThresholds = {0.f, 0.5f, 0.7f, 0.8f, 0.9f, 0.95f, 0.98f, 0.99f};
// Decades for the raw confidence (calibrated_confidence false): a product of
// agreement factors, it spans many of them (on the colon sequences half of
// the estimates lie below about 1e-3, a tenth below about 1e-7).
const std::vector<float> kDecadeThresholds = {0.f, 1e-8f, 1e-7f, 1e-6f, 1e-5f, 1e-4f, 1e-3f, 1e-2f, 1e-1f};

/// How the confidences of this run read: as probabilities (the matcher's
/// calibrated confidence, and predictions recorded with it) or as the raw
/// product of cues; --set calibrated_confidence=false selects the latter.
struct ConfidenceScale {
  bool probability = true;
  const std::vector<float>& thresholds() const { return probability ? kProbabilityThresholds : kDecadeThresholds; }
};

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, sep);) if (!item.empty()) out.push_back(item);
  return out;
}

struct Options {
  std::vector<std::string> sequences;
  std::string preset = "balanced", params_file, json_path, dump_dir, predictions_dir;
  bool methods_given = false;
  std::vector<std::string> overrides;
  std::vector<std::string> method_names = {"bdis", "dis_fast", "dis_medium", "sgbm"};
  size_t max_frames = 0;  ///< 0: every frame
  int reference_width = 0;  ///< 0: errors in the frame's own pixels
  std::size_t max_image_pixels = kDefaultMaxImagePixels;
  bool help = false;
};

Options parseOptions(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() { return optionValue(i, argc, argv); };
    if (a == "-h" || a == "--help") {
      o.help = true;
      return o;
    } else if (a == "--preset") {
      o.preset = value();
    } else if (a == "--params") {
      o.params_file = value();
    } else if (a == "--set") {
      o.overrides.push_back(value());
    } else if (a == "--methods") {
      o.method_names = split(value(), ',');
      o.methods_given = true;
      if (o.method_names.empty()) throw UsageError("--methods needs at least one method");
    } else if (a == "--frames") {
      const long long n = parseInteger("--frames", value());
      if (n < 1) throw UsageError("--frames needs a whole number >= 1, got " + std::to_string(n));
      o.max_frames = static_cast<size_t>(n);
    } else if (a == "--reference-width") {
      const long long w = parseInteger("--reference-width", value());
      if (w < 1) throw UsageError("--reference-width needs a width >= 1");
      o.reference_width = static_cast<int>(w);
    } else if (a == "--dump-dir") {
      o.dump_dir = value();
    } else if (a == "--predictions") {
      o.predictions_dir = value();
    } else if (a == "--json") {
      o.json_path = value();
    } else if (a == "--max-image-pixels") {
      o.max_image_pixels = parseMaxImagePixels(value());
    } else if (!a.empty() && a[0] == '-') {
      throw UsageError("unknown option " + a);
    } else {
      o.sequences.push_back(a);
    }
  }
  if (o.sequences.empty()) throw UsageError(std::string("no sequence given\n") + kUsage);
  if (!o.predictions_dir.empty()) {
    if (o.sequences.size() != 1) throw UsageError("--predictions scores one sequence");
    if (!std::filesystem::is_directory(o.predictions_dir))
      throw std::runtime_error("--predictions " + o.predictions_dir + " is not a directory");
    if (!o.methods_given) o.method_names.clear();
  }
  // Fail before the evaluation, not after it.
  if (!o.json_path.empty()) checkWritableFile(o.json_path);
  if (!o.dump_dir.empty()) ensureWritableDir(o.dump_dir);
  return o;
}

void dumpMaps(const std::filesystem::path& dir, const std::string& name, const cv::Mat& disparity,
              const cv::Mat& confidence) {
  std::filesystem::create_directories(dir);
  writeDisparityPng((dir / name).string(), disparity);
  if (confidence.empty()) return;
  // Exact: a 16-bit PNG ties the least confident estimates, and scoring those
  // files would rank them worse than this run does.
  writeConfidenceTiff((dir / confidenceTiffName(name)).string(), disparity, confidence);
}

/// Every method on the frames of one sequence; one row per method.
std::vector<Row> scoreSequence(const std::string& root, std::vector<Method>& methods, const Options& o,
                               const std::string*& frame_name) {
  const StereoSequence seq = StereoSequence::open(root);
  const size_t n = o.max_frames ? std::min(o.max_frames, seq.names.size()) : seq.names.size();
  std::vector<Row> rows(methods.size());
  std::vector<std::vector<double>> times(methods.size());
  ProgressBar bar(n, root);
  cv::Mat disparity;
  size_t scored = 0;
  for (size_t f = 0; f < n; ++f) {
    frame_name = &seq.names[f];
    if (!o.predictions_dir.empty() &&
        !std::filesystem::exists(std::filesystem::path(o.predictions_dir) / seq.names[f])) {
      bar.update(f + 1);
      continue;
    }
    ++scored;
    // Every file's header before any is decoded: an oversized one costs nothing.
    const std::filesystem::path seq_root(seq.root);
    std::vector<std::string> files = {(seq_root / "left" / seq.names[f]).string(),
                                      (seq_root / "right" / seq.names[f]).string()};
    if (seq.has_ground_truth) files.push_back((seq_root / "gt_disparity" / seq.names[f]).string());
    const bool with_surfaces = seq.has_ground_truth && seq.has_surfaces;
    if (with_surfaces) files.push_back((seq_root / "labels" / seq.names[f]).string());
    for (const std::string& file : files) checkImagePixels(file, o.max_image_pixels);
    const cv::Mat left = seq.left(f);
    checkImagePixels(files[0], left, o.max_image_pixels);
    const cv::Mat right = seq.right(f);
    checkImagePixels(files[1], right, o.max_image_pixels);
    const cv::Mat gt = seq.has_ground_truth ? seq.groundTruth(f) : cv::Mat();
    const cv::Mat labels = seq.has_ground_truth ? classifyPixels(gt, left) : cv::Mat();
    const cv::Mat surfaces = with_surfaces ? seq.surfaces(f) : cv::Mat();
    if (with_surfaces && surfaces.size() != left.size()) {
      throw std::runtime_error(files.back() + " is not a label image of the left image's size");
    }
    const double grid_contrast =
        checkBlockArtefacts(left).grid_contrast + checkBlockArtefacts(right).grid_contrast;
    for (size_t m = 0; m < methods.size(); ++m) {
      if (scored == 1) methods[m].run(left, right, disparity);  // untimed warm-up
      const double t0 = nowMs();
      methods[m].run(left, right, disparity);
      times[m].push_back(nowMs() - t0);
      Row& row = rows[m];
      row.grid_contrast_sum += grid_contrast;
      const cv::Mat confidence = methods[m].confidence(), variance = methods[m].variance();
      row.has_confidence = !confidence.empty();
      row.has_variance = !variance.empty();
      if (seq.has_ground_truth) {
        const double scale = o.reference_width > 0 ? static_cast<double>(o.reference_width) / left.cols : 1.0;
        row.score.add(scoreDisparity(disparity, gt, left, scale));
        row.regions.add(scoreRegions(disparity, gt, labels));
        if (with_surfaces) row.instrument.add(scoreInstrumentBands(disparity, gt, labels, surfaces, confidence));
        row.samples.add(disparity, gt, labels, confidence, variance);
      } else {
        row.valid_pixels_density_sum += validPixelDensity(disparity, left);
        row.border.add(scoreBorderStrips(disparity, left));
      }
      if (!o.dump_dir.empty()) {
        dumpMaps(std::filesystem::path(o.dump_dir) / std::filesystem::path(root).filename() / methods[m].name,
                 seq.names[f], disparity, confidence);
      }
    }
    bar.update(f + 1);
  }
  bar.finish();
  if (scored == 0) throw std::runtime_error("no frame of " + root + " has a file in " + o.predictions_dir);
  if (scored < n) std::printf("%s: %zu of %zu frames have predictions; scored those\n", root.c_str(), scored, n);
  std::string name = seq.root.substr(seq.root.find_last_of('/') + 1);
  if (name.empty()) name = seq.root;
  for (size_t m = 0; m < methods.size(); ++m) {
    rows[m].sequence = name;
    rows[m].method = methods[m].name;
    rows[m].frames = scored;
    rows[m].median_ms = median(times[m]);
    rows[m].has_ground_truth = seq.has_ground_truth;
  }
  return rows;
}

void printSummary(const std::vector<Row>& rows) {
  std::printf("%-28s %-11s %7s %9s %8s %8s %8s %8s %13s\n", "sequence", "method", "frames", "ms/frame", "density",
              "median", "mean", "bad2", "miss_or_bad2");
  for (const Row& r : rows) {
    if (!r.has_ground_truth) continue;
    char ms[32] = "        -";  // predictions were computed elsewhere: no time here
    if (r.method != "predictions") std::snprintf(ms, sizeof ms, "%9.2f", r.median_ms);
    std::printf("%-28s %-11s %7zu %s %8.3f %8.3f %8.3f %7.1f%% %12.1f%%\n", r.sequence.c_str(), r.method.c_str(),
                r.frames, ms, r.score.density(), r.score.medianError(), r.score.meanError(), 100 * r.score.bad2Rate(),
                100 * r.score.missOrBad2Rate());
  }
}

void printRegions(const std::vector<Row>& rows) {
  std::printf("\nwhere the scorable pixels lie (by ground truth): share of them, density, bad2\n");
  std::printf("%-28s %-11s", "sequence", "method");
  for (int k = 0; k < kPixelRegions; ++k) std::printf(" %26s", regionName(static_cast<PixelRegion>(k)));
  std::printf("\n");
  for (const Row& r : rows) {
    if (!r.has_ground_truth) continue;
    std::printf("%-28s %-11s", r.sequence.c_str(), r.method.c_str());
    for (int k = 0; k < kPixelRegions; ++k) {
      const auto region = static_cast<PixelRegion>(k);
      const RegionScore::Counts& c = r.regions[region];
      std::printf("  %5.1f%% %6.3f %6.1f%%    ", 100 * r.regions.share(region), c.density(), 100 * c.bad2Rate());
    }
    std::printf("\n");
  }
}

void printInstrumentBands(const std::vector<Row>& rows) {
  bool any = false;
  for (const Row& r : rows) any = any || r.instrument.any();
  if (!any) return;
  std::printf("\nbeside the instrument (sequences with labels/): the tissue within 12 px of it and its own 12 px\n"
              "rim; share of the scorable pixels, density, bad2, wrong with confidence >= 0.5 (share of the\n"
              "band), mean confidence / share within 2 px of the band's estimates\n");
  std::printf("%-28s %-11s %44s %44s\n", "sequence", "method", "tissue within 12 px", "instrument rim");
  for (const Row& r : rows) {
    if (!r.instrument.any()) continue;
    std::printf("%-28s %-11s", r.sequence.c_str(), r.method.c_str());
    for (const InstrumentBandScore::Band* b : {&r.instrument.tissue, &r.instrument.rim}) {
      const double share = r.regions.scorable() > 0 ? b->scorable / r.regions.scorable() : 0.0;
      std::printf("  %5.1f%% %6.3f %6.1f%%", 100 * share, b->density(), 100 * b->bad2Rate());
      if (r.has_confidence) {
        std::printf(" %6.2f%% %4.2f/%4.2f", 100 * b->confidentBad2Share(), b->meanConfidence(), 1 - b->bad2Rate());
      } else {
        std::printf(" %7s %9s", "-", "-");
      }
    }
    std::printf("\n");
  }
}

void printConfidence(const std::vector<Row>& rows, const ConfidenceScale& scale) {
  bool any = false;
  for (const Row& r : rows) any = any || (r.has_ground_truth && r.has_confidence);
  if (!any) return;
  std::printf("\nconfidence as a ranking of the errors: sparsification area (bad2 of the most confident\n"
              "fraction, f = 0.05..1) against the oracle's; bad2 of the 25 %% / 50 %% most confident;\n"
              "bad2 per confidence decile, least confident first\n");
  std::printf("%-28s %-11s %7s %7s %6s %7s %7s  %s\n", "sequence", "method", "area", "oracle", "ratio", "top25",
              "top50", "deciles (bad2 %)");
  for (const Row& r : rows) {
    if (!r.has_ground_truth || !r.has_confidence) continue;
    const Sparsification s = sparsify(r.samples);
    std::printf("%-28s %-11s %7.4f %7.4f %6.2f %6.1f%% %6.1f%% ", r.sequence.c_str(), r.method.c_str(), s.area,
                s.oracle_area, s.ratio(), 100 * s.bad2_top25, 100 * s.bad2_top50);
    for (double d : s.decile_bad2) std::printf(" %4.1f", 100 * d);
    std::printf("%s\n", s.monotone() ? "  (falling)" : "  (not monotone)");
  }
  std::printf("\nwhat a confidence threshold leaves: density / bad2 of the estimates with confidence >= t\n");
  std::printf("%-28s %-11s", "sequence", "method");
  for (float t : scale.thresholds()) std::printf("     t=%-6g ", t);
  std::printf("\n");
  for (const Row& r : rows) {
    if (!r.has_ground_truth || !r.has_confidence) continue;
    std::printf("%-28s %-11s", r.sequence.c_str(), r.method.c_str());
    for (const ThresholdRow& t : confidenceThresholds(r.samples, scale.thresholds())) {
      std::printf("  %5.3f/%5.1f%%", t.density, 100 * t.bad2);
    }
    std::printf("\n");
  }
  if (!scale.probability) return;
  std::printf("\nthe confidence as the probability of being within 2 px: expected calibration error (0 = says\n"
              "what it means); bad2 predicted (1 - mean confidence) / found; per confidence bin, share of\n"
              "the estimates, mean confidence / share within 2 px\n");
  std::printf("%-28s %-11s %6s %13s ", "sequence", "method", "error", "bad2 pred/fnd");
  for (size_t b = 0; b + 1 < reliabilityEdges().size(); ++b) {
    char bin[32];
    std::snprintf(bin, sizeof bin, "%g-%g", reliabilityEdges()[b], reliabilityEdges()[b + 1]);
    std::printf(" %-17s", bin);
  }
  std::printf("\n");
  for (const Row& r : rows) {
    if (!r.has_ground_truth || !r.has_confidence) continue;
    const Reliability rel = reliability(r.samples, reliabilityEdges());
    std::printf("%-28s %-11s %6.3f %5.1f%%/%5.1f%% ", r.sequence.c_str(), r.method.c_str(), rel.expected_error,
                100 * (1 - rel.mean_confidence), 100 * (1 - rel.within2));
    for (const ReliabilityBin& b : rel.bins) {
      std::printf(" %4.1f%% %.2f/%.2f ", 100 * b.share, b.mean_confidence, b.within2);
    }
    std::printf("\n");
  }
}

void printVariance(const std::vector<Row>& rows) {
  bool any = false;
  for (const Row& r : rows) any = any || (r.has_ground_truth && r.has_variance);
  if (!any) return;
  std::printf("\nvariance as a standard deviation of the error (a Gaussian: 68 %% / 95 %% / 0.674), and as a\n"
              "ranking of the errors (sparsification ratio, the smallest sigma as the most confident)\n");
  std::printf("%-28s %-11s %9s %9s %14s %8s\n", "sequence", "method", "within 1s", "within 2s", "median |e|/s",
              "ranking");
  for (const Row& r : rows) {
    if (!r.has_ground_truth || !r.has_variance) continue;
    const VarianceCalibration c = calibrateVariance(r.samples);
    std::printf("%-28s %-11s %8.1f%% %8.1f%% %14.3f %8.2f\n", r.sequence.c_str(), r.method.c_str(),
                100 * c.within1, 100 * c.within2, c.median_ratio, c.ranking_ratio);
  }
}

void printWithoutGroundTruth(const std::vector<Row>& rows) {
  bool any = false;
  for (const Row& r : rows) any = any || !r.has_ground_truth;
  if (!any) return;
  std::printf("\nsequences without ground truth: density over the valid pixels; estimates within 12 px of\n"
              "either end of a row's valid span more than 3 px from the median 12-40 px further in\n");
  std::printf("%-28s %-11s %7s %9s %8s %16s %9s\n", "sequence", "method", "frames", "ms/frame", "density",
              "border estimates", "outliers");
  for (const Row& r : rows) {
    if (r.has_ground_truth) continue;
    std::printf("%-28s %-11s %7zu %9.2f %8.3f %16.0f %8.1f%%\n", r.sequence.c_str(), r.method.c_str(), r.frames,
                r.median_ms, r.frames ? r.valid_pixels_density_sum / static_cast<double>(r.frames) : 0.0,
                r.border.estimates, 100 * r.border.rate());
  }
}

/// Once per sequence: whether its views went through a block codec.
void printInputs(const std::vector<Row>& rows) {
  std::printf("\ninputs: the views' 8 x 8 block grid, steps across it over the others' (about 1: none;\n"
              ">= 1.2: a block codec such as JPEG has removed texture the matcher needs)\n");
  std::printf("%-28s %12s\n", "sequence", "grid");
  std::string last;
  for (const Row& r : rows) {
    if (r.sequence == last) continue;
    last = r.sequence;
    std::printf("%-28s %12.2f%s\n", r.sequence.c_str(), r.gridContrast(),
                BlockArtefactCheck{r.gridContrast()}.looksBlockCompressed() ? "  block-coded" : "");
  }
}

void writeJson(const std::string& path, const MatcherParams& params, const ConfidenceScale& scale,
               const std::vector<Row>& rows) {
  std::ofstream js(path);
  if (!js) throw std::runtime_error("cannot write " + path);
  js << std::setprecision(6) << "{\n  \"params\": {";
  bool first = true;
  for (const ParamField& f : paramFields()) {
    js << (first ? "" : ", ") << "\"" << f.name << "\": " << f.get(params);
    first = false;
  }
  js << "},\n  \"results\": [\n";
  for (size_t i = 0; i < rows.size(); ++i) {
    const Row& r = rows[i];
    js << "    {\"sequence\": \"" << r.sequence << "\", \"method\": \"" << r.method << "\", \"frames\": " << r.frames
       << ", \"median_ms\": " << r.median_ms << ", \"ground_truth\": " << (r.has_ground_truth ? "true" : "false")
       << ", \"block_grid_contrast\": " << r.gridContrast();
    if (r.has_ground_truth) {
      js << ", \"density\": " << r.score.density() << ", \"median_error\": " << r.score.medianError()
         << ", \"mean_error\": " << r.score.meanError() << ", \"bad2\": " << r.score.bad2Rate()
         << ", \"miss_or_bad2\": " << r.score.missOrBad2Rate() << ",\n     \"regions\": {";
      for (int k = 0; k < kPixelRegions; ++k) {
        const auto region = static_cast<PixelRegion>(k);
        js << (k ? ", " : "") << "\"" << regionName(region) << "\": {\"share\": " << r.regions.share(region)
           << ", \"density\": " << r.regions[region].density() << ", \"bad2\": " << r.regions[region].bad2Rate() << "}";
      }
      js << "}";
      if (r.instrument.any()) {
        js << ",\n     \"instrument_bands\": {";
        bool first_band = true;
        for (const auto& [band_name, b] : {std::pair<const char*, const InstrumentBandScore::Band*>{
                                               "tissue_within_12px", &r.instrument.tissue},
                                           {"instrument_rim_12px", &r.instrument.rim}}) {
          js << (first_band ? "" : ", ") << "\"" << band_name << "\": {\"share\": "
             << (r.regions.scorable() > 0 ? b->scorable / r.regions.scorable() : 0.0)
             << ", \"density\": " << b->density() << ", \"bad2\": " << b->bad2Rate();
          if (r.has_confidence) {
            js << ", \"confident_bad2_share\": " << b->confidentBad2Share()
               << ", \"mean_confidence\": " << b->meanConfidence();
          }
          js << "}";
          first_band = false;
        }
        js << "}";
      }
      if (r.has_confidence) {
        const Sparsification s = sparsify(r.samples);
        js << ",\n     \"confidence\": {\"sparsification_area\": " << s.area << ", \"oracle_area\": " << s.oracle_area
           << ", \"ratio\": " << s.ratio() << ", \"bad2_top25\": " << s.bad2_top25 << ", \"bad2_top50\": "
           << s.bad2_top50 << ", \"monotone\": " << (s.monotone() ? "true" : "false") << ", \"decile_bad2\": [";
        for (size_t d = 0; d < s.decile_bad2.size(); ++d) js << (d ? ", " : "") << s.decile_bad2[d];
        js << "], \"thresholds\": [";
        const std::vector<ThresholdRow> t = confidenceThresholds(r.samples, scale.thresholds());
        for (size_t k = 0; k < t.size(); ++k) {
          js << (k ? ", " : "") << "{\"threshold\": " << t[k].threshold << ", \"density\": " << t[k].density
             << ", \"bad2\": " << t[k].bad2 << "}";
        }
        js << "]";
        if (scale.probability) {
          const Reliability rel = reliability(r.samples, reliabilityEdges());
          js << ", \"calibration_error\": " << rel.expected_error << ", \"predicted_bad2\": " << 1 - rel.mean_confidence
             << ", \"reliability\": [";
          for (size_t k = 0; k < rel.bins.size(); ++k) {
            const ReliabilityBin& b = rel.bins[k];
            js << (k ? ", " : "") << "{\"lower\": " << b.lower << ", \"upper\": " << b.upper << ", \"share\": "
               << b.share << ", \"mean_confidence\": " << b.mean_confidence << ", \"within_2px\": " << b.within2
               << "}";
          }
          js << "]";
        }
        js << "}";
      }
      if (r.has_variance) {
        const VarianceCalibration c = calibrateVariance(r.samples);
        js << ",\n     \"variance\": {\"within_1_sigma\": " << c.within1 << ", \"within_2_sigma\": " << c.within2
           << ", \"median_error_over_sigma\": " << c.median_ratio << ", \"ranking_ratio\": " << c.ranking_ratio
           << "}";
      }
    } else {
      js << ", \"valid_pixel_density\": " << (r.frames ? r.valid_pixels_density_sum / static_cast<double>(r.frames) : 0.0)
         << ", \"border_estimates\": " << r.border.estimates << ", \"border_outliers\": " << r.border.rate();
    }
    js << "}" << (i + 1 < rows.size() ? ",\n" : "\n");
  }
  js << "  ]\n}\n";
}

int run(int argc, char** argv) {
  Options o = parseOptions(argc, argv);
  if (o.help) {
    std::cout << kUsage;
    return 0;
  }
  MatcherParams params = resolveParams(o.preset, o.params_file);
  for (const std::string& assignment : o.overrides) params = applyOverride(params, assignment);
  params.validate();

  cv::setNumThreads(1);  // every method single-threaded, as the matcher is
  std::vector<Method> methods;
  const std::string* frame_name = nullptr;  // the frame being scored, for makePredictions
  if (!o.predictions_dir.empty()) methods.push_back(makePredictions(o.predictions_dir, &frame_name, o.max_image_pixels));
  const auto listed = std::remove(o.method_names.begin(), o.method_names.end(), "predictions");
  if (listed != o.method_names.end() && o.predictions_dir.empty())
    throw UsageError("method predictions needs --predictions DIR");
  o.method_names.erase(listed, o.method_names.end());  // added above when the directory is given
  for (const std::string& m : o.method_names) {
    if (m == "bdis") methods.push_back(makeBdis(params));
    else if (m == "dis_fast") methods.push_back(makeDis(m, cv::DISOpticalFlow::PRESET_FAST));
    else if (m == "dis_medium") methods.push_back(makeDis(m, cv::DISOpticalFlow::PRESET_MEDIUM));
    else if (m == "sgbm") methods.push_back(makeSgbm());
    else throw UsageError("unknown method " + m + " (bdis, dis_fast, dis_medium, sgbm)");
  }

  std::vector<Row> rows;
  for (const std::string& root : o.sequences) {
    for (Row& r : scoreSequence(root, methods, o, frame_name)) rows.push_back(std::move(r));
  }
  printSummary(rows);
  printRegions(rows);
  printInstrumentBands(rows);
  const ConfidenceScale scale{params.calibrated_confidence};
  printConfidence(rows, scale);
  printVariance(rows);
  printWithoutGroundTruth(rows);
  printInputs(rows);
  if (!o.json_path.empty()) writeJson(o.json_path, params, scale, rows);
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return runGuarded("bdis_eval", [&] { return run(argc, argv); }); }
