// Scoring, disparity PNG I/O and sequence access (bdis_stereo/evaluation.hpp).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "bdis_stereo/evaluation.hpp"
#include "bdis_stereo/matcher.hpp"
#include "test_images.hpp"

namespace fs = std::filesystem;

namespace {

using bdis::DisparityScore;
using bdis::kNoDisparity;
using bdis_test::TempPath;

const float kNaNf = std::numeric_limits<float>::quiet_NaN();

// ---------------------------------------------------------------------------
// scoreDisparity
// ---------------------------------------------------------------------------

// 2 x 4 scene scored by hand:
//   gt         2     0     5    10  |   3     4    6    1
//   disparity  2.5   7    -1    13  |   3    NaN  6.5   9
//   left       10    10    10   10  |   0    10   10   10
// Scorable (gt > 0 and left not black): all but (0,1) [gt 0] and (1,0)
// [black] = 6. Estimated: (0,0) err 0.5, (0,3) err 3, (1,2) err 0.5,
// (1,3) err 8 = 4 (the -1 and the NaN are misses). bad2 (> 2 px): 2.
// density 4/6, mean 12/4 = 3, median (0.5 + 3)/2 = 1.75, bad2 rate 2/4,
// miss_or_bad2 (6 - 4 + 2)/6.
struct HandScene {
  cv::Mat gt = (cv::Mat_<float>(2, 4) << 2, 0, 5, 10, 3, 4, 6, 1);
  cv::Mat disparity = (cv::Mat_<float>(2, 4) << 2.5f, 7, kNoDisparity, 13, 3, kNaNf, 6.5f, 9);
  cv::Mat left = (cv::Mat_<uchar>(2, 4) << 10, 10, 10, 10, 0, 10, 10, 10);
};

TEST(EvaluationScore, HandComputedScene) {
  const HandScene h;
  const DisparityScore s = bdis::scoreDisparity(h.disparity, h.gt, h.left);
  EXPECT_EQ(s.scorable, 6);
  EXPECT_EQ(s.estimated, 4);
  EXPECT_EQ(s.bad2, 2);
  EXPECT_DOUBLE_EQ(s.abs_error_sum, 12.0);
  ASSERT_EQ(s.abs_errors.size(), 4u);
  EXPECT_DOUBLE_EQ(s.density(), 4.0 / 6.0);
  EXPECT_DOUBLE_EQ(s.meanError(), 3.0);
  EXPECT_DOUBLE_EQ(s.medianError(), 1.75);
  EXPECT_DOUBLE_EQ(s.bad2Rate(), 0.5);
  EXPECT_DOUBLE_EQ(s.missOrBad2Rate(), 4.0 / 6.0);
}

TEST(EvaluationScore, ExactlyTwoPixelsOffIsNotBad) {
  const cv::Mat gt = (cv::Mat_<float>(1, 3) << 5, 5, 5);
  const cv::Mat d = (cv::Mat_<float>(1, 3) << 7, 3, 7.01f);
  const cv::Mat left(1, 3, CV_8UC1, cv::Scalar(50));
  const DisparityScore s = bdis::scoreDisparity(d, gt, left);
  EXPECT_EQ(s.bad2, 1);  // only the 2.01 px error
  EXPECT_NEAR(s.medianError(), 2.0, 1e-6);
}

TEST(EvaluationScore, BgrLeftIsBlackOnlyWhenEveryChannelIsZero) {
  const cv::Mat gt = (cv::Mat_<float>(1, 3) << 4, 4, 4);
  const cv::Mat d = (cv::Mat_<float>(1, 3) << 4, 4, 9);
  cv::Mat left(1, 3, CV_8UC3);
  left.at<cv::Vec3b>(0, 0) = {0, 0, 0};  // black: not scored
  left.at<cv::Vec3b>(0, 1) = {0, 0, 7};  // dark but valid
  left.at<cv::Vec3b>(0, 2) = {3, 0, 0};
  const DisparityScore s = bdis::scoreDisparity(d, gt, left);
  EXPECT_EQ(s.scorable, 2);
  EXPECT_EQ(s.estimated, 2);
  EXPECT_EQ(s.bad2, 1);
  EXPECT_DOUBLE_EQ(s.meanError(), 2.5);
}

TEST(EvaluationScore, NothingScorableGivesZeroRates) {
  const cv::Mat gt(2, 2, CV_32FC1, cv::Scalar(0));
  const cv::Mat d(2, 2, CV_32FC1, cv::Scalar(3));
  const cv::Mat left(2, 2, CV_8UC1, cv::Scalar(9));
  const DisparityScore s = bdis::scoreDisparity(d, gt, left);
  EXPECT_EQ(s.scorable, 0);
  EXPECT_EQ(s.density(), 0.0);
  EXPECT_EQ(s.meanError(), 0.0);
  EXPECT_EQ(s.medianError(), 0.0);
  EXPECT_EQ(s.bad2Rate(), 0.0);
  EXPECT_EQ(s.missOrBad2Rate(), 0.0);
}

TEST(EvaluationScore, AddAccumulatesFrames) {
  const HandScene h;
  DisparityScore total;
  total.add(bdis::scoreDisparity(h.disparity, h.gt, h.left));
  // Second frame: 3 scorable, 3 estimated, errors 1, 2, 4 (one bad).
  const cv::Mat gt = (cv::Mat_<float>(1, 3) << 10, 10, 10);
  const cv::Mat d = (cv::Mat_<float>(1, 3) << 11, 8, 14);
  total.add(bdis::scoreDisparity(d, gt, cv::Mat(1, 3, CV_8UC1, cv::Scalar(1))));
  EXPECT_EQ(total.scorable, 9);
  EXPECT_EQ(total.estimated, 7);
  EXPECT_EQ(total.bad2, 3);
  EXPECT_DOUBLE_EQ(total.meanError(), 19.0 / 7.0);
  // errors {0.5, 0.5, 1, 2, 3, 4, 8}: odd count, median 2.
  EXPECT_DOUBLE_EQ(total.medianError(), 2.0);
  EXPECT_DOUBLE_EQ(total.missOrBad2Rate(), (9.0 - 7.0 + 3.0) / 9.0);
  // medianError sorts a copy: the stored errors keep their order.
  EXPECT_EQ(total.abs_errors.front(), 0.5f);
  EXPECT_EQ(total.abs_errors.back(), 4.f);
}

TEST(EvaluationScore, RejectsMismatchedInputs) {
  const HandScene h;
  const cv::Mat wrong_size(3, 4, CV_32FC1, cv::Scalar(1));
  EXPECT_THROW(bdis::scoreDisparity(wrong_size, h.gt, h.left), std::invalid_argument);
  EXPECT_THROW(bdis::scoreDisparity(h.disparity, h.gt, cv::Mat(2, 5, CV_8UC1)), std::invalid_argument);
  cv::Mat d64;
  h.disparity.convertTo(d64, CV_64F);
  EXPECT_THROW(bdis::scoreDisparity(d64, h.gt, h.left), std::invalid_argument);
  cv::Mat left16;
  h.left.convertTo(left16, CV_16U);
  EXPECT_THROW(bdis::scoreDisparity(h.disparity, h.gt, left16), std::invalid_argument);
}

TEST(EvaluationScore, AgreesWithTestStatisticsOnMatcherOutput) {
  // scoreDisparity against the ground truth of a synthetic pair agrees with
  // the test's own statistics.
  const bdis_test::StereoPair pair = bdis_test::texturedPair(160, 120, {6.0, 0.0});
  bdis::Matcher m;
  bdis::MatchResult r;
  m.compute(pair.left, pair.right, r);
  const cv::Rect roi = bdis_test::interior(160, 120, 32, 6);
  const DisparityScore s = bdis::scoreDisparity(r.disparity(roi), pair.gt(roi), pair.left(roi));
  const bdis_test::ErrorStats e = bdis_test::errorStats(r.disparity, pair.gt, roi);
  EXPECT_EQ(s.scorable, roi.area());
  EXPECT_EQ(s.estimated, static_cast<double>(e.estimated));
  EXPECT_NEAR(s.medianError(), e.median, 1e-6);
  EXPECT_LT(s.medianError(), 0.01);  // even disparity at half resolution: exact
  EXPECT_EQ(s.bad2, 0);
}

// ---------------------------------------------------------------------------
// Disparity PNG
// ---------------------------------------------------------------------------

TEST(EvaluationPng, WriteStoresRoundedTimes256AndZeroForNone) {
  const cv::Mat d = (cv::Mat_<float>(2, 6) << 7.3f, 0.f, 0.001f, 1.f / 256, 100.123f, kNoDisparity,
                     kNaNf, -0.25f, 255.99f, 300.f, 0.6f / 256, 1.4f / 256);
  TempPath file(".png");
  bdis::writeDisparityPng(file.str(), d);
  const cv::Mat raw = cv::imread(file.str(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(raw.type(), CV_16UC1);
  ASSERT_EQ(raw.size(), d.size());
  const cv::Mat expected = (cv::Mat_<uint16_t>(2, 6) << 1869,  // round(7.3 * 256) = 1868.8
                            1,      // a real 0 must not become "none"
                            1,      // tiny positive: 0.256 rounds up to 1, not 0
                            1, 25631,  // 100.123f * 256 = 25631.49
                            0,         // none
                            0, 0,      // NaN and negative: none
                            65533,     // 255.99 * 256 = 65533.44
                            65535,     // clamped
                            1, 1);
  for (int y = 0; y < 2; ++y) {
    for (int x = 0; x < 6; ++x) {
      EXPECT_EQ(raw.at<uint16_t>(y, x), expected.at<uint16_t>(y, x)) << "at " << x << "," << y;
    }
  }
}

TEST(EvaluationPng, RoundTripKeepsValuesTo1Over512) {
  cv::Mat d(17, 23, CV_32FC1);
  cv::RNG rng(5);
  rng.fill(d, cv::RNG::UNIFORM, 0.0, 250.0);
  d.at<float>(0, 0) = kNoDisparity;
  d.at<float>(3, 7) = kNoDisparity;
  d.at<float>(5, 5) = 0.001f;
  TempPath file(".png");
  bdis::writeDisparityPng(file.str(), d);
  const cv::Mat back = bdis::readDisparityPng(file.str());
  ASSERT_EQ(back.type(), CV_32FC1);
  ASSERT_EQ(back.size(), d.size());
  EXPECT_EQ(back.at<float>(0, 0), kNoDisparity);
  EXPECT_EQ(back.at<float>(3, 7), kNoDisparity);
  EXPECT_EQ(back.at<float>(5, 5), 1.f / 256);  // tiny stays an estimate
  for (int y = 0; y < d.rows; ++y) {
    for (int x = 0; x < d.cols; ++x) {
      const float v = d.at<float>(y, x);
      if (v < 0.f || (y == 5 && x == 5)) continue;
      EXPECT_NEAR(back.at<float>(y, x), v, 0.5 / 256 + 1e-6);
      EXPECT_EQ(back.at<float>(y, x) * 256, std::round(back.at<float>(y, x) * 256));  // on the grid
    }
  }
}

TEST(EvaluationPng, ReadAndWriteRejectBadInput) {
  TempPath missing(".png");
  EXPECT_THROW(bdis::readDisparityPng(missing.str()), std::runtime_error);

  TempPath eight_bit(".png");
  cv::imwrite(eight_bit.str(), cv::Mat(4, 4, CV_8UC1, cv::Scalar(3)));
  EXPECT_THROW(bdis::readDisparityPng(eight_bit.str()), std::runtime_error);

  TempPath out(".png");
  EXPECT_THROW(bdis::writeDisparityPng(out.str(), cv::Mat(4, 4, CV_16UC1, cv::Scalar(3))),
               std::runtime_error);
  EXPECT_THROW(bdis::writeDisparityPng(out.str(), cv::Mat(4, 4, CV_64FC1, cv::Scalar(3))),
               std::runtime_error);
  TempPath dir("");
  fs::create_directories(dir.str());
  EXPECT_THROW(bdis::writeDisparityPng((fs::path(dir.str()) / "no" / "such" / "d.png").string(),
                                       cv::Mat(4, 4, CV_32FC1, cv::Scalar(3))),
               std::runtime_error);
}

TEST(EvaluationPng, ConfidenceKeepsEveryEstimateAndOnlyThem) {
  // Row 0 has estimates, row 1 none: confidences of 0, far below the 16-bit
  // step, about half a step, a step and a half, 0.5, 1, above 1 and NaN.
  const cv::Mat d = (cv::Mat_<float>(2, 8) << 7.f, 7.f, 0.f, 3.f, 3.f, 3.f, 3.f, 3.f,  //
                     kNoDisparity, kNoDisparity, kNaNf, -2.f, kNoDisparity, kNoDisparity, kNoDisparity, kNoDisparity);
  const float step = 1.f / 65535;
  const cv::Mat row = (cv::Mat_<float>(1, 8) << 0.f, 1e-9f, 0.49f * step, 1.5f * step, 0.5f, 1.f, 2.f, kNaNf);
  cv::Mat c;
  cv::vconcat(row, row, c);
  TempPath file(".png");
  bdis::writeConfidencePng(file.str(), d, c);
  const cv::Mat raw = cv::imread(file.str(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(raw.type(), CV_16UC1);
  const uint16_t expected[8] = {1, 1, 1, 2, 32768, 65535, 65535, 1};  // round(0.5 * 65535) = 32768
  for (int x = 0; x < 8; ++x) {
    EXPECT_EQ(raw.at<uint16_t>(0, x), expected[x]) << "estimate at " << x;
    EXPECT_EQ(raw.at<uint16_t>(1, x), 0) << "no estimate at " << x;
  }
  const cv::Mat back = bdis::readConfidence(file.str());
  ASSERT_EQ(back.type(), CV_32FC1);
  EXPECT_FLOAT_EQ(back.at<float>(0, 4), 32768.f / 65535);
  EXPECT_EQ(back.at<float>(1, 4), 0.f);

  TempPath eight_bit(".png");
  cv::imwrite(eight_bit.str(), cv::Mat(4, 4, CV_8UC1, cv::Scalar(3)));
  EXPECT_THROW(bdis::readConfidence(eight_bit.str()), std::runtime_error);
  EXPECT_THROW(bdis::writeConfidencePng(file.str(), d, c.colRange(0, 4)), std::runtime_error);

  // The float TIFF: the same estimates, each confidence as it is (NaN 0 and
  // above 1 clamped), strictly positive, so that 0 still means none.
  TempPath tiff(".tiff");
  bdis::writeConfidenceTiff(tiff.str(), d, c);
  const cv::Mat exact = bdis::readConfidence(tiff.str());
  ASSERT_EQ(exact.type(), CV_32FC1);
  const float expected_float[8] = {std::numeric_limits<float>::min(), 1e-9f, 0.49f * step, 1.5f * step, 0.5f, 1.f, 1.f,
                                   std::numeric_limits<float>::min()};
  for (int x = 0; x < 8; ++x) {
    EXPECT_EQ(exact.at<float>(0, x), expected_float[x]) << "estimate at " << x;
    EXPECT_EQ(exact.at<float>(1, x), 0.f) << "no estimate at " << x;
  }
  EXPECT_THROW(bdis::writeConfidenceTiff(tiff.str(), d, c.colRange(0, 4)), std::runtime_error);
}

// ---------------------------------------------------------------------------
// StereoSequence and findDataDir
// ---------------------------------------------------------------------------

TEST(EvaluationSequence, ListsCommonPairsAndReadsThem) {
  TempPath root("");
  const fs::path r(root.str());
  for (const char* sub : {"left", "right", "gt_disparity"}) fs::create_directories(r / sub);
  const cv::Mat grey(40, 50, CV_8UC1, cv::Scalar(77));
  const cv::Mat bgra(40, 50, CV_8UC4, cv::Scalar(1, 2, 3, 255));
  cv::imwrite((r / "left" / "b.png").string(), grey);
  cv::imwrite((r / "right" / "b.png").string(), grey);
  cv::imwrite((r / "left" / "a.png").string(), bgra);
  cv::imwrite((r / "right" / "a.png").string(), bgra);
  cv::imwrite((r / "left" / "c.png").string(), grey);  // no right image: not a pair
  cv::Mat gt(40, 50, CV_32FC1, cv::Scalar(12.5f));
  gt.at<float>(0, 0) = kNoDisparity;
  bdis::writeDisparityPng((r / "gt_disparity" / "a.png").string(), gt);

  const bdis::StereoSequence seq = bdis::StereoSequence::open(root.str());
  ASSERT_EQ(seq.names, (std::vector<std::string>{"a.png", "b.png"}));
  EXPECT_TRUE(seq.has_ground_truth);
  EXPECT_EQ(seq.left(0).type(), CV_8UC3);  // BGRA comes back as BGR
  EXPECT_EQ(seq.left(1).type(), CV_8UC1);
  EXPECT_EQ(seq.right(1).at<uchar>(3, 3), 77);
  const cv::Mat g = seq.groundTruth(0);
  ASSERT_EQ(g.type(), CV_32FC1);
  EXPECT_EQ(g.at<float>(0, 0), 0.f);  // unknown is 0 here, not -1
  EXPECT_EQ(g.at<float>(1, 1), 12.5f);
  EXPECT_THROW(seq.groundTruth(1), std::runtime_error);  // no file for b.png
  EXPECT_THROW(seq.left(2), std::out_of_range);
}

TEST(EvaluationSequence, OpenRejectsIncompleteFolders) {
  TempPath root("");
  const fs::path r(root.str());
  fs::create_directories(r / "left");
  EXPECT_THROW(bdis::StereoSequence::open(root.str()), std::runtime_error);  // no right/
  fs::create_directories(r / "right");
  EXPECT_THROW(bdis::StereoSequence::open(root.str()), std::runtime_error);  // no pairs
  cv::imwrite((r / "left" / "x.png").string(), cv::Mat(4, 4, CV_16UC1, cv::Scalar(1000)));
  cv::imwrite((r / "right" / "x.png").string(), cv::Mat(4, 4, CV_16UC1, cv::Scalar(1000)));
  std::ofstream((r / "left" / "y.png").string()) << "not a png";
  std::ofstream((r / "right" / "y.png").string()) << "not a png";
  const bdis::StereoSequence seq = bdis::StereoSequence::open(root.str());
  ASSERT_EQ(seq.names, (std::vector<std::string>{"x.png", "y.png"}));
  EXPECT_FALSE(seq.has_ground_truth);
  // 16-bit comes back as stored, for the matcher to reject with its message.
  EXPECT_EQ(seq.left(0).type(), CV_16UC1);
  EXPECT_THROW(seq.right(1), std::runtime_error);  // unreadable
}

TEST(EvaluationSequence, FindDataDirHonoursEnvironment) {
  const char* old = std::getenv("BDIS_DATA_DIR");
  const std::optional<std::string> saved = old ? std::optional<std::string>(old) : std::nullopt;
  setenv("BDIS_DATA_DIR", "/some/where/data", 1);
  EXPECT_EQ(bdis::findDataDir(), "/some/where/data");
  if (saved) {
    setenv("BDIS_DATA_DIR", saved->c_str(), 1);
  } else {
    unsetenv("BDIS_DATA_DIR");
  }
}

}  // namespace
