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
#include <system_error>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

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

uint32_t bigEndian(const unsigned char* p, int bytes) {
  uint32_t v = 0;
  for (int i = 0; i < bytes; ++i) v = (v << 8) | p[i];
  return v;
}

uint32_t littleEndian(const unsigned char* p, int bytes) {
  uint32_t v = 0;
  for (int i = bytes - 1; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}

// JPEG: the size is in the frame header (SOF0..SOF15 but DHT, JPG and DAC),
// after any APPn/COM segments; each segment is skipped by its length.
std::optional<cv::Size> jpegSize(std::istream& in) {
  for (int segments = 0; segments < 1000 && in; ++segments) {
    int byte = in.get();
    if (byte != 0xFF) return std::nullopt;
    while (byte == 0xFF) byte = in.get();  // fill bytes
    if (byte == EOF) return std::nullopt;
    const int marker = byte;
    if (marker == 0xD8 || marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7)) continue;  // no length
    if (marker == 0xD9 || marker == 0xDA) return std::nullopt;  // end of image, start of scan
    unsigned char length_bytes[2];
    if (!in.read(reinterpret_cast<char*>(length_bytes), 2)) return std::nullopt;
    const uint32_t length = bigEndian(length_bytes, 2);
    if (length < 2) return std::nullopt;
    const bool frame_header = marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 &&
                              marker != 0xCC;
    if (frame_header) {
      unsigned char sof[5];  // precision, height, width
      if (length < 7 || !in.read(reinterpret_cast<char*>(sof), 5)) return std::nullopt;
      const uint32_t height = bigEndian(sof + 1, 2), width = bigEndian(sof + 3, 2);
      if (width == 0 || height == 0) return std::nullopt;  // height given later (DNL): rare
      return cv::Size(static_cast<int>(width), static_cast<int>(height));
    }
    in.seekg(length - 2, std::ios::cur);
  }
  return std::nullopt;
}

// PNM (P1..P6): magic, then width and height as text, '#' comments between.
std::optional<cv::Size> pnmSize(std::istream& in) {
  long long values[2] = {0, 0};
  for (long long& value : values) {
    int c = in.get();
    while (c != EOF && (std::isspace(c) || c == '#')) {
      if (c == '#') {
        while (c != EOF && c != '\n') c = in.get();
      }
      c = in.get();
    }
    if (c == EOF || !std::isdigit(c)) return std::nullopt;
    while (c != EOF && std::isdigit(c)) {
      value = value * 10 + (c - '0');
      if (value > (1LL << 31)) return std::nullopt;
      c = in.get();
    }
  }
  return cv::Size(static_cast<int>(values[0]), static_cast<int>(values[1]));
}

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

std::optional<cv::Size> imageSizeFromHeader(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  unsigned char head[26] = {};
  if (!in.read(reinterpret_cast<char*>(head), 2)) return std::nullopt;
  if (head[0] == 0xFF && head[1] == 0xD8) {
    in.seekg(0);
    return jpegSize(in);
  }
  if (head[0] == 'P' && head[1] >= '1' && head[1] <= '6') return pnmSize(in);
  in.read(reinterpret_cast<char*>(head + 2), sizeof(head) - 2);
  const std::streamsize got = 2 + in.gcount();
  static const unsigned char kPngSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  if (got >= 24 && std::equal(kPngSignature, kPngSignature + 8, head) &&
      std::string(reinterpret_cast<const char*>(head + 12), 4) == "IHDR") {
    return cv::Size(static_cast<int>(bigEndian(head + 16, 4) & 0x7FFFFFFF),
                    static_cast<int>(bigEndian(head + 20, 4) & 0x7FFFFFFF));
  }
  if (got >= 26 && head[0] == 'B' && head[1] == 'M') {
    const uint32_t info_size = littleEndian(head + 14, 4);
    if (info_size == 12) {  // BITMAPCOREHEADER: 16-bit sizes
      return cv::Size(static_cast<int>(littleEndian(head + 18, 2)),
                      static_cast<int>(littleEndian(head + 20, 2)));
    }
    // BITMAPINFOHEADER and later: signed 32-bit; a negative height is top-down.
    const int32_t width = static_cast<int32_t>(littleEndian(head + 18, 4));
    const int32_t height = static_cast<int32_t>(littleEndian(head + 22, 4));
    if (width <= 0 || height == INT32_MIN) return std::nullopt;
    return cv::Size(width, height < 0 ? -height : height);
  }
  return std::nullopt;
}

void checkImagePixels(const std::string& path, std::size_t max_pixels) {
  if (const std::optional<cv::Size> size = imageSizeFromHeader(path)) {
    refuseAbove(path, static_cast<std::size_t>(size->width), static_cast<std::size_t>(size->height),
                max_pixels);
  }
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

bool hasPngExtension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".png";
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
