// Accuracy of the default preset on the real synthetic sequences of the shared
// data folder, scored exactly as its README defines. The bar is the authors'
// journal release as measured on our machines (docs/method.md, "Anchor
// numbers"): the default preset must match or beat it on every column at once.
// And its confidence as a ranking of the errors, and its variance as a
// standard deviation of them, against measured values.
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <string>

#include <gtest/gtest.h>

#include "bdis_stereo/error_analysis.hpp"
#include "bdis_stereo/evaluation.hpp"
#include "bdis_stereo/matcher.hpp"
#include "reliability_report.hpp"

namespace {

struct JournalBar {
  const char* sequence;
  double min_density, max_median, max_bad2, max_miss_or_bad2;
};

bool underCi() {
  const char* ci = std::getenv("CI");
  return ci && std::string(ci) == "true";
}

/// A test on a sequence of the shared data folder: skipped without the
/// folder, failed under CI.
template <typename Bar>
class OnSharedData : public ::testing::TestWithParam<Bar> {
 protected:
  void SetUp() override {
    data_ = bdis::findDataDir();
    if (data_.empty()) {
      if (underCi()) FAIL() << "CI=true but the shared data folder was not found (set BDIS_DATA_DIR)";
      GTEST_SKIP() << "shared data folder not found; set BDIS_DATA_DIR";
    }
  }
  /// Runs `params` (the balanced preset unless given) over every frame of
  /// `sequence` (with ground truth) and hands each frame's left image, ground
  /// truth and result to `use`.
  template <typename Use>
  void matchEveryFrame(const char* sequence, Use&& use,
                       const bdis::MatcherParams& params = bdis::MatcherParams::preset("balanced"),
                       const bdis::MatchOutputs& outputs = {}) const {
    const bdis::StereoSequence seq = bdis::StereoSequence::open(data_ + "/" + sequence);
    ASSERT_TRUE(seq.has_ground_truth);
    bdis::Matcher matcher(params);
    bdis::MatchResult result;
    for (size_t i = 0; i < seq.names.size(); ++i) {
      const cv::Mat left = seq.left(i);
      matcher.compute(left, seq.right(i), result, outputs);
      use(left, seq.groundTruth(i), result);
    }
  }
  std::string data_;
};

class DefaultPresetAccuracy : public OnSharedData<JournalBar> {};

TEST_P(DefaultPresetAccuracy, MatchesOrBeatsJournalReleaseOnEveryColumn) {
  const JournalBar bar = GetParam();
  bdis::DisparityScore score;
  ASSERT_NO_FATAL_FAILURE(matchEveryFrame(bar.sequence, [&](const cv::Mat& left, const cv::Mat& gt,
                                                            const bdis::MatchResult& result) {
    score.add(bdis::scoreDisparity(result.disparity, gt, left));
  }));
  RecordProperty("density", std::to_string(score.density()));
  RecordProperty("median_error", std::to_string(score.medianError()));
  RecordProperty("bad2", std::to_string(score.bad2Rate()));
  RecordProperty("miss_or_bad2", std::to_string(score.missOrBad2Rate()));
  std::printf("%s: density %.3f median %.3f mean %.3f bad2 %.1f%% miss_or_bad2 %.1f%%\n",
              bar.sequence, score.density(), score.medianError(), score.meanError(),
              100 * score.bad2Rate(), 100 * score.missOrBad2Rate());
  EXPECT_GE(score.density(), bar.min_density);
  EXPECT_LE(score.medianError(), bar.max_median);
  EXPECT_LE(score.bad2Rate(), bar.max_bad2);
  EXPECT_LE(score.missOrBad2Rate(), bar.max_miss_or_bad2);
}

INSTANTIATE_TEST_SUITE_P(
    SharedData, DefaultPresetAccuracy,
    ::testing::Values(JournalBar{"synthetic_colon_diffuse", 0.60, 0.54, 0.156, 0.498},
                      JournalBar{"synthetic_colon_specular", 0.56, 0.93, 0.247, 0.575}),
    [](const ::testing::TestParamInfo<JournalBar>& info) {
      return std::string(info.param.sequence);
    });

struct RankingBar {
  const char* sequence;
  double max_area, max_ratio, max_top50;
};

class DefaultPresetConfidence : public OnSharedData<RankingBar> {};

// bad2 falls with the confidence across its deciles, and the sparsification
// area, its ratio to the oracle's and the most confident half stay at the
// measured values: diffuse area 0.0188, 2.61 x the oracle's, 0.2 %;
// specular 0.0432, 3.05, 2.3 % (2.2 % before the blurred step cue and the
// calibration's refit; before the block grid cue's seam term
// 0.0442, 3.12, 2.3 %; before the lone edge factor of the slant cue 0.0463,
// 3.26, 2.8 %). The area is held as well as the ratio:
// mending wrong estimates the confidence already held low shrinks the
// oracle's area more than the confidence's, so the ratio can grow while
// every threshold keeps fewer wrong estimates.
TEST_P(DefaultPresetConfidence, RanksTheErrors) {
  const RankingBar bar = GetParam();
  bdis::EstimateSamples samples;
  ASSERT_NO_FATAL_FAILURE(matchEveryFrame(bar.sequence, [&](const cv::Mat& left, const cv::Mat& gt,
                                                            const bdis::MatchResult& result) {
    samples.add(result.disparity, gt, bdis::classifyPixels(gt, left), result.confidence, cv::Mat());
  }));
  const bdis::Sparsification s = bdis::sparsify(samples);
  std::printf("%s: sparsification area %.4f, %.2f x the oracle's, bad2 of the most confident 25 %% / 50 %%: "
              "%.1f %% / %.1f %%\n",
              bar.sequence, s.area, s.ratio(), 100 * s.bad2_top25, 100 * s.bad2_top50);
  EXPECT_TRUE(s.monotone());
  EXPECT_LE(s.area, bar.max_area);
  EXPECT_LE(s.ratio(), bar.max_ratio);
  EXPECT_LE(s.bad2_top50, bar.max_top50);
}

INSTANTIATE_TEST_SUITE_P(
    SharedData, DefaultPresetConfidence,
    ::testing::Values(RankingBar{"synthetic_colon_diffuse", 0.020, 2.65, 0.004},
                      RankingBar{"synthetic_colon_specular", 0.044, 3.10, 0.024}),
    [](const ::testing::TestParamInfo<RankingBar>& info) {
      return std::string(info.param.sequence);
    });

struct CalibrationBar {
  const char* sequence;
  const char* preset;
  double max_calibration_error;
};

class PresetCalibration : public OnSharedData<CalibrationBar> {};

// The published confidence says what share of estimates is within 2 px
// (the calibration was fitted on generated scenes only, so these frames
// check it): per confidence bin the share within 2 px against the bin's mean
// confidence, and their weighted mean difference. No bin holding 1 % of the
// estimates or more may claim more than it has by over 0.03: a node that
// trusts the confidence must not be misled towards the wrong depths.
// Measured: expected calibration error diffuse 0.056, specular 0.085, every
// bin at or below what it has (-0.003 at most; 0.063 / 0.092 before the
// blurred step cue and the tables refitted with it): the colon's errors are rarer
// than the generated scenes' at the same product, its textured tissue has
// more of the peaked gradients the slant cue's lone edge factor doubts, and
// its dark blocks, which the codec flattened, more of the block grid cue's
// seam term (before that term 0.060 / 0.079, before the lone edge factor
// 0.057 / 0.038). The table was fitted on balanced; the other presets, which
// a user switches to for speed or for offline work, keep it: fast 0.046 /
// 0.069, accurate 0.055 / 0.091, none claimed over.
TEST_P(PresetCalibration, SaysTheShareOfEstimatesWithinTwoPx) {
  const CalibrationBar bar = GetParam();
  const bdis::MatcherParams params = bdis::MatcherParams::preset(bar.preset);
  bdis::EstimateSamples samples;
  ASSERT_NO_FATAL_FAILURE(matchEveryFrame(bar.sequence, [&](const cv::Mat& left, const cv::Mat& gt,
                                                            const bdis::MatchResult& result) {
    samples.add(result.disparity, gt, bdis::classifyPixels(gt, left), result.confidence, cv::Mat());
  }, params));
  const bdis::Reliability r = bdis::reliability(samples);
  const std::string label = std::string(bar.sequence) + ", " + bar.preset;
  const double over_claim = bdis_test::reportReliability(label.c_str(), r);
  ASSERT_EQ(r.bins.size(), 8u);
  EXPECT_LE(r.expected_error, bar.max_calibration_error);
  EXPECT_LE(over_claim, 0.03);
}

INSTANTIATE_TEST_SUITE_P(
    SharedData, PresetCalibration,
    ::testing::Values(CalibrationBar{"synthetic_colon_diffuse", "balanced", 0.07},
                      CalibrationBar{"synthetic_colon_specular", "balanced", 0.095},
                      CalibrationBar{"synthetic_colon_diffuse", "fast", 0.06},
                      CalibrationBar{"synthetic_colon_specular", "fast", 0.08},
                      CalibrationBar{"synthetic_colon_diffuse", "accurate", 0.07},
                      CalibrationBar{"synthetic_colon_specular", "accurate", 0.10}),
    [](const ::testing::TestParamInfo<CalibrationBar>& info) {
      return std::string(info.param.sequence) + "_" + info.param.preset;
    });

struct VarianceBar {
  const char* sequence;
  double max_ranking_ratio;
};

class DefaultPresetVariance : public OnSharedData<VarianceBar> {};

// With compute_variance, sigma describes the errors as a standard deviation
// should (the bands a Gaussian's 68 % and 95 % sit in: 60-80 % within 1
// sigma, 90-98 % within 2) and ranks them nearly as the confidence does.
// Measured: diffuse 73.4 % / 93.4 %, ranking 2.61 x the oracle's; specular
// 79.8 % / 95.4 %, 3.06 (before the blurred step cue and the outlier term's
// refit 77.3 % / 95.0 % and 79.6 % / 95.8 %; without the outlier term 79 % /
// 93 % and 74 % / 91 %, but ranking 5.5 and 5.4).
TEST_P(DefaultPresetVariance, DescribesAndRanksTheErrors) {
  const VarianceBar bar = GetParam();
  bdis::MatcherParams params = bdis::MatcherParams::preset("balanced");
  params.compute_variance = true;
  bdis::EstimateSamples samples;
  bool confidence_released = true;
  // The node's way when only the variance is subscribed: the confidence is
  // computed for the variance but not published.
  ASSERT_NO_FATAL_FAILURE(matchEveryFrame(
      bar.sequence,
      [&](const cv::Mat& left, const cv::Mat& gt, const bdis::MatchResult& result) {
        confidence_released = confidence_released && result.confidence.empty();
        samples.add(result.disparity, gt, bdis::classifyPixels(gt, left), cv::Mat(), result.variance);
      },
      params, bdis::MatchOutputs{false, true}));
  const bdis::VarianceCalibration c = bdis::calibrateVariance(samples);
  std::printf("%s: %.1f %% of the errors within 1 sigma, %.1f %% within 2, median |e| / sigma %.3f, "
              "ranking %.2f x the oracle's\n",
              bar.sequence, 100 * c.within1, 100 * c.within2, c.median_ratio, c.ranking_ratio);
  EXPECT_TRUE(confidence_released);
  EXPECT_GE(c.within1, 0.60);
  EXPECT_LE(c.within1, 0.80);
  EXPECT_GE(c.within2, 0.90);
  EXPECT_LE(c.within2, 0.98);
  EXPECT_LE(c.ranking_ratio, bar.max_ranking_ratio);
}

INSTANTIATE_TEST_SUITE_P(
    SharedData, DefaultPresetVariance,
    ::testing::Values(VarianceBar{"synthetic_colon_diffuse", 2.70}, VarianceBar{"synthetic_colon_specular", 3.25}),
    [](const ::testing::TestParamInfo<VarianceBar>& info) {
      return std::string(info.param.sequence);
    });

struct ThresholdBar {
  const char* sequence;
  float min_confidence;
  double min_density, max_bad2;
};

class DefaultPresetMinConfidence : public OnSharedData<ThresholdBar> {};

// min_confidence publishes what the README's threshold table promises for
// it: measured with the setting at 0.7, diffuse 0.490 density at 2.1 %
// bad2, specular 0.346 at 3.3 %; at 0.95, 0.354 / 0.27 % and 0.191 / 0.46 %.
TEST_P(DefaultPresetMinConfidence, KeepsTheThresholdTablesDensityAndBad2) {
  const ThresholdBar bar = GetParam();
  bdis::MatcherParams params = bdis::MatcherParams::preset("balanced");
  params.min_confidence = bar.min_confidence;
  bdis::DisparityScore score;
  // The node's way when nobody subscribes to the confidence: it still decides.
  ASSERT_NO_FATAL_FAILURE(matchEveryFrame(
      bar.sequence,
      [&](const cv::Mat& left, const cv::Mat& gt, const bdis::MatchResult& result) {
        score.add(bdis::scoreDisparity(result.disparity, gt, left));
      },
      params, bdis::MatchOutputs{false, false}));
  std::printf("%s, min_confidence %g: density %.3f bad2 %.2f%%\n", bar.sequence, bar.min_confidence,
              score.density(), 100 * score.bad2Rate());
  EXPECT_GE(score.density(), bar.min_density);
  EXPECT_LE(score.bad2Rate(), bar.max_bad2);
}

INSTANTIATE_TEST_SUITE_P(
    SharedData, DefaultPresetMinConfidence,
    ::testing::Values(ThresholdBar{"synthetic_colon_diffuse", 0.7f, 0.470, 0.030},
                      ThresholdBar{"synthetic_colon_specular", 0.7f, 0.335, 0.040},
                      ThresholdBar{"synthetic_colon_diffuse", 0.95f, 0.335, 0.005},
                      ThresholdBar{"synthetic_colon_specular", 0.95f, 0.185, 0.008}),
    [](const ::testing::TestParamInfo<ThresholdBar>& info) {
      // The threshold as printed, with what a test name may not hold as '_'.
      char threshold[32];
      std::snprintf(threshold, sizeof threshold, "%g", static_cast<double>(info.param.min_confidence));
      std::string name = std::string(info.param.sequence) + "_" + threshold;
      for (char& c : name) c = std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
      return name;
    });

}  // namespace
