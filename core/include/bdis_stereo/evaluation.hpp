// Scoring and data I/O for sequences in the layout of the project's data
// folders (left/, right/, gt_disparity/, camera.yaml). Used by the offline
// evaluator, the accuracy tests and the benchmarks.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace bdis {

/// Scores of one method over a set of frames, as the data README defines them:
/// over pixels with ground truth > 0 and a non-black left image.
struct DisparityScore {
  double scorable = 0;      ///< pixels with ground truth and a non-black left image
  double estimated = 0;     ///< of those, pixels with an estimate
  double bad2 = 0;          ///< of the estimated, pixels off by more than 2 px
  double abs_error_sum = 0;
  std::vector<float> abs_errors;  ///< per estimated pixel, for the median

  void add(const DisparityScore& other);
  double density() const;         ///< estimated / scorable
  double meanError() const;       ///< px
  double medianError() const;     ///< px (sorts a copy)
  double bad2Rate() const;        ///< bad2 / estimated
  double missOrBad2Rate() const;  ///< (scorable - estimated + bad2) / scorable
};

/// Scores `disparity` (CV_32FC1, negative = no estimate) against `gt`
/// (CV_32FC1, 0 = unknown), masking pixels that are black in `left`. Errors
/// are multiplied by `error_scale` first: 640 / width counts them in pixels
/// of a 640 px wide frame, to compare frame sizes.
DisparityScore scoreDisparity(const cv::Mat& disparity, const cv::Mat& gt, const cv::Mat& left,
                              double error_scale = 1.0);

/// KITTI convention: 16-bit PNG, value = round(d * 256), 0 = no estimate.
/// Reads into CV_32FC1 with kNoDisparity (-1) for 0. Throws std::runtime_error.
cv::Mat readDisparityPng(const std::string& path);
/// Writes CV_32FC1 disparity (negative = none) as 16-bit PNG; values are
/// clamped to the 16-bit range. Throws std::runtime_error on failure.
void writeDisparityPng(const std::string& path, const cv::Mat& disparity);

/// Confidence as 16-bit PNG: value = round(c * 65535), 0 = no estimate. An
/// estimate (disparity >= 0) is stored as at least 1, so that a confidence
/// below 1 / 131070 (the confidence spans many decades) does not read as a
/// missing one; pixels without an estimate are 0 whatever their confidence.
/// The lowest confidences tie at 1: rank from writeConfidenceTiff's files.
/// `disparity` and `confidence` are CV_32FC1 of one size. Throws std::runtime_error.
void writeConfidencePng(const std::string& path, const cv::Mat& disparity, const cv::Mat& confidence);
/// The same as a 32-bit float TIFF, exact: 0 = no estimate, an estimate's
/// confidence at least the smallest normal float. `path` should end in .tiff.
void writeConfidenceTiff(const std::string& path, const cv::Mat& disparity, const cv::Mat& confidence);
/// Reads either file into CV_32FC1 in [0, 1] (a PNG's value / 65535). Throws
/// std::runtime_error for anything else than 16-bit or 32-bit float single channel.
cv::Mat readConfidence(const std::string& path);

/// Reads an image as stored (IMREAD_UNCHANGED); 8-bit BGRA becomes BGR.
/// Anything else (16-bit, float) is returned as is, so the matcher rejects it
/// with its own message. Throws std::runtime_error naming the file when it is
/// missing, a directory or not a readable image.
cv::Mat readStereoImage(const std::string& path);

/// Names of the regular files present in both directories, sorted. Throws
/// std::runtime_error when either is not a directory.
std::vector<std::string> pairedFileNames(const std::string& dir_a, const std::string& dir_b);

/// cv::imwrite that throws std::runtime_error naming the path on failure.
void writeImage(const std::string& path, const cv::Mat& image);

/// One stereo sequence on disk.
struct StereoSequence {
  std::string root;
  std::vector<std::string> names;  ///< file names present in both left/ and right/, sorted
  bool has_ground_truth = false;   ///< gt_disparity/ exists
  bool has_surfaces = false;       ///< labels/ exists (generated scenes: the surface each left pixel sees)

  /// Lists the sequence; throws std::runtime_error if left/ or right/ is missing or empty.
  static StereoSequence open(const std::string& root);
  cv::Mat left(size_t i) const;    ///< readStereoImage of left/<name>
  cv::Mat right(size_t i) const;
  cv::Mat groundTruth(size_t i) const;  ///< CV_32FC1 px, 0 = unknown (not -1)
  /// CV_8UC1 labels/<name>: 0 none, 1 tissue, 2 instrument (kInstrumentSurface);
  /// throws std::runtime_error if it is missing or not an 8-bit single-channel image.
  cv::Mat surfaces(size_t i) const;
};

/// Root of the shared data folder, found at run time: $BDIS_DATA_DIR if set,
/// else ../shared/data from the working directory if it exists; empty
/// string when neither is there.
std::string findDataDir();

}  // namespace bdis
