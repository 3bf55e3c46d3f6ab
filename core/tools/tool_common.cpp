#include "tool_common.hpp"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cmath>
#include <cstdint>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <system_error>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "bdis_stereo/image_header.hpp"

namespace bdis {
namespace tools {

namespace {
// Messages end in exactly one newline, even when they wrap an OpenCV
// exception text that carries its own.
std::string trimTrailing(std::string s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.pop_back();
  return s;
}
}  // namespace

int runGuarded(const char* tool, const std::function<int()>& body) {
  try {
    return body();
  } catch (const UsageError& e) {
    std::cerr << tool << ": " << trimTrailing(e.what()) << "\n(see " << tool << " --help)\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << tool << ": error: " << trimTrailing(e.what()) << "\n";
    return 1;
  } catch (...) {
    std::cerr << tool << ": error: unknown exception\n";
    return 1;
  }
}

MatcherParams resolveParams(const std::string& preset, const std::string& params_file) {
  MatcherParams p = bindPreset(ParamValue::ofString(preset.empty() ? "balanced" : preset), "--preset");
  if (!params_file.empty()) p = loadParams(params_file, p);
  return p;
}

std::string optionValue(int& i, int argc, char** argv) {
  const std::string option = argv[i];
  if (i + 1 >= argc) throw UsageError(option + " needs a value");
  return argv[++i];
}

namespace {
template <typename T>
T parseWhole(const std::string& what, const std::string& text, const char* kind,
             T (*parse)(const std::string&, size_t*)) {
  size_t used = 0;
  T v{};
  try {
    v = parse(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (text.empty() || used != text.size()) {
    throw UsageError(what + " needs " + kind + ", got '" + text + "'");
  }
  return v;
}
}  // namespace

double parseDouble(const std::string& what, const std::string& text) {
  return parseWhole<double>(what, text, "a number",
                            [](const std::string& t, size_t* used) { return std::stod(t, used); });
}

long long parseInteger(const std::string& what, const std::string& text) {
  return parseWhole<long long>(what, text, "an integer",
                               [](const std::string& t, size_t* used) { return std::stoll(t, used); });
}

MatcherParams applyOverride(MatcherParams params, const std::string& assignment) {
  const size_t eq = assignment.find('=');
  if (eq == std::string::npos) throw UsageError("expected NAME=VALUE, got '" + assignment + "'");
  try {
    bindParam(params, assignment.substr(0, eq), ParamValue::fromText(assignment.substr(eq + 1)), "--set");
  } catch (const ParamError& e) {
    throw UsageError(e.what());
  }
  return params;
}

std::size_t parseMaxImagePixels(const std::string& text) {
  const long long n = parseInteger("--max-image-pixels", text);
  if (n < 1) throw UsageError("--max-image-pixels needs a whole number >= 1, got " + text);
  return static_cast<std::size_t>(n);
}

namespace {

std::string pixelsText(std::size_t pixels) {
  // 16777216 (4096x4096): the square that many pixels make, when there is one.
  const auto side = static_cast<std::size_t>(std::llround(std::sqrt(static_cast<double>(pixels))));
  return std::to_string(pixels) +
         (side * side == pixels ? " (" + std::to_string(side) + "x" + std::to_string(side) + ")" : "");
}

void refuseAbove(const std::string& path, std::size_t width, std::size_t height, std::size_t max_pixels) {
  if (width * height <= max_pixels) return;
  throw std::runtime_error(path + " is " + std::to_string(width) + "x" + std::to_string(height) + " (" +
                           std::to_string(width * height) + " pixels), more than --max-image-pixels " +
                           pixelsText(max_pixels) +
                           ": downscale the images or raise --max-image-pixels");
}

}  // namespace

void checkImagePixels(const std::string& path, std::size_t max_pixels) {
  std::ifstream in(path, std::ios::binary);
  const std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ImageHeader header;
  if (!detectImageFormat(bytes.data(), bytes.size(), header.format)) return;  // the decoder decides
  const std::string error = readImageHeader(bytes.data(), bytes.size(), header);
  if (!error.empty()) throw std::runtime_error(path + " " + error);
  refuseAbove(path, static_cast<std::size_t>(header.width), static_cast<std::size_t>(header.height), max_pixels);
}

void checkImagePixels(const std::string& path, const cv::Mat& image, std::size_t max_pixels) {
  refuseAbove(path, static_cast<std::size_t>(image.cols), static_cast<std::size_t>(image.rows), max_pixels);
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

namespace fs = std::filesystem;

void checkWritableFile(const std::string& path) {
  if (path.empty()) throw std::runtime_error("empty output path");
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    throw std::runtime_error("cannot write " + path + ": is a directory");
  }
  fs::path dir = fs::path(path).parent_path();
  if (dir.empty()) dir = ".";
  if (!fs::exists(dir, ec)) {
    throw std::runtime_error("cannot write " + path + ": directory " + dir.string() +
                             " does not exist");
  }
  if (!fs::is_directory(dir, ec)) {
    throw std::runtime_error("cannot write " + path + ": " + dir.string() + " is not a directory");
  }
  if (::access(dir.c_str(), W_OK | X_OK) != 0) {
    throw std::runtime_error("cannot write " + path + ": directory " + dir.string() +
                             " is not writable");
  }
}

void ensureWritableDir(const std::string& dir) {
  if (dir.empty()) throw std::runtime_error("empty output directory");
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir)) {
    throw std::runtime_error("cannot create output directory " + dir +
                             (ec ? ": " + ec.message() : std::string()));
  }
  if (::access(dir.c_str(), W_OK | X_OK) != 0) {
    throw std::runtime_error("output directory " + dir + " is not writable");
  }
}

namespace {
std::string lowerExtension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}
}  // namespace

bool hasPngExtension(const std::string& path) { return lowerExtension(path) == ".png"; }

bool hasTiffExtension(const std::string& path) {
  const std::string ext = lowerExtension(path);
  return ext == ".tif" || ext == ".tiff";
}

ProgressBar::ProgressBar(size_t total, std::string label) : total_(total), label_(std::move(label)) {
  update(0);
}

void ProgressBar::update(size_t done) {
  done_ = done;
  constexpr int kWidth = 30;
  const double frac = total_ ? static_cast<double>(done) / static_cast<double>(total_) : 1.0;
  const int filled = static_cast<int>(frac * kWidth);
  std::fprintf(stderr, "\r%s [%s%s] %zu/%zu", label_.c_str(), std::string(filled, '#').c_str(),
               std::string(kWidth - filled, '.').c_str(), done, total_);
  std::fflush(stderr);
}

void ProgressBar::message(const std::string& line) {
  // Blank the bar's line, print the message in its place, redraw below.
  const size_t width = label_.size() + 60;
  std::fprintf(stderr, "\r%s\r%s\n", std::string(width, ' ').c_str(), trimTrailing(line).c_str());
  if (!finished_) update(done_);
  std::fflush(stderr);
}

void ProgressBar::finish() {
  if (finished_) return;
  finished_ = true;
  std::fprintf(stderr, "\n");
}

}  // namespace tools
}  // namespace bdis
