// Regions, confidence ranking, variance calibration and border strips
// (bdis_stereo/error_analysis.hpp) on constructed inputs whose answer is known.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

#include <opencv2/core.hpp>

#include "bdis_stereo/error_analysis.hpp"

namespace {

using bdis::EstimateSamples;
using bdis::kNotScorable;
using bdis::PixelRegion;

uchar label(const cv::Mat& labels, int y, int x) { return labels.at<uchar>(y, x); }
constexpr uchar code(PixelRegion r) { return static_cast<uchar>(r); }

TEST(ErrorRegions, EachPixelInTheFirstRegionThatApplies) {
  // One row, 40 px: background at 5 px, a near strip (columns 20-29) at 12 px.
  // Right view: the strip covers right columns 8-17, which hide the
  // background pixels whose matches fall there (left columns 13-19 at 5 px:
  // x - 5 in 8..14, rounded).
  const int w = 40;
  cv::Mat gt(3, w, CV_32FC1, cv::Scalar(5.f));
  gt.colRange(20, 30).setTo(12.f);
  cv::Mat left(3, w, CV_8UC1, cv::Scalar(100));
  left.at<uchar>(1, 35) = 10;          // dark
  left.at<uchar>(1, 36) = 0;           // black: not scorable
  gt.at<float>(1, 37) = 0.f;           // no ground truth: not scorable
  bdis::RegionOptions options;
  options.edge_band_px = 1;
  const cv::Mat labels = bdis::classifyPixels(gt, left, options);
  // x - d < 0: columns 0-4 at 5 px.
  for (int x = 0; x < 5; ++x) EXPECT_EQ(label(labels, 1, x), code(PixelRegion::OutOfView)) << x;
  // Hidden behind the strip in the right view.
  for (int x = 14; x < 18; ++x) EXPECT_EQ(label(labels, 1, x), code(PixelRegion::Occluded)) << x;
  // The strip's own pixels are seen: the edge band around its borders (1 px).
  EXPECT_EQ(label(labels, 1, 20), code(PixelRegion::DepthEdge));
  EXPECT_EQ(label(labels, 1, 29), code(PixelRegion::DepthEdge));
  EXPECT_EQ(label(labels, 1, 30), code(PixelRegion::DepthEdge));
  EXPECT_EQ(label(labels, 1, 25), code(PixelRegion::Rest));
  EXPECT_EQ(label(labels, 1, 8), code(PixelRegion::Rest));
  EXPECT_EQ(label(labels, 1, 35), code(PixelRegion::Dark));
  EXPECT_EQ(label(labels, 1, 36), kNotScorable);
  EXPECT_EQ(label(labels, 1, 37), kNotScorable);
}

TEST(ErrorRegions, ScoresPerRegion) {
  const cv::Mat gt(1, 6, CV_32FC1, cv::Scalar(2.f));
  cv::Mat labels = (cv::Mat_<uchar>(1, 6) << code(PixelRegion::OutOfView), code(PixelRegion::Rest),
                    code(PixelRegion::Rest), code(PixelRegion::Rest), code(PixelRegion::Dark), kNotScorable);
  const cv::Mat d = (cv::Mat_<float>(1, 6) << 7.f, 2.5f, 9.f, -1.f, -1.f, 8.f);
  const bdis::RegionScore s = bdis::scoreRegions(d, gt, labels);
  EXPECT_EQ(s.scorable(), 5);
  EXPECT_DOUBLE_EQ(s.share(PixelRegion::Rest), 3.0 / 5.0);
  EXPECT_DOUBLE_EQ(s[PixelRegion::Rest].density(), 2.0 / 3.0);
  EXPECT_DOUBLE_EQ(s[PixelRegion::Rest].bad2Rate(), 0.5);
  EXPECT_DOUBLE_EQ(s[PixelRegion::OutOfView].bad2Rate(), 1.0);
  EXPECT_DOUBLE_EQ(s[PixelRegion::Dark].density(), 0.0);
}

TEST(ErrorInstrumentBands, TissueBesideTheInstrumentAndItsRim) {
  // 60 x 40 px, ground truth 10 px everywhere; the instrument a 20 x 20
  // square (columns 20-39, rows 10-29); bands of 3 px: the tissue ring
  // (columns 17-42, rows 7-32, less the square: 276 px) and the rim (the
  // square less columns 23-36, rows 13-26: 204 px).
  const cv::Mat gt(40, 60, CV_32FC1, cv::Scalar(10.f));
  cv::Mat regions(40, 60, CV_8UC1, cv::Scalar(code(PixelRegion::Rest)));
  cv::Mat surfaces(40, 60, CV_8UC1, cv::Scalar(1));
  surfaces(cv::Rect(20, 10, 20, 20)).setTo(bdis::kInstrumentSurface);
  cv::Mat d = gt.clone();
  cv::Mat conf(40, 60, CV_32FC1, cv::Scalar(0.6f));
  // Tissue: the ring's left side (3 x 26 px) 5 px too near, its upper half
  // with confidence 0.8, its lower half 0.3; the ring's top right of it (3 x
  // 23 px) without estimate, one of those pixels not scorable.
  d(cv::Rect(17, 7, 3, 26)).setTo(15.f);
  conf(cv::Rect(17, 7, 3, 13)).setTo(0.8f);
  conf(cv::Rect(17, 20, 3, 13)).setTo(0.3f);
  d(cv::Rect(20, 7, 23, 3)).setTo(-1.f);
  regions.at<uchar>(8, 30) = kNotScorable;
  // Rim: its left side (3 x 20 px) 3 px too near with confidence 0.9.
  d(cv::Rect(20, 10, 3, 20)).setTo(13.f);
  conf(cv::Rect(20, 10, 3, 20)).setTo(0.9f);
  d.at<float>(0, 0) = 50.f;  // far from the instrument: in neither band

  const bdis::InstrumentBandScore s = bdis::scoreInstrumentBands(d, gt, regions, surfaces, conf, 3, 0.5f);
  EXPECT_EQ(s.tissue.scorable, 275);
  EXPECT_EQ(s.tissue.estimated, 276 - 69);
  EXPECT_EQ(s.tissue.bad2, 78);
  EXPECT_EQ(s.tissue.confident_bad2, 39);
  EXPECT_NEAR(s.tissue.confidentBad2Share(), 39.0 / 275, 1e-12);
  EXPECT_NEAR(s.tissue.meanConfidence(), (39 * 0.8 + 39 * 0.3 + (207 - 78) * 0.6) / 207, 1e-6);
  EXPECT_EQ(s.rim.scorable, 204);
  EXPECT_EQ(s.rim.estimated, 204);
  EXPECT_EQ(s.rim.bad2, 60);
  EXPECT_EQ(s.rim.confident_bad2, 60);
  EXPECT_NEAR(s.rim.meanConfidence(), (60 * 0.9 + 144 * 0.6) / 204, 1e-6);

  // Without a confidence nothing is confident; frames add up.
  bdis::InstrumentBandScore two = bdis::scoreInstrumentBands(d, gt, regions, surfaces, cv::Mat(), 3);
  EXPECT_EQ(two.tissue.confident_bad2, 0);
  EXPECT_EQ(two.tissue.confidence_sum, 0);
  two.add(s);
  EXPECT_EQ(two.tissue.scorable, 550);
  EXPECT_EQ(two.rim.confident_bad2, 60);
  // No instrument in view: empty bands.
  EXPECT_FALSE(bdis::scoreInstrumentBands(d, gt, regions, cv::Mat(40, 60, CV_8UC1, cv::Scalar(1)), conf).any());
  EXPECT_THROW(bdis::scoreInstrumentBands(d, gt, regions, surfaces, conf, 0), std::invalid_argument);
  EXPECT_THROW(bdis::scoreInstrumentBands(d, gt, regions, surfaces(cv::Rect(0, 0, 30, 40)), conf),
               std::invalid_argument);
}

/// n samples: error e_i, confidence c_i.
EstimateSamples samples(const std::vector<float>& errors, const std::vector<float>& confidence) {
  EstimateSamples s;
  s.abs_error = errors;
  s.confidence = confidence;
  s.scorable = static_cast<double>(errors.size());
  return s;
}

TEST(ErrorConfidence, PerfectRankingMatchesTheOracle) {
  // 100 estimates, the 20 worst (error 5) the least confident.
  std::vector<float> e(100, 0.5f), c(100);
  for (int i = 0; i < 100; ++i) {
    c[static_cast<size_t>(i)] = static_cast<float>(i) / 100.f;
    if (i < 20) e[static_cast<size_t>(i)] = 5.f;
  }
  const bdis::Sparsification s = bdis::sparsify(samples(e, c));
  EXPECT_NEAR(s.ratio(), 1.0, 1e-9);
  EXPECT_EQ(s.bad2_top25, 0.0);
  EXPECT_EQ(s.bad2_top50, 0.0);
  // Deciles, least confident first: 100 %, 100 %, then 0.
  EXPECT_EQ(s.decile_bad2[0], 1.0);
  EXPECT_EQ(s.decile_bad2[1], 1.0);
  EXPECT_EQ(s.decile_bad2[2], 0.0);
  EXPECT_TRUE(s.monotone());
  // bad2 of the most confident f: 0 up to f = 0.8, then (f - 0.8) / f; the
  // trapezoids from 0.05 to 1: 0.05 * (0.5 * 0.2 / 1 + 0.15 / 0.95 + 0.1 / 0.9 + 0.05 / 0.85 * 1.5 - ...)
  // computed step by step below.
  double area = 0, prev = 0;
  for (int i = 1; i <= 20; ++i) {
    const double f = 0.05 * i, b = f > 0.8 ? (f - 0.8) / f : 0.0;
    if (i > 1) area += 0.05 * 0.5 * (prev + b);
    prev = b;
  }
  EXPECT_NEAR(s.area, area, 1e-9);
}

TEST(ErrorConfidence, ReversedRankingIsFarFromTheOracleAndNotMonotone) {
  std::vector<float> e(100, 0.5f), c(100);
  for (int i = 0; i < 100; ++i) {
    c[static_cast<size_t>(i)] = static_cast<float>(i) / 100.f;
    if (i >= 80) e[static_cast<size_t>(i)] = 5.f;  // the worst are the most confident
  }
  const bdis::Sparsification s = bdis::sparsify(samples(e, c));
  EXPECT_GT(s.ratio(), 4.0);
  EXPECT_EQ(s.bad2_top25, 20.0 / 25.0);
  EXPECT_FALSE(s.monotone());
}

TEST(ErrorConfidence, ThresholdsLeaveDensityAndBad2) {
  // 4 estimates of 8 scorable pixels.
  EstimateSamples s = samples({0.5f, 3.f, 0.2f, 4.f}, {0.9f, 0.8f, 0.3f, 0.1f});
  s.scorable = 8;
  const std::vector<bdis::ThresholdRow> rows = bdis::confidenceThresholds(s, {0.f, 0.5f, 0.85f, 0.95f});
  ASSERT_EQ(rows.size(), 4u);
  EXPECT_DOUBLE_EQ(rows[0].density, 0.5);
  EXPECT_DOUBLE_EQ(rows[0].bad2, 0.5);
  EXPECT_DOUBLE_EQ(rows[1].density, 0.25);
  EXPECT_DOUBLE_EQ(rows[1].bad2, 0.5);
  EXPECT_DOUBLE_EQ(rows[2].density, 0.125);
  EXPECT_DOUBLE_EQ(rows[2].bad2, 0.0);
  EXPECT_DOUBLE_EQ(rows[3].density, 0.0);
}

TEST(ErrorConfidence, ReliabilityComparesEachBinsConfidenceWithItsShareWithinTwoPx) {
  // 40 estimates at 0.55, 22 of them within 2 px (as claimed); 60 at 0.99,
  // all within 2 px (0.01 more than claimed); one at exactly 1 (the last bin
  // holds its upper edge) and one above the edges (left out).
  std::vector<float> error, confidence;
  for (int i = 0; i < 40; ++i) {
    error.push_back(i < 22 ? 1.f : 5.f);
    confidence.push_back(0.55f);
  }
  for (int i = 0; i < 60; ++i) {
    error.push_back(0.5f);
    confidence.push_back(0.99f);
  }
  error.push_back(3.f);
  confidence.push_back(1.f);
  error.push_back(0.f);
  confidence.push_back(1.5f);
  const bdis::Reliability r = bdis::reliability(samples(error, confidence), {0.f, 0.5f, 0.6f, 0.98f, 1.f});
  ASSERT_EQ(r.bins.size(), 4u);
  EXPECT_DOUBLE_EQ(r.bins[0].share, 0.0);
  EXPECT_NEAR(r.bins[1].share, 40.0 / 101, 1e-12);
  EXPECT_NEAR(r.bins[1].mean_confidence, 0.55, 1e-6);
  EXPECT_DOUBLE_EQ(r.bins[1].within2, 22.0 / 40);
  EXPECT_DOUBLE_EQ(r.bins[2].share, 0.0);
  EXPECT_FLOAT_EQ(r.bins[3].lower, 0.98f);
  EXPECT_NEAR(r.bins[3].share, 61.0 / 101, 1e-12);
  EXPECT_NEAR(r.bins[3].mean_confidence, (60 * 0.99 + 1.0) / 61, 1e-6);
  EXPECT_DOUBLE_EQ(r.bins[3].within2, 60.0 / 61);
  const double expected = 61.0 / 101 * std::fabs((60 * 0.99 + 1.0) / 61 - 60.0 / 61);
  EXPECT_NEAR(r.expected_error, expected, 1e-6);
  // Over all 101: the mean confidence and the share within 2 px.
  EXPECT_NEAR(r.mean_confidence, (40 * 0.55 + 60 * 0.99 + 1.0) / 101, 1e-6);
  EXPECT_DOUBLE_EQ(r.within2, 82.0 / 101);
  // The most a bin claims over what it has: about 0 at 0.5-0.6, the wrong
  // estimate at confidence 1 in 0.98-1; no bin holds a 70 % share.
  EXPECT_NEAR(r.mostClaimedOver(), (60 * 0.99 + 1.0) / 61 - 60.0 / 61, 1e-6);
  EXPECT_DOUBLE_EQ(r.mostClaimedOver(0.f, 0.7), -1.0);
  // A confidence that claims 0.99 for estimates that are all wrong is far off.
  const bdis::Reliability wrong = bdis::reliability(samples({5.f, 6.f, 7.f}, {0.99f, 0.99f, 0.99f}), {0.f, 1.f});
  EXPECT_NEAR(wrong.expected_error, 0.99, 1e-6);
  EXPECT_NEAR(wrong.mostClaimedOver(), 0.99, 1e-6);
  EXPECT_DOUBLE_EQ(wrong.mostClaimedOver(0.5f), -1.0);  // its one bin starts at 0
  // Fewer than two edges: no bins.
  EXPECT_TRUE(bdis::reliability(samples({1.f}, {0.5f}), {0.f}).bins.empty());
}

TEST(ErrorVariance, GaussianErrorsWithTheirSigmaAreCalibrated) {
  std::mt19937 rng(3);
  EstimateSamples s;
  for (int i = 0; i < 200000; ++i) {
    const float sigma = 0.2f + 0.01f * static_cast<float>(i % 200);
    std::normal_distribution<float> n(0.f, sigma);
    s.abs_error.push_back(std::fabs(n(rng)));
    s.confidence.push_back(0.f);
    s.sigma.push_back(sigma);
  }
  const bdis::VarianceCalibration c = bdis::calibrateVariance(s);
  EXPECT_NEAR(c.within1, 0.6827, 0.005);
  EXPECT_NEAR(c.within2, 0.9545, 0.005);
  EXPECT_NEAR(c.median_ratio, 0.6745, 0.01);
  // Twice too wide a sigma: within 1 sigma is then within 2 true sigmas.
  for (float& sigma : s.sigma) sigma *= 2.f;
  EXPECT_NEAR(bdis::calibrateVariance(s).within1, 0.9545, 0.005);
}

TEST(ErrorVariance, RanksTheErrorsBySigmaAsAConfidence) {
  // 80 estimates off by 0.5 px and 20 by 5 px (outliers).
  EstimateSamples s;
  for (int i = 0; i < 100; ++i) {
    s.abs_error.push_back(i < 80 ? 0.5f : 5.f);
    s.confidence.push_back(0.f);
  }
  auto rankingWith = [&](auto sigma_of_error) {
    s.sigma.clear();
    for (float e : s.abs_error) s.sigma.push_back(sigma_of_error(e));
    return bdis::calibrateVariance(s).ranking_ratio;
  };
  // Sigma that grows with the error ranks as the oracle does.
  EXPECT_DOUBLE_EQ(rankingWith([](float e) { return e; }), 1.0);
  // Sigma that shrinks with it puts the outliers first: the worst ranking,
  // the same as one sigma for all (ties rank as badly as they can).
  const double reversed = rankingWith([](float e) { return 1.f / e; });
  EXPECT_GT(reversed, 3.0);
  EXPECT_DOUBLE_EQ(rankingWith([](float) { return 1.f; }), reversed);
  // As sparsify() ranks a confidence of -sigma.
  std::vector<float> trust;
  for (float e : s.abs_error) trust.push_back(-1.f / e);
  EXPECT_DOUBLE_EQ(bdis::sparsifyBy(trust, s.abs_error).ratio(), reversed);
  EXPECT_EQ(bdis::sparsifyBy({1.f}, s.abs_error).ratio(), 0.0);  // sizes that do not pair up
}

TEST(ErrorBorderStrips, CountsEstimatesOffTheInnerMedian) {
  // 10 rows of 200 px; black frame: columns 0-19 and 180-199. Disparity 10
  // everywhere inside, except a wrong strip of 8 px (at 30) next to the left
  // frame in rows 0-4.
  cv::Mat left(10, 200, CV_8UC1, cv::Scalar(90));
  left.colRange(0, 20).setTo(0);
  left.colRange(180, 200).setTo(0);
  cv::Mat d(10, 200, CV_32FC1, cv::Scalar(10.f));
  d.colRange(0, 20).setTo(-1.f);
  d.colRange(180, 200).setTo(-1.f);
  d(cv::Rect(20, 0, 8, 5)).setTo(30.f);
  const bdis::BorderStripScore s = bdis::scoreBorderStrips(d, left);
  // 12 px per end and row, both ends of 10 rows.
  EXPECT_EQ(s.estimates, 240);
  EXPECT_EQ(s.outliers, 40);
  EXPECT_NEAR(bdis::validPixelDensity(d, left), 1.0, 1e-12);
}

}  // namespace
