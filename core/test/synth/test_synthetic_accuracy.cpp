// Accuracy of the matcher (default parameters) on generated scenes with exact
// ground truth, one difficulty each, scored as the data README defines, plus
// the behaviour each difficulty calls for. Frames 0, 5 and 10 of each variant
// at 640x480. Thresholds sit a modest margin beyond the values measured when
// they were set (in the comments: BDIS / OpenCV DIS fast on the same frames);
// DIS fast is printed alongside, and asserted only where a variant's bar says so.
// Part of test_synth (it needs the generator).
#include <gtest/gtest.h>

#include "bdis_stereo/error_analysis.hpp"
#include "bdis_stereo/evaluation.hpp"
#include "bdis_stereo/matcher.hpp"
#include "cues_product_params.hpp"
#include "reliability_report.hpp"
#include "synth_test_util.hpp"

#include <functional>
#include <iterator>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace {

using namespace synth_test;

const int kFrames[] = {0, 5, 10};

/// Matcher results of the frames of a variant (default parameters unless
/// given), computed once per process.
struct MatcherRun {
  std::vector<const SyntheticFrame*> frames;
  std::vector<bdis::MatchResult> results;
};

const MatcherRun& bdisRun(const SceneConfig& config, const bdis::MatcherParams& params = {}) {
  static std::map<std::string, MatcherRun> runs;
  const std::string key = configKey(config) + "\n" + bdis::toYaml(params);
  auto it = runs.find(key);
  if (it != runs.end()) return it->second;
  MatcherRun& run = runs[key];
  cv::setNumThreads(1);
  bdis::Matcher matcher(params);
  for (int i : kFrames) {
    const SyntheticFrame& f = cachedFrame(config, i);
    run.frames.push_back(&f);
    run.results.emplace_back();
    matcher.compute(f.left, f.right, run.results.back());
  }
  return run;
}

// The region tests below set "confident" (kConfident) on the cues' product,
// and check what the published confidence (a probability of being within
// 2 px) claims in the same regions; PublishedConfidenceSaysTheShareWithinTwoPx
// checks it over whole frames.
const MatcherRun& bdisRun(const std::string& name) {
  return bdisRun(variant(name), bdis_test::cuesProductParams());
}


struct Bar {
  const char* variant;
  double min_density, max_median, max_bad2, max_miss_or_bad2;
  bool bad2_at_most_dis_fast = false;  ///< fewer outliers than OpenCV DIS fast on the same frames
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
  if (bar.bad2_at_most_dis_fast) {
    EXPECT_LE(bdis_score.bad2Rate(), dis_score.bad2Rate());
  }
}

// Measured when set (density / median px / bad2 / miss_or_bad2), BDIS with
// default parameters and, for reference, OpenCV DIS fast. Clipped highlights
// (grey 255) are left out since: specular and instrument lost 2-3 points of
// density there and more than half their outliers (2.1 -> 0.9 %, 5.1 -> 4.0 %).
// One Gauss-Newton step per patch, one refinement step; the posterior
// window's samples 2 level px apart and the floor at 0.0175 since (in
// brackets the density / bad2 / miss_or_bad2 with the samples 1 px apart and
// the floor at 0.0075):
//   diffuse         bdis 0.965 / 0.133 /  0.6% /  4.0%   (0.961 /  0.5% /  4.4%)   dis_fast 1.000 / 0.177 /  1.7% /  1.7%
//   specular        bdis 0.951 / 0.104 /  0.6% /  5.5%   (0.943 /  0.4% /  6.1%)   dis_fast 1.000 / 0.211 /  3.6% /  3.6%
//   dark_periphery  bdis 0.769 / 0.281 /  4.8% / 26.8%   (0.779 /  5.5% / 26.4%)   dis_fast 1.000 / 0.407 / 10.7% / 10.7%
//   textureless     bdis 0.958 / 0.137 /  0.7% /  4.9%   (0.956 /  0.8% /  5.1%)   dis_fast 1.000 / 0.182 /  1.6% /  1.6%
//   instrument      bdis 0.927 / 0.114 /  3.4% / 10.5%   (0.919 /  3.1% / 10.9%)   dis_fast 1.000 / 0.247 / 11.5% / 11.5%
//   tube            bdis 0.900 / 0.429 /  9.8% / 18.8%   (0.869 /  9.7% / 21.5%)   dis_fast 0.989 / 0.924 / 29.1% / 29.9%
//   dark_tube       bdis 0.714 / 0.762 / 21.7% / 44.1%   (0.694 / 22.2% / 46.0%)   dis_fast 1.000 / 1.944 / 49.3% / 49.3%
//   compressed_dark bdis 0.765 / 0.475 / 13.9% / 34.1%                           dis_fast 1.000 / 0.469 / 10.8% / 10.8%
// dark_tube is the colon-like failure class, the near wall at a grazing angle
// in the dark: its bar holds what it scores, no better than that. So is
// compressed_dark, the dark periphery as JPEG at quality 75: the codec
// removes most of the dark texture the finest searched level relies on, and
// there BDIS publishes more outliers than DIS fast, which searches a level
// coarser (a known gap, docs/method.md "Compressed frames").
// The dark periphery is the variant where a guess is most tempting: there
// BDIS must publish fewer outliers than DIS fast, which publishes everything.
INSTANTIATE_TEST_SUITE_P(
    Generated, SyntheticAccuracy,
    ::testing::Values(Bar{"diffuse", 0.94, 0.17, 0.010, 0.060},              //
                      Bar{"specular", 0.93, 0.13, 0.008, 0.075},             //
                      Bar{"dark_periphery", 0.75, 0.34, 0.070, 0.30, true},  //
                      Bar{"textureless", 0.93, 0.17, 0.015, 0.070},          //
                      Bar{"instrument", 0.90, 0.14, 0.040, 0.125},           //
                      Bar{"tube", 0.88, 0.50, 0.11, 0.21},                   //
                      Bar{"dark_tube", 0.69, 0.85, 0.24, 0.46, true},        //
                      Bar{"compressed_dark", 0.74, 0.55, 0.16, 0.37}),       //
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
  /// Of the confident estimates, the share off by more than 2 px.
  double wrongAmongConfident() const { return confident ? static_cast<double>(confident_bad2) / confident : 0.0; }
};

constexpr float kConfident = 0.5f;

RegionStats regionStats(const MatcherRun& run, const std::function<cv::Mat(const SyntheticFrame&)>& region,
                        float confident = kConfident) {
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
        if (c >= confident) {
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

/// The same frames with the confidence as published: the probability of
/// being within 2 px.
const MatcherRun& publishedRun(const std::string& name) { return bdisRun(variant(name)); }

/// What a consumer acting on the published confidence gets in a region: the
/// share of it wrong at 0.5 and at 0.9 or more.
struct PublishedRegionStats {
  RegionStats at_half, at_nine_tenths;
};
PublishedRegionStats publishedRegionStats(const std::string& name,
                                          const std::function<cv::Mat(const SyntheticFrame&)>& region) {
  return {regionStats(publishedRun(name), region, 0.5f), regionStats(publishedRun(name), region, 0.9f)};
}

void printPublished(const char* what, const PublishedRegionStats& s) {
  std::printf("  published, %-19s %7ld px  estimated %5.1f%%  >= 0.5 %5.1f%%, and wrong %5.2f%%  >= 0.9 %5.1f%%, "
              "and wrong %5.2f%%  mean confidence %.3f\n",
              what, s.at_half.pixels, 100 * s.at_half.share(s.at_half.estimated),
              100 * s.at_half.share(s.at_half.confident), 100 * s.at_half.share(s.at_half.confident_bad2),
              100 * s.at_nine_tenths.share(s.at_nine_tenths.confident),
              100 * s.at_nine_tenths.share(s.at_nine_tenths.confident_bad2), s.at_half.meanConfidence());
}

TEST(SyntheticBehaviour, TexturelessPatchGetsLowConfidenceNotConfidentWrongDepth) {
  // Inside the albedo-flat disk (eroded by 10 px, so no patch reaches its
  // textured rim) a matcher can only guess. Measured on the cues' product:
  // 60% estimated, 0.0% with confidence >= 0.5, mean confidence 0.002 vs
  // 0.243 on the rest. Published (a probability of being within 2 px): every
  // estimate at 0.5 or more, 5.05% of the disk wrong there; 37.2% of it at
  // 0.9 or more, of which 2.4% are wrong.
  const MatcherRun& run = bdisRun("textureless");
  const auto disk = [](const SyntheticFrame& f) {
    cv::Mat m;
    cv::erode(f.textureless, m, cv::Mat(), cv::Point(-1, -1), 10);
    return m;
  };
  const RegionStats patch = regionStats(run, disk);
  const RegionStats rest = regionStats(run, [](const SyntheticFrame& f) {
    cv::Mat m;
    cv::dilate(f.textureless, m, cv::Mat(), cv::Point(-1, -1), 20);
    return m == 0;
  });
  print("textureless patch", patch);
  print("rest of the tissue", rest);
  const PublishedRegionStats published_patch = publishedRegionStats("textureless", disk);
  printPublished("textureless patch", published_patch);
  EXPECT_GT(published_patch.at_nine_tenths.confident, 0);
  EXPECT_LE(published_patch.at_nine_tenths.wrongAmongConfident(), 0.1);  // what 0.9 claims
  EXPECT_GT(patch.pixels, 20000);
  EXPECT_LE(patch.share(patch.confident), 0.01);
  EXPECT_LE(patch.share(patch.confident_bad2), 0.005);
  EXPECT_LT(patch.meanConfidence(), 0.2 * rest.meanConfidence());
}

/// The 12 px band on either side of a frame's instrument outline: the tissue
/// next to it (where foreground fattening strikes) or the instrument's rim.
cv::Mat instrumentBand(const SyntheticFrame& f, bool tissue_side) {
  const cv::Mat inst = f.label == bdis::synth::kLabelInstrument;
  cv::Mat grown, shrunk;
  cv::dilate(inst, grown, cv::Mat(), cv::Point(-1, -1), 12);
  cv::erode(inst, shrunk, cv::Mat(), cv::Point(-1, -1), 12);
  return tissue_side ? (grown & ~inst) : (inst & ~shrunk);
}

TEST(SyntheticBehaviour, InstrumentBoundaryHasFewConfidentOutliers) {
  // Bands of 12 px on either side of the instrument's outline (tissue next to
  // it, where foreground fattening strikes, and the instrument's rim).
  // Measured on the cues' product: confident (>= 0.5) and off by > 2 px on
  // 0.00% of the tissue band, of the rim and of the tissue farther away
  // (nothing in the bands reaches 0.5 on that scale). Before the confidence
  // took the covering patches' disagreement and the left-right difference
  // into account: 13.7% and 8.7%, the fattened band among the frame's most
  // confident pixels; with those cues and before the slant cue: 0.45% and
  // 0.74%. Published: wrong at 0.5 or more on 0.45% of the tissue band and
  // 0.74% of the rim (the target is 3%; the bar here 0.85%), none of the few
  // at 0.9 or more wrong; 0.29% and 0.61% before the blurred step cue, whose
  // refitted calibration lifts more of the bands' estimates above 0.5 (24%
  // and 17% of them now, 98% and 96% of those right); 0.66% and 0.77%
  // before the slant cue's lone edge factor, 1.12% and 1.75% before the
  // refinement's smoothness was cut at image edges, 2.24% and 2.20% before
  // the support weights were on in balanced.
  const MatcherRun& run = bdisRun("instrument");
  auto band = instrumentBand;
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
  const PublishedRegionStats published_tissue =
      publishedRegionStats("instrument", [&](const SyntheticFrame& f) { return band(f, true); });
  const PublishedRegionStats published_rim =
      publishedRegionStats("instrument", [&](const SyntheticFrame& f) { return band(f, false); });
  printPublished("tissue within 12 px", published_tissue);
  printPublished("tool rim", published_rim);
  for (const PublishedRegionStats* b : {&published_tissue, &published_rim}) {
    EXPECT_LE(b->at_half.share(b->at_half.confident_bad2), 0.0085);
    EXPECT_LE(b->at_nine_tenths.wrongAmongConfident(), 0.1);
  }
  EXPECT_GT(tissue.pixels, 10000);
  EXPECT_LE(tissue.share(tissue.confident_bad2), 0.005);
  EXPECT_LE(rim.share(rim.confident_bad2), 0.005);
  EXPECT_LE(away.share(away.confident_bad2), 0.002);

  // bdis_eval scores the same bands (scoreInstrumentBands) from the same pixels.
  const MatcherRun& published = bdisRun(variant("instrument"));
  bdis::InstrumentBandScore bands;
  for (size_t k = 0; k < published.frames.size(); ++k) {
    const SyntheticFrame& f = *published.frames[k];
    const bdis::MatchResult& r = published.results[k];
    bands.add(bdis::scoreInstrumentBands(r.disparity, f.gt, bdis::classifyPixels(f.gt, f.left), f.label,
                                         r.confidence));
  }
  EXPECT_EQ(bands.tissue.scorable, published_tissue.at_half.pixels);
  EXPECT_EQ(bands.tissue.confident_bad2, published_tissue.at_half.confident_bad2);
  EXPECT_EQ(bands.rim.scorable, published_rim.at_half.pixels);
  EXPECT_EQ(bands.rim.confident_bad2, published_rim.at_half.confident_bad2);
}

TEST(SyntheticBehaviour, InstrumentBoundaryInTheDarkHasFewerConfidentOutliers) {
  // dark_tube: the instrument and the tissue behind it at 9 and 16 grey
  // levels, an edge of a few grey levels that the lit thresholds of the
  // support weights do not see; scaled with the centre's grey level they
  // do. The shaft's near-black pixels (grey below dark_floor_grey, 10) are
  // left out like black ones: on them a patch matched the tissue's texture
  // beside the shaft, at the tissue's depth. Published, wrong at 0.5 or
  // more: 2.74% of the tissue band and 0.88% of the rim (0.00% at 0.9 or
  // more); 2.81% and 0.97% before the support cue counted the shaft's
  // near-black pixels as holes; 8.38% and 14.34% (0.21% and 1.81%) with
  // dark_floor_grey 0;
  // 7.32% and 13.08% before the blurred step cue's refitted calibration
  // lifted more of them above 0.5; with the lit thresholds of the weights
  // in the dark too, 20.32% and 18.54% (before the refinement's smoothness
  // was cut at image edges and the slant cue's lone edge factor).
  const PublishedRegionStats tissue =
      publishedRegionStats("dark_tube", [](const SyntheticFrame& f) { return instrumentBand(f, true); });
  const PublishedRegionStats rim =
      publishedRegionStats("dark_tube", [](const SyntheticFrame& f) { return instrumentBand(f, false); });
  printPublished("dark_tube: tissue within 12 px", tissue);
  printPublished("dark_tube: tool rim", rim);
  EXPECT_GT(tissue.at_half.pixels, 5000);
  EXPECT_LE(tissue.at_half.share(tissue.at_half.confident_bad2), 0.035);
  EXPECT_LE(rim.at_half.share(rim.at_half.confident_bad2), 0.02);
}

TEST(SyntheticBehaviour, DarkPeripheryLowersConfidenceRatherThanGuessing) {
  // Pixels whose grey level is below 40 (the periphery under a narrow beam)
  // vs the lit middle (above 80). Measured on the cues' product: mean
  // confidence 0.042 vs 0.191; 1.1% confident in the dark, none of them off
  // by > 2 px. Published: mean 0.595 vs 0.978; in the dark 3.61% of the
  // pixels wrong at 0.5 or more, 46.2% at 0.9 or more with 0.45% of those
  // wrong.
  const MatcherRun& run = bdisRun("dark_periphery");
  const RegionStats dark = regionStats(run, [](const SyntheticFrame& f) { return grey(f.left) < 40; });
  const RegionStats lit = regionStats(run, [](const SyntheticFrame& f) { return grey(f.left) > 80; });
  print("dark periphery (< 40)", dark);
  print("lit middle (> 80)", lit);
  const PublishedRegionStats published_dark =
      publishedRegionStats("dark_periphery", [](const SyntheticFrame& f) { return grey(f.left) < 40; });
  const PublishedRegionStats published_lit =
      publishedRegionStats("dark_periphery", [](const SyntheticFrame& f) { return grey(f.left) > 80; });
  printPublished("dark periphery", published_dark);
  printPublished("lit middle", published_lit);
  EXPECT_LE(published_dark.at_half.share(published_dark.at_half.confident_bad2), 0.05);
  EXPECT_LE(published_dark.at_nine_tenths.wrongAmongConfident(), 0.1);
  EXPECT_LT(published_dark.at_half.meanConfidence(), published_lit.at_half.meanConfidence());
  EXPECT_GT(dark.pixels, 100000);
  EXPECT_LT(dark.meanConfidence(), 0.5 * lit.meanConfidence());
  EXPECT_LE(dark.share(dark.confident_bad2), 0.005);
}

TEST(SyntheticBehaviour, SpecularHighlightsDoNotPullConfidentDepths) {
  // Highlight pixels (specular radiance >= 0.1 of saturation in either view)
  // of the specular variant. Measured on the cues' product: 23.6%
  // confident, none of them off by > 2 px (0.83% before clipped pixels were
  // left out and the confidence saw the patches' disagreement). Published:
  // every estimate (86.9%) at 0.9 or more, 0.01% of the highlights wrong.
  const MatcherRun& run = bdisRun("specular");
  const RegionStats hl = regionStats(run, [](const SyntheticFrame& f) {
    const cv::Mat right = warpRightToLeft(f.specular_right, f.gt);
    return (f.specular_left >= 0.1f) | (right >= 0.1f);
  });
  print("highlights", hl);
  const PublishedRegionStats published_hl = publishedRegionStats("specular", [](const SyntheticFrame& f) {
    const cv::Mat right = warpRightToLeft(f.specular_right, f.gt);
    return (f.specular_left >= 0.1f) | (right >= 0.1f);
  });
  printPublished("highlights", published_hl);
  EXPECT_LE(published_hl.at_half.share(published_hl.at_half.confident_bad2), 0.005);
  EXPECT_GT(hl.pixels, 30000);
  EXPECT_LE(hl.share(hl.confident_bad2), 0.005);
}

TEST(SyntheticBehaviour, SpecularLobeAroundAClippedHighlightIsNotConfident) {
  // The specular variant's draw 19 puts a large clipped highlight in a broad
  // lobe that moves with the view; the tissue in a ring around it matches
  // the lobe, about 3 px too far, and nothing but the lobe cue doubts it.
  // The estimates within 24 px of a clipped left pixel, published, wrong at
  // 0.9 or more: 6.17% of the ring's pixels (6.78% with the cue fading over
  // one patch side instead of two, 8.25% without the cue).
  SceneConfig config = variant("specular");
  config.seed = 19;
  const auto near_clipped = [](const SyntheticFrame& f) {
    cv::Mat not_clipped = grey(f.left) < 255, distance;
    cv::distanceTransform(not_clipped, distance, cv::DIST_L2, 3);
    return cv::Mat(distance <= 24.f);
  };
  const RegionStats ring = regionStats(bdisRun(config), near_clipped, 0.9f);
  print("within 24 px of clipped", ring);
  EXPECT_GT(ring.pixels, 20000);
  EXPECT_LE(ring.share(ring.confident_bad2), 0.065);
}

/// The estimates of a run pooled for the confidence and variance analyses.
bdis::EstimateSamples samplesOf(const MatcherRun& run) {
  bdis::EstimateSamples samples;
  for (size_t k = 0; k < run.frames.size(); ++k) {
    const SyntheticFrame& f = *run.frames[k];
    const bdis::MatchResult& r = run.results[k];
    samples.add(r.disparity, f.gt, bdis::classifyPixels(f.gt, f.left), r.confidence, r.variance);
  }
  return samples;
}

TEST(SyntheticBehaviour, ConfidenceRanksTheErrors) {
  // A higher confidence has fewer outliers: bad2 falls from each tenth of
  // the estimates to the next more confident one, the most confident half
  // holds few, and the sparsification area stays near the oracle's.
  // Measured (bad2 of the most confident 50 %, of each tenth, least
  // confident first; sparsification area, / oracle's):
  //   instrument     0.0 %: 29.5  0.7  0.0 0.0 0.0 0.0 0.0 0.0 0.0 0.0; 0.0012, 1.64
  //   tube           0.5 %: 28.3 15.0  9.8 7.3 4.6 1.8 0.8 0.1 0.0 0.0; 0.0146, 5.56
  //   dark_periphery 0.0 %: 35.6  9.8  1.5 0.3 0.0 0.0 0.0 0.0 0.0 0.0; 0.0036, 3.04
  //   dark_tube      4.5 %: 61.3 42.4 33.0 26.9 16.5 10.6 7.0 3.4 1.2 0.0; 0.0633, 2.87
  //   compressed_dark 0.0 %: 61.1 43.2 25.2 9.2 1.9 0.2 0.0 0.0 0.0 0.0; 0.0221, 2.09
  // The support weights (on in balanced) took tube from 1.1 %, area 0.0219
  // and 4.42 (the figures these lines held before) to the above: every decile
  // fell, the area by a third, and the ratio rose because the estimates they
  // mend were ones the confidence already held low, so the oracle's area
  // shrank more. That is why tube's bar on the area is tight and on the ratio
  // loose.
  // Before the edge distance cue (an estimate near a jump between
  // neighbours) 1.71, tube 4.48 (area 0.0222), dark periphery 3.29, dark_tube
  // 6.0 % and 2.97, compressed_dark 2.24.
  // Before the residual fit cues (a slant the estimates miss that the
  // images still show, a shift their texture pins only loosely) 1.76, tube
  // 1.8 % and 5.07 (area 0.0252), dark periphery 4.37, dark_tube 7.4 % and
  // 3.26 (0.0841), compressed_dark 2.58; with the slant one alone 1.71,
  // 4.76, 4.19, 3.18, 2.53.
  // With the posterior window's samples 1 px apart and the floor at 0.0075:
  // instrument 0.0012, 1.60; tube 2.0 %, 0.0275, 5.62; dark periphery
  // 0.0084, 5.12; dark_tube 9.0 %, 0.0937, 3.48.
  // The ratios grew with the refinement (from 1.78, 4.88 and 2.95) while
  // every decile fell: it mends estimates the confidence already held low,
  // which shrinks the oracle's area more than the confidence's. The area
  // itself is held too.
  // Before the consensus cue (an estimate apart from its wider
  // neighbourhood) 1.97, tube 2.7 % and 5.19, dark periphery 0.3 % and 4.12.
  // Before the misfit cue (slant on strong texture) 2.31, tube 4.0 % and
  // 6.52; before the slant cue tube's half held 6.0 %; before the support
  // cue the ratios were 2.33, 7.18 and 4.54 (the dark periphery's survivors
  // among rejected neighbours ranked too high).
  struct Bar {
    double max_top50, max_ratio, max_area;
  };
  const std::map<std::string, Bar> bars = {
      {"instrument", {0.01, 2.0, 0.002}},
      {"tube", {0.01, 6.3, 0.016}},
      {"dark_periphery", {0.01, 3.9, 0.006}},
      {"dark_tube", {0.075, 3.25, 0.085}},
      {"compressed_dark", {0.01, 2.65, 0.03}}};
  for (const auto& [name, bar] : bars) {
    const bdis::Sparsification s = bdis::sparsify(samplesOf(bdisRun(name)));
    std::printf("  %-15s bad2 of the most confident half %.1f %%, deciles:", name.c_str(), 100 * s.bad2_top50);
    for (double d : s.decile_bad2) std::printf(" %.1f", 100 * d);
    std::printf("; sparsification area %.4f, %.2f x the oracle's\n", s.area, s.ratio());
    EXPECT_TRUE(s.monotone()) << name;
    EXPECT_LE(s.bad2_top50, bar.max_top50) << name;
    EXPECT_LE(s.ratio(), bar.max_ratio) << name;
    EXPECT_LE(s.area, bar.max_area) << name;
  }
}

TEST(SyntheticBehaviour, PublishedConfidenceSaysTheShareWithinTwoPx) {
  // The calibration was fitted on other seeds of these variants (7 and 11);
  // these frames are seed 1. Per variant, the expected calibration error
  // (per confidence bin, |mean confidence - share within 2 px|, weighted by
  // the bin's share), and the most a bin from 0.8 up (where a node sets its
  // threshold) holding 1 % of the estimates or more claims over what it has.
  // Measured: error 0.003 (diffuse, specular, textureless) to 0.048 (tube,
  // whose bins below 0.95 hold more right estimates than they claim); most
  // claimed over 0.05 (dark_tube's 0.95-0.98 bin: 0.97 / 0.92), the others
  // 0.03 or less. Below 0.5 compressed_dark claims 0.46 where 0.35 are
  // right: the estimates a threshold drops anyway.
  for (const char* name : {"diffuse", "specular", "textureless", "instrument", "dark_periphery", "tube", "dark_tube",
                           "compressed_dark"}) {
    const bdis::Reliability r = bdis::reliability(samplesOf(bdisRun(variant(name))));
    const double over_claim = bdis_test::reportReliability(name, r, 0.8f);
    EXPECT_LE(r.expected_error, 0.06) << name;
    EXPECT_LE(over_claim, 0.07) << name;
  }
}

TEST(SyntheticBehaviour, GainDifferenceBetweenTheViewsIsCompensatedWhenAsked) {
  // The right camera's grey levels 10 % above or below the left's (real
  // views differ by 0.87-1.11 over 33 px boxes) on the dark periphery. Mean
  // normalisation cancels an offset, not a gain: on the periphery's
  // brightness slope a gain leaves a ramp in the residual, which weak
  // texture aligns to (docs/method.md, "A gain difference between the
  // views"). By default that is a known gap: the bars hold what it scores,
  // and the confidence must put those errors where a threshold removes them.
  // With gain_compensation the estimate of the gain is divided out and the
  // frames score about as the matched pair (0.769 / 4.8 %).
  // Measured (density / bad2; bad2 of the most confident half; deciles,
  // least confident first):
  //   gain 1.1  0.761 /  9.5 %; 0.0 %: 65.0 23.0  6.3  1.0 0.0 0.0 0.0 0.0 0.0 0.0
  //             compensated 0.773 /  4.7 %; 0.0 %: 30.9 10.5  4.2  0.9 0.1 0.0 0.0 0.0 0.0 0.0
  //   gain 0.9  0.750 / 10.5 %; 0.0 %: 58.6 27.7 11.3  5.6 2.1 0.1 0.0 0.0 0.0 0.0
  //             compensated 0.769 /  5.0 %; 0.0 %: 30.0 12.6  5.4  1.9 0.2 0.0 0.0 0.0 0.0 0.0
  struct Bar {
    double gain;
    bool compensated;
    double min_density, max_bad2;
  };
  for (const Bar& bar : {Bar{1.1, false, 0.73, 0.115}, Bar{0.9, false, 0.72, 0.125}, Bar{1.1, true, 0.75, 0.06},
                         Bar{0.9, true, 0.75, 0.06}}) {
    SceneConfig config = variant("dark_periphery");
    config.right_gain = bar.gain;
    bdis::MatcherParams params;
    params.gain_compensation = bar.compensated;
    const MatcherRun& run = bdisRun(config, params);
    bdis::DisparityScore score;
    for (size_t k = 0; k < run.frames.size(); ++k) {
      score.add(bdis::scoreDisparity(run.results[k].disparity, run.frames[k]->gt, run.frames[k]->left));
    }
    const bdis::Sparsification s = bdis::sparsify(samplesOf(run));
    std::printf("  right gain %.1f%s: density %.3f, bad2 %.1f %%; most confident half %.1f %%, deciles:", bar.gain,
                bar.compensated ? ", compensated" : "", score.density(), 100 * score.bad2Rate(), 100 * s.bad2_top50);
    for (double d : s.decile_bad2) std::printf(" %.1f", 100 * d);
    std::printf("\n");
    SCOPED_TRACE("gain " + std::to_string(bar.gain) + (bar.compensated ? ", compensated" : ""));
    EXPECT_GE(score.density(), bar.min_density);
    EXPECT_LE(score.bad2Rate(), bar.max_bad2);
    EXPECT_TRUE(s.monotone());
    EXPECT_LE(s.bad2_top50, 0.01);
  }
}

TEST(SyntheticBehaviour, VarianceDescribesTheErrorsAsAStandardDeviation) {
  // With compute_variance on the colon-like tube: the share of errors within
  // 1 and 2 sigma where a Gaussian has 68 % and 95 %, and sigma as a ranking
  // of the errors (sparsification ratio, the smallest sigma first). Measured:
  // 78.0 % and 94.2 %, ranking 5.56 (before the support weights in
  // balanced 77.5 %, 93.5 %, 4.63: they mend the errors sigma held large,
  // and the oracle's area shrinks more, as for the confidence; without the
  // variance's outlier term 82.0 % and 94.2 %, ranking 8.56).
  bdis::MatcherParams params;
  params.compute_variance = true;
  bdis::Matcher matcher(params);
  bdis::EstimateSamples samples;
  for (int i : kFrames) {
    const SyntheticFrame& f = cachedFrame(variant("tube"), i);
    bdis::MatchResult r;
    matcher.compute(f.left, f.right, r);
    samples.add(r.disparity, f.gt, bdis::classifyPixels(f.gt, f.left), r.confidence, r.variance);
  }
  const bdis::VarianceCalibration c = bdis::calibrateVariance(samples);
  std::printf("  tube: %.1f %% of the errors within 1 sigma, %.1f %% within 2, median |e| / sigma %.3f, "
              "ranking %.2f\n",
              100 * c.within1, 100 * c.within2, c.median_ratio, c.ranking_ratio);
  EXPECT_GE(c.within1, 0.60);
  EXPECT_LE(c.within1, 0.85);
  EXPECT_GE(c.within2, 0.88);
  EXPECT_LE(c.ranking_ratio, 6.3);
}

TEST(SyntheticBehaviour, VarianceAtACoarserFinestLevelIsNarrowedToItsErrors) {
  // The variance was fitted at finest level 1; at level 2 (wider frames, or
  // as set here on 640 px ones) it is narrowed by kVarianceScalePerLevel.
  // The same tube frames as above and the flat diffuse ones at finest level 2,
  // whose flat tissue the variance covers widest. Measured: 81.4 % of the
  // errors within 1 sigma, 96.1 % within 2, median |e| / sigma 0.43 (without
  // the narrowing 86.6 %, 97.5 %, 0.36).
  bdis::MatcherParams params;
  params.compute_variance = true;
  params.finest_level = 2;
  bdis::Matcher matcher(params);
  bdis::EstimateSamples samples;
  for (const char* name : {"tube", "diffuse"}) {
    for (int i : kFrames) {
      const SyntheticFrame& f = cachedFrame(variant(name), i);
      bdis::MatchResult r;
      matcher.compute(f.left, f.right, r);
      samples.add(r.disparity, f.gt, bdis::classifyPixels(f.gt, f.left), r.confidence, r.variance);
    }
  }
  const bdis::VarianceCalibration c = bdis::calibrateVariance(samples);
  std::printf("  finest level 2: %.1f %% of the errors within 1 sigma, %.1f %% within 2, median |e| / sigma %.3f\n",
              100 * c.within1, 100 * c.within2, c.median_ratio);
  EXPECT_GE(c.within1, 0.60);
  EXPECT_LE(c.within1, 0.84);
  EXPECT_GE(c.within2, 0.90);
}

TEST(SyntheticBehaviour, VariationalRefinementRemovesOutliers) {
  // The accurate preset with and without its variational refinement, frames
  // 0, 5 and 10 of each variant: the refinement moves estimates only, so the
  // density stays, and bad2 falls where the patches are wrong for want of a
  // slant (tube), in the dark and on flat texture.
  // Measured (bad2 without -> with): tube 8.6 -> 7.0 %, dark_periphery 9.8
  // -> 6.5 %, textureless 1.7 -> 0.7 %, instrument 3.9 -> 3.1 %, diffuse 1.4
  // -> 0.4 %, specular 0.8 -> 0.6 %; earlier builds: tube 9.4 -> 8.0 %,
  // dark_periphery 10.5 -> 6.7 %. Before the texture
  // centroid correction, which runs in both and removes part of the same
  // slant's errors first: tube 11.8 -> 9.5 %, specular 1.0 -> 0.7 %.
  struct Bar {
    const char* variant;
    double max_ratio;  ///< bad2 with the refinement / without, at most
  };
  const Bar bars[] = {{"tube", 0.9},        {"dark_periphery", 0.75}, {"textureless", 0.6},
                      {"instrument", 0.85}, {"diffuse", 0.6},         {"specular", 0.9}};
  bdis::MatcherParams with = bdis::MatcherParams::preset("accurate");
  ASSERT_GT(with.refinement_iterations, 0);
  // One scale: the choice between two would mix the refinement's effect
  // with the coarser scale's.
  with.two_scales = false;
  bdis::MatcherParams without = with;
  without.refinement_iterations = 0;
  bdis::Matcher refined(with), unrefined(without);
  for (const Bar& bar : bars) {
    bdis::DisparityScore score_with, score_without;
    for (int i : kFrames) {
      const SyntheticFrame& f = cachedFrame(variant(bar.variant), i);
      bdis::MatchResult r;
      refined.compute(f.left, f.right, r);
      score_with.add(bdis::scoreDisparity(r.disparity, f.gt, f.left));
      unrefined.compute(f.left, f.right, r);
      score_without.add(bdis::scoreDisparity(r.disparity, f.gt, f.left));
    }
    std::printf("  %-15s density %.3f -> %.3f, bad2 %.1f -> %.1f %%\n", bar.variant, score_without.density(),
                score_with.density(), 100 * score_without.bad2Rate(), 100 * score_with.bad2Rate());
    EXPECT_EQ(score_with.density(), score_without.density()) << bar.variant;
    EXPECT_LE(score_with.bad2Rate(), bar.max_ratio * score_without.bad2Rate()) << bar.variant;
  }
}

TEST(SyntheticBehaviour, TwoScalesKeepFewerWrongEstimatesWhereTheFootprintIsShort) {
  // Balanced with and without two_scales, frames 0, 5 and 10: the density
  // stays (the choice fills no hole), bad2 falls on dark, flat and
  // block-coded tissue, where a patch at level 1 sees too little signal,
  // and the tissue beside the instrument is not made confidently wrong (the
  // coarser estimates are not taken near a depth edge).
  // Measured (bad2 without -> with): dark_periphery 4.73 -> 3.85 %,
  // compressed_dark 14.08 -> 10.09 %, textureless 0.64 -> 0.03 %, diffuse
  // 0.58 -> 0.03 %; lit and edged: specular 0.59 -> 0.54 %, instrument 3.00
  // -> 2.94 %, tube 6.51 -> 6.49 %, dark_tube 18.48 -> 17.99 %.
  struct Bar {
    const char* variant;
    double max_ratio;  ///< bad2 with two_scales / without, at most
  };
  const Bar bars[] = {{"dark_periphery", 0.9}, {"compressed_dark", 0.8}, {"textureless", 0.25}, {"diffuse", 0.25},
                      {"specular", 1.1},        {"instrument", 1.1},      {"tube", 1.1},        {"dark_tube", 1.0}};
  bdis::MatcherParams with;
  with.two_scales = true;
  for (const Bar& bar : bars) {
    const MatcherRun& one = bdisRun(variant(bar.variant));
    const MatcherRun& two = bdisRun(variant(bar.variant), with);
    bdis::DisparityScore score_one, score_two;
    for (size_t k = 0; k < one.frames.size(); ++k) {
      score_one.add(bdis::scoreDisparity(one.results[k].disparity, one.frames[k]->gt, one.frames[k]->left));
      score_two.add(bdis::scoreDisparity(two.results[k].disparity, two.frames[k]->gt, two.frames[k]->left));
    }
    std::printf("  %-15s density %.3f -> %.3f, bad2 %.2f -> %.2f %%\n", bar.variant, score_one.density(),
                score_two.density(), 100 * score_one.bad2Rate(), 100 * score_two.bad2Rate());
    EXPECT_EQ(score_two.density(), score_one.density()) << bar.variant;
    EXPECT_LE(score_two.bad2Rate(), bar.max_ratio * score_one.bad2Rate()) << bar.variant;
  }
  // Beside the instrument, wrong at 0.5 or more: 0.45 -> 0.45 % (the bar of
  // InstrumentBoundaryHasFewConfidentOutliers); 4.8 % on bdis_eval's
  // instrument s11 before the choice kept off depth edges.
  const auto tissue_band = [](const SyntheticFrame& f) { return instrumentBand(f, true); };
  const RegionStats band_one = regionStats(bdisRun(variant("instrument")), tissue_band, 0.5f);
  const RegionStats band_two = regionStats(bdisRun(variant("instrument"), with), tissue_band, 0.5f);
  std::printf("  instrument, tissue within 12 px wrong at >= 0.5: %.2f -> %.2f %%\n",
              100 * band_one.share(band_one.confident_bad2), 100 * band_two.share(band_two.confident_bad2));
  EXPECT_LE(band_two.share(band_two.confident_bad2), 0.0085);
}

TEST(SyntheticBehaviour, ClippedHighlightsGetNoEstimate) {
  // A clipped highlight (grey 255) holds no texture, and it sits elsewhere on
  // the tissue in the other view: the pixels in it get no estimate.
  const MatcherRun& run = bdisRun("specular");
  long clipped = 0, estimated = 0;
  for (size_t k = 0; k < run.frames.size(); ++k) {
    const cv::Mat1b g = grey(run.frames[k]->left);
    for (int y = 0; y < g.rows; ++y) {
      for (int x = 0; x < g.cols; ++x) {
        if (g(y, x) < 255) continue;
        ++clipped;
        estimated += run.results[k].disparity.at<float>(y, x) >= 0.f ? 1 : 0;
      }
    }
  }
  std::printf("  clipped pixels %ld, estimated %ld\n", clipped, estimated);
  EXPECT_GT(clipped, 1000);
  EXPECT_EQ(estimated, 0);
}

TEST(SearchBands, DefaultBandsScoreAsTheWholeLevelSearch) {
  // The finest level searched per band of 8 patch rows (the default) against
  // both passes over the whole level at once (0, as DIS): the bands change
  // which neighbours the backward pass offers at their bottom edges, not the
  // scores. Measured (density / median px / bad2), whole level against bands
  // of 8: diffuse 0.966 / 0.133 / 0.6 % against 0.965 / 0.133 / 0.6 %,
  // instrument 0.927 / 0.114 / 3.5 % against 0.927 / 0.114 / 3.4 %, tube
  // 0.899 / 0.431 / 9.9 % against 0.900 / 0.429 / 9.8 %. One-row bands (1:
  // no lower neighbour at all) are printed beside them: they miss the
  // tolerances below on tube (median +0.005 px, bad2 +0.5 %; diffuse and
  // instrument lose 0.003 of density, within its tolerance), so the
  // tolerances can tell a cut propagation.
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
