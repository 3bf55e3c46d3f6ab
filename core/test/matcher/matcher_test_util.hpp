// Helpers shared by the matcher's behaviour tests: running a matcher on a
// pair, the output contract, error statistics against known disparity.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <utility>

#include <opencv2/core.hpp>

#include "bdis_stereo/matcher.hpp"
#include "test_images.hpp"

namespace matcher_test {

using bdis::kNoDisparity;
using bdis::Matcher;
using bdis::MatcherParams;
using bdis::MatchResult;
using namespace bdis_test;

constexpr int kW = 320;
constexpr int kH = 240;

/// Full-resolution side of one patch at the finest searched level.
inline int patchAtFullRes(const MatcherParams& p, int width = 640) { return p.patchSizeFor(width) << p.finestLevelFor(width); }

/// Margin that keeps every evaluated pixel two patches (at full resolution)
/// away from the image border, where fewer patches cover a pixel.
inline int accuracyMargin(const MatcherParams& p) { return 2 * patchAtFullRes(p); }

/// Least-squares line d = intercept + slope * t through the estimates in roi,
/// t the column (along_columns) or the row; NaNs without estimates.
inline std::pair<double, double> fitDisparityLine(const cv::Mat& disparity, const cv::Rect& roi,
                                           bool along_columns) {
  double n = 0, sum_t = 0, sum_d = 0, sum_tt = 0, sum_td = 0;
  for (int y = roi.y; y < roi.br().y; ++y) {
    for (int x = roi.x; x < roi.br().x; ++x) {
      const float d = disparity.at<float>(y, x);
      if (d < 0.f) continue;
      const double t = along_columns ? x : y;
      n += 1, sum_t += t, sum_d += d, sum_tt += t * t, sum_td += t * d;
    }
  }
  if (n == 0) return {std::nan(""), std::nan("")};
  const double slope = (n * sum_td - sum_t * sum_d) / (n * sum_tt - sum_t * sum_t);
  return {slope, (sum_d - slope * sum_t) / n};
}

inline MatchResult run(const MatcherParams& params, const cv::Mat& left, const cv::Mat& right) {
  Matcher m(params);
  MatchResult r;
  m.compute(left, right, r);
  return r;
}

inline void printStats(const char* what, const ErrorStats& s) {
  std::printf("[measured] %s: density %.4f, median |err| %.4f px, p95 %.4f px, max %.4f px, "
              "bias %+.4f px\n",
              what, s.density(), s.median, s.p95, s.max, s.mean_signed);
}

// Output contract of one result: sizes, types, value ranges, and that
// "no estimate" is consistent across the three outputs.
inline void expectValidResult(const MatchResult& r, cv::Size size, bool with_variance) {
  ASSERT_EQ(r.disparity.size(), size);
  ASSERT_EQ(r.disparity.type(), CV_32FC1);
  ASSERT_EQ(r.confidence.size(), size);
  ASSERT_EQ(r.confidence.type(), CV_32FC1);
  if (with_variance) {
    ASSERT_EQ(r.variance.size(), size);
    ASSERT_EQ(r.variance.type(), CV_32FC1);
  } else {
    ASSERT_TRUE(r.variance.empty()) << "variance must be empty when compute_variance is off";
  }
  int bad_disparity = 0, bad_confidence = 0, bad_variance = 0;
  for (int y = 0; y < size.height; ++y) {
    for (int x = 0; x < size.width; ++x) {
      const float d = r.disparity.at<float>(y, x);
      const float c = r.confidence.at<float>(y, x);
      const bool has = d >= 0.f;
      if (!has && d != kNoDisparity) ++bad_disparity;  // also catches NaN and inf
      if (has && !std::isfinite(d)) ++bad_disparity;
      if (!(c >= 0.f && c <= 1.f) || (!has && c != 0.f)) ++bad_confidence;
      if (with_variance) {
        const float v = r.variance.at<float>(y, x);
        if (has ? !(v >= 0.f && std::isfinite(v)) : !std::isnan(v)) ++bad_variance;
      }
    }
  }
  EXPECT_EQ(bad_disparity, 0) << "disparity must be >= 0 (finite) or exactly kNoDisparity";
  EXPECT_EQ(bad_confidence, 0) << "confidence must be in [0, 1] and 0 without an estimate";
  EXPECT_EQ(bad_variance, 0) << "variance must be finite >= 0 with an estimate, NaN without";
}

inline double density(const cv::Mat& disparity) {
  return static_cast<double>(cv::countNonZero(disparity >= 0.f)) / disparity.total();
}

}  // namespace matcher_test
