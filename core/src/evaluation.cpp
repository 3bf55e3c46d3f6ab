#include "bdis_stereo/evaluation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace fs = std::filesystem;

namespace bdis {

void DisparityScore::add(const DisparityScore& o) {
  scorable += o.scorable;
  estimated += o.estimated;
  bad2 += o.bad2;
  abs_error_sum += o.abs_error_sum;
  abs_errors.insert(abs_errors.end(), o.abs_errors.begin(), o.abs_errors.end());
}

double DisparityScore::density() const { return scorable > 0 ? estimated / scorable : 0.0; }
double DisparityScore::meanError() const { return estimated > 0 ? abs_error_sum / estimated : 0.0; }
double DisparityScore::bad2Rate() const { return estimated > 0 ? bad2 / estimated : 0.0; }
double DisparityScore::missOrBad2Rate() const {
  return scorable > 0 ? (scorable - estimated + bad2) / scorable : 0.0;
}
double DisparityScore::medianError() const {
  if (abs_errors.empty()) return 0.0;
  std::vector<float> e = abs_errors;
  const size_t mid = e.size() / 2;
  std::nth_element(e.begin(), e.begin() + static_cast<long>(mid), e.end());
  if (e.size() % 2 == 1) return e[mid];
  const float upper = e[mid];
  const float lower = *std::max_element(e.begin(), e.begin() + static_cast<long>(mid));
  return 0.5 * (static_cast<double>(lower) + upper);
}

DisparityScore scoreDisparity(const cv::Mat& disparity, const cv::Mat& gt, const cv::Mat& left,
                              double error_scale) {
  if (disparity.type() != CV_32FC1 || gt.type() != CV_32FC1 || disparity.size() != gt.size() ||
      left.size() != gt.size() || left.depth() != CV_8U) {
    throw std::invalid_argument("scoreDisparity: disparity and ground truth must be CV_32FC1 and "
                                "the left image 8-bit, all of one size");
  }
  DisparityScore s;
  const int ch = left.channels();
  for (int y = 0; y < gt.rows; ++y) {
    const float* d = disparity.ptr<float>(y);
    const float* g = gt.ptr<float>(y);
    const uchar* l = left.ptr<uchar>(y);
    for (int x = 0; x < gt.cols; ++x) {
      bool black = true;
      for (int c = 0; c < ch; ++c) black = black && l[x * ch + c] == 0;
      if (!(g[x] > 0.f) || black) continue;
      s.scorable += 1;
      if (!(d[x] >= 0.f)) continue;  // no estimate (negative or NaN)
      const float e = static_cast<float>(error_scale * std::fabs(d[x] - g[x]));
      s.estimated += 1;
      s.abs_error_sum += e;
      s.abs_errors.push_back(e);
      if (e > 2.f) s.bad2 += 1;
    }
  }
  return s;
}

cv::Mat readDisparityPng(const std::string& path) {
  const cv::Mat raw = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (raw.empty()) throw std::runtime_error("cannot read disparity PNG " + path);
  if (raw.type() != CV_16UC1) {
    throw std::runtime_error("disparity PNG " + path + " is not 16-bit single channel");
  }
  cv::Mat out(raw.size(), CV_32FC1);
  for (int y = 0; y < raw.rows; ++y) {
    const uint16_t* r = raw.ptr<uint16_t>(y);
    float* o = out.ptr<float>(y);
    for (int x = 0; x < raw.cols; ++x) o[x] = r[x] == 0 ? -1.f : r[x] / 256.f;
  }
  return out;
}

void writeDisparityPng(const std::string& path, const cv::Mat& disparity) {
  if (disparity.type() != CV_32FC1) {
    throw std::runtime_error("writeDisparityPng: disparity must be CV_32FC1");
  }
  cv::Mat raw(disparity.size(), CV_16UC1);
  for (int y = 0; y < raw.rows; ++y) {
    const float* d = disparity.ptr<float>(y);
    uint16_t* r = raw.ptr<uint16_t>(y);
    for (int x = 0; x < raw.cols; ++x) {
      // A real estimate never becomes 0 (= none): tiny disparities round up to 1/256.
      r[x] = d[x] >= 0.f ? static_cast<uint16_t>(std::clamp(std::lround(d[x] * 256.f), 1L, 65535L))
                         : 0;
    }
  }
  writeImage(path, raw);
}

namespace {

/// The confidence of every estimate through `encode` (NaN as 0), 0 elsewhere.
template <typename T, typename Encode>
cv::Mat confidenceImage(const cv::Mat& disparity, const cv::Mat& confidence, int type, Encode encode) {
  if (disparity.type() != CV_32FC1 || confidence.type() != CV_32FC1 || disparity.size() != confidence.size()) {
    throw std::runtime_error("writing a confidence: disparity and confidence must be CV_32FC1 of one size");
  }
  cv::Mat out(confidence.size(), type);
  for (int y = 0; y < out.rows; ++y) {
    const float* d = disparity.ptr<float>(y);
    const float* c = confidence.ptr<float>(y);
    T* o = out.ptr<T>(y);
    for (int x = 0; x < out.cols; ++x) o[x] = d[x] >= 0.f ? encode(std::isfinite(c[x]) ? c[x] : 0.f) : T(0);
  }
  return out;
}

}  // namespace

void writeConfidencePng(const std::string& path, const cv::Mat& disparity, const cv::Mat& confidence) {
  writeImage(path, confidenceImage<uint16_t>(disparity, confidence, CV_16UC1, [](float c) {
               return static_cast<uint16_t>(std::clamp(std::lround(c * 65535.f), 1L, 65535L));
             }));
}

void writeConfidenceTiff(const std::string& path, const cv::Mat& disparity, const cv::Mat& confidence) {
  writeImage(path, confidenceImage<float>(disparity, confidence, CV_32FC1, [](float c) {
               return std::max(std::min(c, 1.f), std::numeric_limits<float>::min());
             }));
}

cv::Mat readConfidence(const std::string& path) {
  const cv::Mat raw = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (raw.empty()) throw std::runtime_error("cannot read confidence " + path);
  if (raw.type() == CV_32FC1) return raw;
  if (raw.type() != CV_16UC1) {
    throw std::runtime_error("confidence " + path + " is neither 16-bit nor 32-bit float single channel");
  }
  cv::Mat out;
  raw.convertTo(out, CV_32FC1, 1.0 / 65535.0);
  return out;
}

void writeImage(const std::string& path, const cv::Mat& image) {
  bool ok = false;
  try {
    ok = cv::imwrite(path, image);
  } catch (const cv::Exception& e) {
    throw std::runtime_error("cannot write " + path + ": " + e.msg);
  }
  if (!ok) throw std::runtime_error("cannot write " + path);
}

cv::Mat readStereoImage(const std::string& path) {
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (!fs::exists(st)) throw std::runtime_error("cannot read " + path + ": no such file");
  if (fs::is_directory(st)) throw std::runtime_error("cannot read " + path + ": is a directory");
  cv::Mat img;
  try {
    img = cv::imread(path, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    throw std::runtime_error("cannot read " + path + ": " + e.msg);
  }
  if (img.empty()) {
    throw std::runtime_error("cannot read " + path + ": not a readable image (or no permission)");
  }
  if (img.depth() == CV_8U && img.channels() == 4) cv::cvtColor(img, img, cv::COLOR_BGRA2BGR);
  return img;
}

std::vector<std::string> pairedFileNames(const std::string& dir_a, const std::string& dir_b) {
  for (const std::string& d : {dir_a, dir_b}) {
    std::error_code ec;
    if (!fs::is_directory(d, ec)) throw std::runtime_error(d + " is not a directory");
  }
  std::vector<std::string> names;
  std::error_code ec;
  for (fs::directory_iterator it(dir_a, ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code ec2;
    const std::string name = it->path().filename().string();
    if (it->is_regular_file(ec2) && fs::is_regular_file(fs::path(dir_b) / name, ec2)) {
      names.push_back(name);
    }
  }
  if (ec) throw std::runtime_error("cannot list " + dir_a + ": " + ec.message());
  std::sort(names.begin(), names.end());
  return names;
}

StereoSequence StereoSequence::open(const std::string& root) {
  StereoSequence seq;
  seq.root = root;
  seq.names = pairedFileNames((fs::path(root) / "left").string(), (fs::path(root) / "right").string());
  if (seq.names.empty()) throw std::runtime_error("sequence " + root + " has no image pairs");
  seq.has_ground_truth = fs::is_directory(fs::path(root) / "gt_disparity");
  seq.has_surfaces = fs::is_directory(fs::path(root) / "labels");
  return seq;
}

cv::Mat StereoSequence::left(size_t i) const {
  return readStereoImage((fs::path(root) / "left" / names.at(i)).string());
}
cv::Mat StereoSequence::right(size_t i) const {
  return readStereoImage((fs::path(root) / "right" / names.at(i)).string());
}
cv::Mat StereoSequence::groundTruth(size_t i) const {
  cv::Mat d = readDisparityPng((fs::path(root) / "gt_disparity" / names.at(i)).string());
  cv::max(d, 0.f, d);  // unknown (-1) becomes 0 as in the file
  return d;
}

cv::Mat StereoSequence::surfaces(size_t i) const {
  const std::string path = (fs::path(root) / "labels" / names.at(i)).string();
  cv::Mat labels = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (labels.empty()) throw std::runtime_error("cannot read " + path);
  if (labels.type() != CV_8UC1) throw std::runtime_error(path + " is not an 8-bit single-channel label image");
  return labels;
}

std::string findDataDir() {
  if (const char* env = std::getenv("BDIS_DATA_DIR")) {
    if (*env) return env;
  }
  std::error_code ec;
  const fs::path beside = fs::current_path(ec) / ".." / "shared" / "data";
  if (fs::is_directory(beside, ec)) return fs::weakly_canonical(beside, ec).string();
  return {};
}

}  // namespace bdis
