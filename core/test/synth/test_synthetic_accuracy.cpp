// Accuracy of the matcher (default parameters) on generated scenes with exact
// ground truth, one difficulty each, scored as the data README defines, plus
// the behaviour each difficulty calls for. Frames 0, 5 and 10 of each variant
// at 640x480. Thresholds sit a modest margin beyond the values measured when
// they were set (in the comments: BDIS / OpenCV DIS fast on the same frames);
// DIS fast is printed alongside for the README, not asserted.
// Part of test_synth (it needs the generator).
#include <gtest/gtest.h>

#include "bdis_stereo/evaluation.hpp"
#include "bdis_stereo/matcher.hpp"
#include "synth_test_util.hpp"

#include <functional>
#include <iterator>
#include <map>
#include <string>
#include <vector>

namespace {

using namespace synth_test;

const int kFrames[] = {0, 5, 10};

/// Matcher results of the frames of a variant, computed once per process.
struct MatcherRun {
  std::vector<const SyntheticFrame*> frames;
  std::vector<bdis::MatchResult> results;
};

const MatcherRun& bdisRun(const std::string& name) {
  static std::map<std::string, MatcherRun> runs;
  auto it = runs.find(name);
  if (it != runs.end()) return it->second;
  MatcherRun& run = runs[name];
  cv::setNumThreads(1);
  bdis::Matcher matcher;  // default parameters
  for (int i : kFrames) {
    const SyntheticFrame& f = cachedFrame(variant(name), i);
    run.frames.push_back(&f);
    run.results.emplace_back();
    matcher.compute(f.left, f.right, run.results.back());
  }
  return run;
}

struct Bar {
  const char* variant;
  double min_density, max_median, max_bad2, max_miss_or_bad2;
};

class SyntheticAccuracy : public ::testing::TestWithParam<Bar> {};

TEST_P(SyntheticAccuracy, DefaultParamsMeetTheMeasuredBar) {
  const Bar bar = GetParam();
  const MatcherRun& run = bdisRun(bar.variant);
  bdis::DisparityScore bdis_score, dis_score;
  for (size_t k = 0; k < run.frames.size(); ++k) {
    const SyntheticFrame& f = *run.frames[k];
    bdis_score.add(bdis::scoreDisparity(run.results[k].disparity, f.gt, f.left));
    dis_score.add(bdis::scoreDisparity(disFastDisparity(f.left, f.right), f.gt, f.left));
  }
  std::printf("%s:\n", bar.variant);
  printScore("bdis (default params)", bdis_score);
  printScore("OpenCV DIS fast", dis_score);
  RecordProperty("density", std::to_string(bdis_score.density()));
  RecordProperty("median_error", std::to_string(bdis_score.medianError()));
  RecordProperty("bad2", std::to_string(bdis_score.bad2Rate()));
  RecordProperty("miss_or_bad2", std::to_string(bdis_score.missOrBad2Rate()));
  EXPECT_GE(bdis_score.density(), bar.min_density);
  EXPECT_LE(bdis_score.medianError(), bar.max_median);
  EXPECT_LE(bdis_score.bad2Rate(), bar.max_bad2);
  EXPECT_LE(bdis_score.missOrBad2Rate(), bar.max_miss_or_bad2);
}

// Measured when set (density / median px / bad2 / miss_or_bad2), BDIS with
// default parameters and, for reference, OpenCV DIS fast:
//   diffuse         bdis 0.964 / 0.161 /  2.1% /  5.6%   dis_fast 1.000 / 0.177 /  1.7% /  1.7%
//   specular        bdis 0.965 / 0.122 /  2.6% /  6.0%   dis_fast 1.000 / 0.211 /  3.6% /  3.6%
//   dark_periphery  bdis 0.774 / 0.421 / 14.5% / 33.8%   dis_fast 1.000 / 0.407 / 10.7% / 10.7%
//   textureless     bdis 0.958 / 0.165 /  2.4% /  6.5%   dis_fast 1.000 / 0.182 /  1.6% /  1.6%
//   instrument      bdis 0.954 / 0.137 /  6.0% / 10.3%   dis_fast 1.000 / 0.247 / 11.5% / 11.5%
//   tube            bdis 0.891 / 0.507 / 12.1% / 21.7%   dis_fast 0.989 / 0.924 / 29.1% / 29.9%
INSTANTIATE_TEST_SUITE_P(
    Generated, SyntheticAccuracy,
    ::testing::Values(Bar{"diffuse", 0.94, 0.20, 0.030, 0.075},         //
                      Bar{"specular", 0.94, 0.16, 0.035, 0.080},        //
                      Bar{"dark_periphery", 0.74, 0.48, 0.165, 0.37},   //
                      Bar{"textureless", 0.93, 0.20, 0.033, 0.085},     //
                      Bar{"instrument", 0.93, 0.17, 0.070, 0.125},      //
                      Bar{"tube", 0.86, 0.57, 0.14, 0.245}),            //
    [](const ::testing::TestParamInfo<Bar>& info) { return std::string(info.param.variant); });

/// Per-region tallies of the matcher's output against ground truth.
struct RegionStats {
  long pixels = 0;            // with ground truth
  long estimated = 0;
  long confident = 0;         // confidence >= kConfident
  long confident_bad2 = 0;    // ... and off by more than 2 px
  double confidence_sum = 0;  // over pixels with ground truth
  double meanConfidence() const { return pixels ? confidence_sum / pixels : 0.0; }
  double share(long n) const { return pixels ? static_cast<double>(n) / pixels : 0.0; }
};

constexpr float kConfident = 0.5f;

RegionStats regionStats(const MatcherRun& run, const std::function<cv::Mat(const SyntheticFrame&)>& region) {
  RegionStats s;
  for (size_t k = 0; k < run.frames.size(); ++k) {
    const SyntheticFrame& f = *run.frames[k];
    const bdis::MatchResult& r = run.results[k];
    const cv::Mat mask = region(f);
    for (int y = 0; y < f.gt.rows; ++y) {
      for (int x = 0; x < f.gt.cols; ++x) {
        const float g = f.gt.at<float>(y, x);
        if (!mask.at<uchar>(y, x) || !(g > 0.f)) continue;
        ++s.pixels;
        const float d = r.disparity.at<float>(y, x), c = r.confidence.at<float>(y, x);
        s.confidence_sum += c;
        if (!(d >= 0.f)) continue;
        ++s.estimated;
        if (c >= kConfident) {
          ++s.confident;
          if (std::fabs(d - g) > 2.f) ++s.confident_bad2;
        }
      }
    }
  }
  return s;
}

void print(const char* what, const RegionStats& s) {
  std::printf("  %-30s %7ld px  estimated %5.1f%%  confident %5.1f%%  confident & bad2 %5.2f%%  mean confidence %.3f\n",
              what, s.pixels, 100 * s.share(s.estimated), 100 * s.share(s.confident), 100 * s.share(s.confident_bad2),
              s.meanConfidence());
}

TEST(SyntheticBehaviour, TexturelessPatchGetsLowConfidenceNotConfidentWrongDepth) {
  // Inside the albedo-flat disk (eroded by 10 px, so no patch reaches its
  // textured rim) a matcher can only guess. Measured: 63% estimated, 0.0%
  // with confidence >= 0.5, mean confidence 0.023 vs 0.43 on the rest.
  const MatcherRun& run = bdisRun("textureless");
  const RegionStats patch = regionStats(run, [](const SyntheticFrame& f) {
    cv::Mat m;
    cv::erode(f.textureless, m, cv::Mat(), cv::Point(-1, -1), 10);
    return m;
  });
  const RegionStats rest = regionStats(run, [](const SyntheticFrame& f) {
    cv::Mat m;
    cv::dilate(f.textureless, m, cv::Mat(), cv::Point(-1, -1), 20);
    return m == 0;
  });
  print("textureless patch", patch);
  print("rest of the tissue", rest);
  EXPECT_GT(patch.pixels, 20000);
  EXPECT_LE(patch.share(patch.confident), 0.01);
  EXPECT_LE(patch.share(patch.confident_bad2), 0.005);
  EXPECT_LT(patch.meanConfidence(), 0.2 * rest.meanConfidence());
}

TEST(SyntheticBehaviour, InstrumentBoundaryHasFewConfidentOutliers) {
  // Bands of 12 px on either side of the instrument's outline (tissue next to
  // it, where foreground fattening strikes, and the instrument's rim).
  // Measured: confident (>= 0.5) and off by > 2 px on 13.7% of the tissue
  // band and 8.7% of the rim, 0.00% on tissue farther away. That is a known
  // weakness of the matcher (a wrong depth next to a tool should be a missing
  // one); these bars only hold it from getting worse.
  const MatcherRun& run = bdisRun("instrument");
  auto band = [](const SyntheticFrame& f, bool tissue_side) {
    const cv::Mat inst = f.label == bdis::synth::kLabelInstrument;
    cv::Mat grown, shrunk;
    cv::dilate(inst, grown, cv::Mat(), cv::Point(-1, -1), 12);
    cv::erode(inst, shrunk, cv::Mat(), cv::Point(-1, -1), 12);
    return tissue_side ? (grown & ~inst) : (inst & ~shrunk);
  };
  const RegionStats tissue = regionStats(run, [&](const SyntheticFrame& f) { return band(f, true); });
  const RegionStats rim = regionStats(run, [&](const SyntheticFrame& f) { return band(f, false); });
  const RegionStats away = regionStats(run, [](const SyntheticFrame& f) {
    cv::Mat grown;
    cv::dilate(f.label == bdis::synth::kLabelInstrument, grown, cv::Mat(), cv::Point(-1, -1), 24);
    return grown == 0;
  });
  print("tissue within 12 px of the tool", tissue);
  print("tool rim (12 px)", rim);
  print("tissue farther than 24 px", away);
  EXPECT_GT(tissue.pixels, 10000);
  EXPECT_LE(tissue.share(tissue.confident_bad2), 0.16);
  EXPECT_LE(rim.share(rim.confident_bad2), 0.105);
  EXPECT_LE(away.share(away.confident_bad2), 0.002);
}

TEST(SyntheticBehaviour, DarkPeripheryLowersConfidenceRatherThanGuessing) {
  // Pixels whose grey level is below 40 (the periphery under a narrow beam)
  // vs the lit middle (above 80). Measured: mean confidence 0.11 vs 0.38;
  // 8% confident in the dark, none of them off by > 2 px.
  const MatcherRun& run = bdisRun("dark_periphery");
  const RegionStats dark = regionStats(run, [](const SyntheticFrame& f) { return grey(f.left) < 40; });
  const RegionStats lit = regionStats(run, [](const SyntheticFrame& f) { return grey(f.left) > 80; });
  print("dark periphery (< 40)", dark);
  print("lit middle (> 80)", lit);
  EXPECT_GT(dark.pixels, 100000);
  EXPECT_LT(dark.meanConfidence(), 0.5 * lit.meanConfidence());
  EXPECT_LE(dark.share(dark.confident_bad2), 0.005);
}

TEST(SyntheticBehaviour, SpecularHighlightsDoNotPullConfidentDepths) {
  // Highlight pixels (specular radiance >= 0.1 of saturation in either view)
  // of the specular variant. Measured: 82% confident, 0.83% confident and off
  // by > 2 px.
  const MatcherRun& run = bdisRun("specular");
  const RegionStats hl = regionStats(run, [](const SyntheticFrame& f) {
    const cv::Mat right = warpRightToLeft(f.specular_right, f.gt);
    return (f.specular_left >= 0.1f) | (right >= 0.1f);
  });
  print("highlights", hl);
  EXPECT_GT(hl.pixels, 30000);
  EXPECT_LE(hl.share(hl.confident_bad2), 0.015);
}

TEST(SearchBands, DefaultBandsScoreAsTheWholeLevelSearch) {
  // The finest level searched per band of 8 patch rows (the default) against
  // both passes over the whole level at once (0, as DIS): the bands change
  // which neighbours the backward pass offers at their bottom edges, not the
  // scores. Measured (density / median px / bad2), whole level against bands
  // of 8: diffuse 0.958 / 0.154 / 1.5 % against 0.956 / 0.154 / 1.3 %,
  // instrument 0.943 / 0.133 / 5.1 % against 0.943 / 0.133 / 5.0 %, tube
  // 0.880 / 0.496 / 11.2 % against 0.880 / 0.495 / 11.2 %. One-row bands (1:
  // no lower neighbour at all) are printed beside them: they miss the
  // tolerances below on diffuse (density -0.007), instrument (-0.005) and tube
  // (bad2 +0.4 %), so the tolerances can tell a cut propagation.
  for (const char* name : {"diffuse", "instrument", "tube"}) {
    std::printf("%s:\n", name);
    // The whole-level search's disparities, once per frame, as the reference.
    std::vector<cv::Mat> whole_disparity;
    bdis::MatcherParams whole_params;
    whole_params.search_band_rows = 0;
    bdis::Matcher whole_matcher(whole_params);
    for (int i : kFrames) {
      const SyntheticFrame& f = cachedFrame(variant(name), i);
      bdis::MatchResult r;
      whole_matcher.compute(f.left, f.right, r);
      whole_disparity.push_back(r.disparity);
    }
    std::map<int, bdis::DisparityScore> scores;
    std::map<int, long> differing_pixels;  // from the whole-level search
    for (const int band_rows : {0, 8, 1}) {
      bdis::MatcherParams params;
      params.search_band_rows = band_rows;
      bdis::Matcher matcher(params);
      for (size_t k = 0; k < std::size(kFrames); ++k) {
        const SyntheticFrame& f = cachedFrame(variant(name), kFrames[k]);
        bdis::MatchResult r;
        matcher.compute(f.left, f.right, r);
        scores[band_rows].add(bdis::scoreDisparity(r.disparity, f.gt, f.left));
        cv::Mat differ;
        cv::compare(r.disparity, whole_disparity[k], differ, cv::CMP_NE);
        differing_pixels[band_rows] += cv::countNonZero(differ);
      }
      printScore(("search_band_rows " + std::to_string(band_rows)).c_str(), scores[band_rows]);
      std::printf("    differs from the whole-level search in %ld px\n", differing_pixels[band_rows]);
    }
    EXPECT_EQ(differing_pixels[0], 0) << name;  // same parameters, same result
    // The default is in effect: the band edges change some patches.
    EXPECT_GT(differing_pixels[8], 1000) << name;
    const bdis::DisparityScore& whole = scores[0];
    const bdis::DisparityScore& banded = scores[8];
    EXPECT_NEAR(banded.density(), whole.density(), 0.004) << name;
    EXPECT_LE(banded.medianError(), whole.medianError() + 0.003) << name;
    EXPECT_LE(banded.bad2Rate(), whole.bad2Rate() + 0.001) << name;
  }
}
}  // namespace
