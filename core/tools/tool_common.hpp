// Small pieces shared by the offline tools: error handling that always exits
// with a message (never a signal), parameter loading, a progress bar, timing.
#pragma once

#include <chrono>
#include <cstddef>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "bdis_stereo/evaluation.hpp"  // readStereoImage, pairedFileNames
#include "bdis_stereo/params.hpp"

namespace bdis {
namespace tools {

/// Runs `body`, turning any exception into "<tool>: error: <what>" on stderr
/// and exit code 1 (2 for usage errors thrown as UsageError).
int runGuarded(const char* tool, const std::function<int()>& body);

/// Thrown for bad command lines; runGuarded prints the usage text too.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// The value after option argv[i] (advancing i); UsageError "OPT needs a value" at the end.
std::string optionValue(int& i, int argc, char** argv);

/// Whole-string number parsing for option `what`; UsageError "WHAT needs a number,
/// got 'TEXT'" (or "an integer") otherwise.
double parseDouble(const std::string& what, const std::string& text);
long long parseInteger(const std::string& what, const std::string& text);

/// Preset (default "balanced") then an optional YAML file on top.
MatcherParams resolveParams(const std::string& preset, const std::string& params_file);

/// Applies "name=value" to one field through bdis::bindParam (source "--set";
/// the value read by ParamValue::fromText); throws UsageError naming the field.
MatcherParams applyOverride(MatcherParams params, const std::string& assignment);

/// Default of --max-image-pixels, the same as the nodelet's max_image_pixels:
/// 4096 x 4096. An image above it is refused (bounded memory and time).
constexpr std::size_t kDefaultMaxImagePixels = 4096u * 4096u;

/// The value of --max-image-pixels: a whole number >= 1 (UsageError otherwise).
std::size_t parseMaxImagePixels(const std::string& text);

/// Throws std::runtime_error when the image at `path` (a JPEG, PNG, BMP or
/// PNM; other formats are left to the decoder) has more than `max_pixels`
/// pixels as far as its header tells, or is a truncated or corrupt JPEG or
/// PNG (readImageHeader), so that it is refused before it is decoded.
void checkImagePixels(const std::string& path, std::size_t max_pixels);

/// The same limit on an image already decoded (formats the header probe does
/// not read).
void checkImagePixels(const std::string& path, const cv::Mat& image, std::size_t max_pixels);

/// Monotonic milliseconds.
inline double nowMs() {
  using namespace std::chrono;
  return duration<double, std::milli>(steady_clock::now().time_since_epoch()).count();
}

double median(std::vector<double> values);

/// Throws std::runtime_error unless a file can be created at `path`: its
/// directory must exist and be writable and `path` must not be a directory.
void checkWritableFile(const std::string& path);

/// Creates `dir` (and parents) if needed; throws std::runtime_error unless it
/// then is a writable directory.
void ensureWritableDir(const std::string& dir);

/// True when `path` ends in ".png" (any case).
bool hasPngExtension(const std::string& path);
/// Whether `path` ends in .tif or .tiff (any case).
bool hasTiffExtension(const std::string& path);

/// A one-line progress bar on stderr, redrawn in place.
class ProgressBar {
 public:
  ProgressBar(size_t total, std::string label);
  void update(size_t done);
  /// Prints `line` on its own line on stderr, then redraws the bar.
  void message(const std::string& line);
  void finish();

 private:
  size_t total_;
  size_t done_ = 0;
  std::string label_;
  bool finished_ = false;
};

}  // namespace tools
}  // namespace bdis
