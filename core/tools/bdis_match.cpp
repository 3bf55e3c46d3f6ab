// bdis_match: runs the matcher on one rectified pair, or on every pair of two
// folders, and writes the disparity (and optionally confidence and variance)
// as 16-bit PNGs.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>

#include "bdis_stereo/evaluation.hpp"
#include "bdis_stereo/matcher.hpp"
#include "tool_common.hpp"

namespace {

namespace fs = std::filesystem;
using namespace bdis;
using namespace bdis::tools;

constexpr const char* kUsage = R"(usage: bdis_match LEFT RIGHT OUT.png [options]
       bdis_match --left-dir L --right-dir R --out-dir O [options]

Computes the disparity of a rectified stereo pair (left image as reference,
d = x_left - x_right) with the BDIS matcher, single-threaded.

Single pair: writes OUT.png and prints "time_ms=<x>" on stdout, the compute
time of this pair measured after one untimed warm-up compute on it.

Directory mode: processes every file name present in both L and R, in sorted
order, and writes O/<name> (a name that does not end in .png gets .png instead
of its extension); O is created if needed. A progress bar goes to stderr, then
one summary line to stdout:
  frames=<ok> failed=<n> median_ms=<x> mean_density=<x> out_dir=O
median_ms is over the compute times of the frames (one untimed warm-up on the
first frame); density is the share of non-black left pixels with an estimate.
A frame that cannot be processed is reported on stderr and skipped; the exit
code is then 1.

Inputs: 8-bit mono, BGR or BGRA (alpha dropped) images of equal size and type,
at least 32 px on each side and at most --max-image-pixels pixels. Pure black
pixels are treated as outside the view.

Outputs (16-bit single-channel PNG, or a float TIFF for the confidence):
  disparity   round(d * 256), 0 = no estimate (estimates never round to 0)
  confidence  round(c * 65535) for the confidence c in [0, 1], 0 = no estimate;
              estimates are stored as at least 1. The calibrated confidence
              (the probability of being within 2 px) has most estimates near 1,
              and with --set calibrated_confidence=false the cues' product
              spans many decades (c < 1/131070 is common): to rank or threshold
              them exactly, write a 32-bit float TIFF (C.tiff,
              --confidence-format tiff), the exact c, 0 = no estimate
  variance    round(var * 256) for the disparity variance var in px^2, 0 = no
              estimate; estimates are stored as at least 1 and saturate at
              65535 (var >= 256 px^2)

options:
  --preset NAME            fast | balanced (default) | accurate
  --params FILE.yaml       parameter file on top of the preset
  --set NAME=VALUE         override one matcher parameter (repeatable)
  --confidence C.png       also write the confidence (single pair); C.tiff
                           writes it as a 32-bit float TIFF
  --variance V.png         also write the variance (single pair); turns on
                           compute_variance
  --left-dir L, --right-dir R, --out-dir O
                           directory mode (all three are needed)
  --confidence-dir DIR     directory mode: also write DIR/<name> confidence
  --confidence-format F    png (default) or tiff: DIR/<stem>.tiff, 32-bit float
  --variance-dir DIR       directory mode: also write DIR/<name> variance;
                           turns on compute_variance
  --max-image-pixels N     refuse images of more than N pixels (default
                           16777216 = 4096x4096, as the nodelet's
                           max_image_pixels); read from the file's header
                           before decoding (PNG, JPEG, BMP, PNM), after
                           decoding for other formats
  -h, --help               this text

Exit code: 0 on success, 1 on an error or a failed frame, 2 on a bad command line.
)";

struct Options {
  std::vector<std::string> positional;
  std::string preset = "balanced", params_file;
  std::vector<std::string> overrides;
  std::string confidence, variance;                         // single pair
  std::string left_dir, right_dir, out_dir, confidence_dir, variance_dir;  // directory mode
  bool confidence_tiff = false, confidence_format_given = false;  // --confidence-format
  std::size_t max_image_pixels = kDefaultMaxImagePixels;
  bool dir_mode() const { return !left_dir.empty() || !right_dir.empty() || !out_dir.empty(); }
};

/// Output paths of one pair; empty = not written.
struct Outputs {
  std::string disparity, confidence, variance;
};

uint16_t toU16(double v) {
  return static_cast<uint16_t>(std::clamp(std::lround(v), 0L, 65535L));
}

cv::Mat encodeVariance(const MatchResult& r) {
  if (r.variance.empty()) throw std::runtime_error("the matcher returned no variance");
  cv::Mat out(r.variance.size(), CV_16UC1);
  for (int y = 0; y < out.rows; ++y) {
    const float* v = r.variance.ptr<float>(y);
    const float* d = r.disparity.ptr<float>(y);
    uint16_t* o = out.ptr<uint16_t>(y);
    for (int x = 0; x < out.cols; ++x) {
      const bool estimate = d[x] >= 0.f && v[x] >= 0.f;  // false for NaN
      o[x] = estimate ? std::max<uint16_t>(1, toU16(static_cast<double>(v[x]) * 256.0)) : 0;
    }
  }
  return out;
}

/// Share of the non-black pixels of `left` that have an estimate.
double density(const cv::Mat& disparity, const cv::Mat& left) {
  const int ch = left.channels();
  size_t valid = 0, estimated = 0;
  for (int y = 0; y < left.rows; ++y) {
    const uchar* l = left.ptr<uchar>(y);
    const float* d = disparity.ptr<float>(y);
    for (int x = 0; x < left.cols; ++x) {
      bool black = true;
      for (int c = 0; c < ch; ++c) black = black && l[x * ch + c] == 0;
      if (black) continue;
      ++valid;
      if (d[x] >= 0.f) ++estimated;
    }
  }
  return valid ? static_cast<double>(estimated) / static_cast<double>(valid) : 0.0;
}

/// Reads, matches and writes one pair; returns the timed compute in ms.
class PairRunner {
 public:
  PairRunner(const MatcherParams& params, std::size_t max_image_pixels)
      : matcher_(params), max_image_pixels_(max_image_pixels) {}

  double run(const std::string& left_path, const std::string& right_path, const Outputs& out,
             bool warm_up, double* frame_density) {
    // Both headers first: an oversized image costs neither time nor memory.
    checkImagePixels(left_path, max_image_pixels_);
    checkImagePixels(right_path, max_image_pixels_);
    const cv::Mat left = readStereoImage(left_path);
    checkImagePixels(left_path, left, max_image_pixels_);
    const cv::Mat right = readStereoImage(right_path);
    checkImagePixels(right_path, right, max_image_pixels_);
    double ms = 0;
    try {
      if (warm_up) matcher_.compute(left, right, result_);
      const double t0 = nowMs();
      matcher_.compute(left, right, result_);
      ms = nowMs() - t0;
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error(left_path + ", " + right_path + ": " + e.what());
    }
    writeDisparityPng(out.disparity, result_.disparity);
    if (hasTiffExtension(out.confidence)) {
      writeConfidenceTiff(out.confidence, result_.disparity, result_.confidence);
    } else if (!out.confidence.empty()) {
      writeConfidencePng(out.confidence, result_.disparity, result_.confidence);
    }
    if (!out.variance.empty()) writeImage(out.variance, encodeVariance(result_));
    if (frame_density) *frame_density = density(result_.disparity, left);
    return ms;
  }

 private:
  Matcher matcher_;
  MatchResult result_;
  std::size_t max_image_pixels_;
};

bool samePath(const std::string& a, const std::string& b) {
  std::error_code ec1, ec2;
  const fs::path pa = fs::weakly_canonical(a, ec1), pb = fs::weakly_canonical(b, ec2);
  return !ec1 && !ec2 && pa == pb;
}

using NamedPaths = std::vector<std::pair<std::string, std::string>>;

/// Usage error if an output coincides with an input or another output (the
/// inputs may coincide: matching an image with itself is legal).
void requireDistinctOutputs(const NamedPaths& inputs, const NamedPaths& outputs) {
  NamedPaths all = inputs;
  all.insert(all.end(), outputs.begin(), outputs.end());
  for (size_t j = inputs.size(); j < all.size(); ++j) {
    for (size_t i = 0; i < j; ++i) {
      if (all[i].second.empty() || all[j].second.empty()) continue;
      if (samePath(all[i].second, all[j].second)) {
        throw UsageError(all[i].first + " and " + all[j].first + " are the same path (" +
                         all[j].second + ")");
      }
    }
  }
}

void requirePng(const std::string& what, const std::string& path) {
  if (!path.empty() && !hasPngExtension(path)) {
    throw UsageError(what + " must be a .png file (16-bit PNG output), got '" + path + "'");
  }
}

Options parseArgs(int argc, char** argv, bool* help) {
  Options o;
  *help = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      const std::string v = optionValue(i, argc, argv);
      if (v.empty()) throw UsageError(a + " needs a non-empty value");
      return v;
    };
    if (a == "-h" || a == "--help") {
      *help = true;
      return o;
    } else if (a == "--preset") {
      o.preset = value();
    } else if (a == "--params") {
      o.params_file = value();
    } else if (a == "--set") {
      o.overrides.push_back(value());
    } else if (a == "--confidence") {
      o.confidence = value();
    } else if (a == "--variance") {
      o.variance = value();
    } else if (a == "--left-dir") {
      o.left_dir = value();
    } else if (a == "--right-dir") {
      o.right_dir = value();
    } else if (a == "--out-dir") {
      o.out_dir = value();
    } else if (a == "--confidence-dir") {
      o.confidence_dir = value();
    } else if (a == "--variance-dir") {
      o.variance_dir = value();
    } else if (a == "--confidence-format") {
      const std::string f = value();
      if (f != "png" && f != "tiff") throw UsageError("--confidence-format is png or tiff, got '" + f + "'");
      o.confidence_tiff = f == "tiff";
      o.confidence_format_given = true;
    } else if (a == "--max-image-pixels") {
      o.max_image_pixels = parseMaxImagePixels(value());
    } else if (a.size() > 1 && a[0] == '-') {
      throw UsageError("unknown option " + a);
    } else {
      o.positional.push_back(a);
    }
  }
  if (o.dir_mode()) {
    if (o.left_dir.empty() || o.right_dir.empty() || o.out_dir.empty()) {
      throw UsageError("directory mode needs --left-dir, --right-dir and --out-dir");
    }
    if (!o.positional.empty()) {
      throw UsageError("directory mode takes no LEFT RIGHT OUT arguments (got '" +
                       o.positional.front() + "')");
    }
    if (!o.confidence.empty() || !o.variance.empty()) {
      throw UsageError("in directory mode use --confidence-dir / --variance-dir");
    }
    if (o.confidence_format_given && o.confidence_dir.empty()) {
      throw UsageError("--confidence-format needs --confidence-dir");
    }
  } else {
    if (o.positional.size() != 3) {
      throw UsageError("expected LEFT RIGHT OUT.png, got " + std::to_string(o.positional.size()) +
                       " argument(s)");
    }
    if (!o.confidence_dir.empty() || !o.variance_dir.empty()) {
      throw UsageError("--confidence-dir / --variance-dir need directory mode (--left-dir ...)");
    }
    if (o.confidence_format_given) {
      throw UsageError("--confidence-format is for directory mode; for one pair name the file C.png or C.tiff");
    }
  }
  return o;
}

MatcherParams buildParams(const Options& o) {
  MatcherParams params = resolveParams(o.preset, o.params_file);
  for (const std::string& s : o.overrides) params = applyOverride(params, s);
  if (!o.variance.empty() || !o.variance_dir.empty()) params.compute_variance = true;
  params.validate();
  return params;
}

int runSingle(const Options& o, const MatcherParams& params) {
  const std::string &left = o.positional[0], &right = o.positional[1];
  const Outputs out{o.positional[2], o.confidence, o.variance};
  requirePng("OUT", out.disparity);
  if (!out.confidence.empty() && !hasPngExtension(out.confidence) && !hasTiffExtension(out.confidence)) {
    throw UsageError("--confidence must be a .png (16-bit) or .tiff (32-bit float) file, got '" + out.confidence +
                     "'");
  }
  requirePng("--variance", out.variance);
  requireDistinctOutputs({{"LEFT", left}, {"RIGHT", right}},
                         {{"OUT", out.disparity}, {"--confidence", out.confidence},
                          {"--variance", out.variance}});
  // Fail on a bad output path before spending time on the match.
  for (const std::string& p : {out.disparity, out.confidence, out.variance}) {
    if (!p.empty()) checkWritableFile(p);
  }
  PairRunner runner(params, o.max_image_pixels);
  const double ms = runner.run(left, right, out, /*warm_up=*/true, nullptr);
  std::printf("time_ms=%.3f\n", ms);
  return 0;
}

int runDirectory(const Options& o, const MatcherParams& params) {
  requireDistinctOutputs({{"--left-dir", o.left_dir}, {"--right-dir", o.right_dir}},
                         {{"--out-dir", o.out_dir}, {"--confidence-dir", o.confidence_dir},
                          {"--variance-dir", o.variance_dir}});
  const std::vector<std::string> names = pairedFileNames(o.left_dir, o.right_dir);
  if (names.empty()) {
    throw std::runtime_error("no file name is present in both " + o.left_dir + " and " +
                             o.right_dir);
  }
  for (const std::string& d : {o.out_dir, o.confidence_dir, o.variance_dir}) {
    if (!d.empty()) ensureWritableDir(d);
  }

  PairRunner runner(params, o.max_image_pixels);
  std::vector<double> times, densities;
  std::set<std::string> written;
  size_t failed = 0;
  bool warmed_up = false;
  ProgressBar bar(names.size(), o.left_dir);
  for (size_t i = 0; i < names.size(); ++i) {
    const std::string& name = names[i];
    const std::string out_name =
        hasPngExtension(name) ? name : fs::path(name).stem().string() + ".png";
    auto outPath = [&](const std::string& dir, const std::string& file) {
      return dir.empty() ? std::string() : (fs::path(dir) / file).string();
    };
    const std::string confidence_name =
        o.confidence_tiff ? fs::path(out_name).stem().string() + ".tiff" : out_name;
    try {
      if (!written.insert(out_name).second) {
        throw std::runtime_error("output " + out_name + " was already written for another input");
      }
      double frame_density = 0;
      const double ms = runner.run((fs::path(o.left_dir) / name).string(),
                                   (fs::path(o.right_dir) / name).string(),
                                   {outPath(o.out_dir, out_name), outPath(o.confidence_dir, confidence_name),
                                    outPath(o.variance_dir, out_name)},
                                   /*warm_up=*/!warmed_up, &frame_density);
      warmed_up = true;
      times.push_back(ms);
      densities.push_back(frame_density);
    } catch (const std::exception& e) {
      ++failed;
      bar.message(std::string("bdis_match: frame ") + name + " failed: " + e.what());
    }
    bar.update(i + 1);
  }
  bar.finish();

  double mean_density = 0;
  for (double d : densities) mean_density += d;
  if (!densities.empty()) mean_density /= static_cast<double>(densities.size());
  std::printf("frames=%zu failed=%zu median_ms=%.2f mean_density=%.3f out_dir=%s\n", times.size(),
              failed, median(times), mean_density, o.out_dir.c_str());
  if (failed) {
    std::fprintf(stderr, "bdis_match: %zu of %zu frame(s) failed\n", failed, names.size());
    return 1;
  }
  return 0;
}

int run(int argc, char** argv) {
  bool help = false;
  const Options o = parseArgs(argc, argv, &help);
  if (help) {
    std::cout << kUsage;
    return 0;
  }
  const MatcherParams params = buildParams(o);
  cv::setNumThreads(1);  // the matcher is single-threaded; keep OpenCV so too
  return o.dir_mode() ? runDirectory(o, params) : runSingle(o, params);
}

}  // namespace

int main(int argc, char** argv) {
  return runGuarded("bdis_match", [&] { return run(argc, argv); });
}
