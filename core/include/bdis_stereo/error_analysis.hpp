// Where a disparity map is wrong and whether its confidence says so: scorable
// pixels split into regions by what the ground truth says about them, the
// confidence's sparsification curve against the oracle's, the calibration of
// a variance, and, for sequences without ground truth, outliers in the strips
// along the rectification border. Used by bdis_eval and the accuracy tests.
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace bdis {

/// The region of a scorable pixel; the first that applies, in this order.
enum class PixelRegion : unsigned char {
  OutOfView,  ///< its match x - d_gt lies left of the right image
  Occluded,   ///< a nearer surface covers its match in the right view (GT z-buffer)
  Dark,       ///< left grey level below RegionOptions::dark_grey
  DepthEdge,  ///< within RegionOptions::edge_band_px of a jump in the ground truth
  Rest,       ///< lit, visible, away from depth edges
};
constexpr int kPixelRegions = 5;
/// "out_of_view", "occluded", "dark", "depth_edge", "rest".
const char* regionName(PixelRegion region);

struct RegionOptions {
  double dark_grey = 30.0;         ///< grey levels (Rec. 601 luma of the left image)
  float edge_jump_px = 2.f;        ///< a GT jump between 4-neighbours larger than this is a depth edge
  int edge_band_px = 3;            ///< half-width of the band around a depth edge
  float occlusion_margin_px = 1.f; ///< how much nearer the occluder must be
};

/// Label image (CV_8UC1): the PixelRegion of every scorable pixel (ground
/// truth > 0, left image not black), kNotScorable elsewhere.
constexpr unsigned char kNotScorable = 255;
cv::Mat classifyPixels(const cv::Mat& gt, const cv::Mat& left, const RegionOptions& options = {});

/// Share, density and bad2 per region, summed over frames.
struct RegionScore {
  struct Counts {
    double scorable = 0, estimated = 0, bad2 = 0;
    double density() const { return scorable > 0 ? estimated / scorable : 0.0; }
    double bad2Rate() const { return estimated > 0 ? bad2 / estimated : 0.0; }
  };
  std::array<Counts, kPixelRegions> regions{};
  double scorable() const;
  double share(PixelRegion r) const;  ///< of all scorable pixels
  const Counts& operator[](PixelRegion r) const { return regions[static_cast<size_t>(r)]; }
  void add(const RegionScore& other);
};

/// `disparity` (CV_32FC1, negative = none) against `labels` from classifyPixels and `gt`.
RegionScore scoreRegions(const cv::Mat& disparity, const cv::Mat& gt, const cv::Mat& labels);

/// Scenes with an instrument whose pixels are known (the `labels/` bdis_synth
/// writes: the surface each left pixel sees, kInstrumentSurface on the
/// instrument): the tissue within `band_px` of the instrument's outline, where
/// a patch straddling the outline carries the instrument's depth onto the
/// tissue beside it (foreground fattening), and the instrument's own rim of
/// `band_px`, where the tissue's depth bleeds in. "Within" is the chessboard
/// distance (a 3 x 3 dilation repeated `band_px` times).
constexpr unsigned char kInstrumentSurface = 2;
struct InstrumentBandScore {
  struct Band {
    double scorable = 0, estimated = 0, bad2 = 0;
    double confident_bad2 = 0;  ///< off by > 2 px with confidence >= the threshold given
    double confidence_sum = 0;  ///< over the estimates, when there is a confidence
    double density() const { return scorable > 0 ? estimated / scorable : 0.0; }
    double bad2Rate() const { return estimated > 0 ? bad2 / estimated : 0.0; }
    /// Confidently wrong estimates as a share of the band's scorable pixels.
    double confidentBad2Share() const { return scorable > 0 ? confident_bad2 / scorable : 0.0; }
    /// What the band's confidence claims (its mean) against what it has (1 - bad2 rate).
    double meanConfidence() const { return estimated > 0 ? confidence_sum / estimated : 0.0; }
  };
  Band tissue, rim;
  bool any() const { return tissue.scorable + rim.scorable > 0; }
  void add(const InstrumentBandScore& other);
};
/// `surfaces` CV_8UC1 (kInstrumentSurface on the instrument), `regions` from
/// classifyPixels (its scorable pixels are scored), `confidence` CV_32FC1 or
/// empty (then no pixel counts as confident).
InstrumentBandScore scoreInstrumentBands(const cv::Mat& disparity, const cv::Mat& gt, const cv::Mat& regions,
                                         const cv::Mat& surfaces, const cv::Mat& confidence, int band_px = 12,
                                         float confident = 0.5f);

/// Every estimated scorable pixel's confidence, absolute error and (when a
/// variance is given) standard deviation, pooled over frames.
struct EstimateSamples {
  std::vector<float> confidence, abs_error, sigma;
  double scorable = 0;  ///< scorable pixels, estimated or not (for densities)
  /// Adds a frame; `confidence` and `variance` may be empty (CV_32FC1 otherwise).
  void add(const cv::Mat& disparity, const cv::Mat& gt, const cv::Mat& labels, const cv::Mat& confidence,
           const cv::Mat& variance);
  size_t size() const { return abs_error.size(); }
};

/// The confidence as a ranking of the errors. Estimates are sorted by
/// confidence, most confident first; bad2 of the most confident fraction f
/// is integrated over f from 0.05 to 1 (trapezoids at steps of 0.05); the
/// oracle sorts by the true error instead.
struct Sparsification {
  double area = 0, oracle_area = 0;
  double ratio() const { return oracle_area > 0 ? area / oracle_area : 0.0; }
  double bad2_top25 = 0, bad2_top50 = 0;  ///< bad2 of the 25 % / 50 % most confident
  /// bad2 of each tenth of the estimates, least confident first.
  std::array<double, 10> decile_bad2{};
  /// Whether bad2 falls (or stays) from each decile to the next more confident one.
  bool monotone(double tolerance = 0.0) const;
};
Sparsification sparsify(const EstimateSamples& samples);
/// The same for any score, a higher `trust` ranking an estimate as more
/// likely right; `trust` and `abs_error` pair up index by index.
Sparsification sparsifyBy(const std::vector<float>& trust, const std::vector<float>& abs_error);

/// What a confidence threshold leaves: density (of all scorable pixels) and
/// bad2 of the estimates whose confidence is at least `threshold`.
struct ThresholdRow {
  float threshold;
  double density, bad2;
};
std::vector<ThresholdRow> confidenceThresholds(const EstimateSamples& samples, const std::vector<float>& thresholds);

/// The confidence as the probability of being within 2 px, as the matcher's
/// calibrated confidence claims to be: per bin of confidence [lower, upper)
/// (the last bin holds its upper edge too), the share of the estimates in
/// it, their mean confidence and the share of them within 2 px; and the
/// expected calibration error, the bins' |mean confidence - share within
/// 2 px| weighted by their shares (0 for a confidence that says what it means).
/// Over all the binned estimates too: 1 - their mean confidence is the share
/// of wrong ones the confidence predicts, against 1 - within2 found.
struct ReliabilityBin {
  float lower = 0, upper = 0;
  double share = 0, mean_confidence = 0, within2 = 0;
};
struct Reliability {
  std::vector<ReliabilityBin> bins;
  double expected_error = 0;
  double mean_confidence = 0, within2 = 0;  ///< over every binned estimate
  /// The most a bin claims over what it has (mean confidence - share within
  /// 2 px), over the bins from `from_confidence` up holding at least
  /// `min_share` of the estimates; -1 when none does.
  double mostClaimedOver(float from_confidence = 0.f, double min_share = 0.01) const;
};
/// The bins bdis_eval and the tests use: 0-0.5, 0.5-0.6, ..., 0.9-0.95,
/// 0.95-0.98, 0.98-1, finer where most estimates lie.
const std::vector<float>& reliabilityEdges();
/// `edges` increasing, at least two; estimates outside [front, back] are left out.
Reliability reliability(const EstimateSamples& samples, const std::vector<float>& edges = reliabilityEdges());

/// How well a variance describes the errors, as a standard deviation should:
/// the shares of |error| within 1 and 2 sigma (a Gaussian: 68 % and 95 %),
/// the median of |error| / sigma (a Gaussian: 0.674), and how well sigma
/// ranks the errors: the sparsification ratio with the smallest sigma taken
/// as the most confident (what a node weighting by 1 / variance relies on).
struct VarianceCalibration {
  double within1 = 0, within2 = 0, median_ratio = 0, ranking_ratio = 0;
  size_t samples = 0;
};
VarianceCalibration calibrateVariance(const EstimateSamples& samples);

/// Sequences without ground truth: along the border of the rectified view.
/// Per row, the estimates within `strip_px` of either end of the left
/// image's valid (non-black) span, against the median of the estimates
/// between `reference_from` and `reference_to` px in from that end; an
/// estimate more than `tolerance_px` from it is an outlier. Rows whose
/// reference holds no estimate are left out.
struct BorderStripScore {
  double estimates = 0, outliers = 0;
  double rate() const { return estimates > 0 ? outliers / estimates : 0.0; }
  void add(const BorderStripScore& o) {
    estimates += o.estimates;
    outliers += o.outliers;
  }
};
BorderStripScore scoreBorderStrips(const cv::Mat& disparity, const cv::Mat& left, int strip_px = 12,
                                   int reference_from = 12, int reference_to = 40, float tolerance_px = 3.f);

/// Density over the left image's valid (non-black) pixels.
double validPixelDensity(const cv::Mat& disparity, const cv::Mat& left);

}  // namespace bdis
