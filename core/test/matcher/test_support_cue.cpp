// The support cue (support_cue.hpp) on hand-made maps whose neighbourhoods
// hold a known share of estimates.
#include <gtest/gtest.h>

#include "bdis_stereo/matcher.hpp"
#include "support_cue.hpp"

namespace {

using bdis::kNoDisparity;
using bdis::detail::SupportCue;

constexpr int kPatch = 8;          // level px: the box has 7 x 7 blocks of 2 x 2 px, side 14
constexpr float kHalving = 0.25f;  // share of the box without an estimate that halves

/// The factor the cue gives a pixel whose box lacks estimates at `missing` of its valid pixels.
float expectedFactor(float missing) { return 1.f / (1.f + (missing / kHalving) * (missing / kHalving)); }

struct Maps {
  cv::Mat1f disparity, confidence, grey;
  cv::Mat1b valid;
  Maps(int w, int h) : disparity(h, w, 20.f), confidence(h, w, 1.f), grey(h, w, 100.f), valid(h, w, uchar{1}) {}
  void removeEstimates(const cv::Rect& r) {
    disparity(r).setTo(kNoDisparity);
    confidence(r).setTo(0.f);
  }
  /// No estimate and invalid, at grey level `grey` (0: outside the view; 255: clipped).
  void invalidate(const cv::Rect& r, float grey_level) {
    removeEstimates(r);
    valid(r).setTo(0);
    grey(r).setTo(grey_level);
  }
  void apply(SupportCue& cue) { cue.apply(disparity, valid, grey, kPatch, kHalving, confidence); }
};

TEST(SupportCue, FullySupportedEstimatesKeepTheirConfidence) {
  Maps m(64, 48);
  SupportCue cue;
  m.apply(cue);
  EXPECT_EQ(cv::countNonZero(m.confidence != 1.f), 0);
}

TEST(SupportCue, EstimatesBesideAHoleGetTheFactorOfTheMissingShare) {
  Maps m(64, 48);
  m.removeEstimates(cv::Rect(32, 0, 32, 48));  // the right half has no estimate
  SupportCue cue;
  m.apply(cue);
  // Away from the top and bottom the box has 14 rows; at column x it spans
  // the columns of the blocks x / 2 - 3 .. x / 2 + 3, those from 32 on without estimates.
  for (int x = 16; x < 32; ++x) {
    const int last_column = 2 * (x / 2 + 3) + 1;
    const float missing = static_cast<float>(std::max(0, last_column - 31)) / 14.f;
    EXPECT_NEAR(m.confidence(24, x), expectedFactor(missing), 1e-5f) << "x " << x;
  }
  EXPECT_NEAR(m.confidence(24, 31), expectedFactor(6.f / 14.f), 1e-5f);  // about 0.25
  EXPECT_EQ(m.confidence(24, 25), 1.f);  // its box ends at column 31
  for (int x = 32; x < 64; ++x) EXPECT_EQ(m.confidence(24, x), 0.f) << "no estimate stays 0";
}

TEST(SupportCue, ALoneEstimateAmongHolesIsAlmostDiscounted) {
  Maps m(64, 48);
  m.removeEstimates(cv::Rect(0, 0, 64, 48));
  m.disparity(20, 30) = 12.f;
  m.confidence(20, 30) = 0.8f;
  SupportCue cue;
  m.apply(cue);
  EXPECT_NEAR(m.confidence(20, 30), 0.8f * expectedFactor(195.f / 196.f), 1e-5f);  // about 0.05
}

TEST(SupportCue, BlackFrameDoesNotCountAgainstAnEstimate) {
  // Pixels outside the view (invalid and dark: a rectification frame) can
  // have no estimate, so the border of the view keeps its confidence.
  Maps m(64, 48);
  m.invalidate(cv::Rect(0, 0, 10, 48), 0.f);
  SupportCue cue;
  m.apply(cue);
  EXPECT_EQ(cv::countNonZero(m.confidence.colRange(10, 64) != 1.f), 0);
}

TEST(SupportCue, SaturatedPixelsCountAsHoles) {
  // A clipped highlight (invalid and bright) is a failure of the
  // measurement: the tissue around it, where a highlight that moves between
  // the views leaves wrong matches, has less support.
  Maps m(64, 48);
  m.invalidate(cv::Rect(28, 18, 8, 8), 255.f);
  SupportCue cue;
  m.apply(cue);
  // Beside the highlight (block 13: columns 20 .. 33, rows 16 .. 29), its box
  // holds 6 of its 8 columns: 48 clipped pixels of 196.
  EXPECT_NEAR(m.confidence(22, 27), expectedFactor(48.f / 196.f), 1e-5f);
  EXPECT_EQ(m.confidence(22, 10), 1.f);  // out of reach
}

TEST(SupportCue, NearBlackPixelsInsideTheViewCountAsHoles) {
  // Below the dark floor (invalid, dark but not black) inside the row's
  // valid span: a near-black surface the matcher could not measure, such as
  // an instrument's shaft, whose neighbours' estimates are often its depth.
  Maps m(64, 48);
  m.invalidate(cv::Rect(28, 18, 8, 8), 6.f);
  SupportCue cue;
  m.apply(cue);
  EXPECT_NEAR(m.confidence(22, 27), expectedFactor(48.f / 196.f), 1e-5f);  // as a clipped highlight
  EXPECT_EQ(m.confidence(22, 10), 1.f);
}

TEST(SupportCue, DarkSeamAfterAFrameAndBlackHolesDoNotCount) {
  // A frame's dark seam reaches the row's end through the black: outside
  // the view, like the frame. A black hole inside the view (a dead pixel, a
  // masked instrument) is no failure of the measurement either.
  Maps m(64, 48);
  m.invalidate(cv::Rect(0, 0, 10, 48), 0.f);
  m.invalidate(cv::Rect(10, 0, 4, 48), 8.f);
  m.invalidate(cv::Rect(50, 0, 14, 48), 5.f);  // dark up to the row's end: no span reaches past it
  m.invalidate(cv::Rect(30, 20, 6, 6), 0.f);
  SupportCue cue;
  m.apply(cue);
  const cv::Mat1f inside = m.confidence(cv::Rect(14, 0, 36, 48));
  const cv::Mat1b hole = m.valid(cv::Rect(14, 0, 36, 48)) == 0;
  EXPECT_EQ(cv::countNonZero((inside != 1.f) & ~hole), 0);
}

TEST(SupportCue, TinyMapsAndReusedBuffers) {
  SupportCue cue;
  for (const auto& [w, h] : {std::pair<int, int>{1, 1}, {3, 40}, {40, 3}, {64, 48}, {5, 5}}) {
    Maps m(w, h);
    m.apply(cue);
    EXPECT_EQ(cv::countNonZero(m.confidence != 1.f), 0) << w << "x" << h;
  }
  Maps m(5, 5);
  m.removeEstimates(cv::Rect(0, 0, 5, 5));
  m.disparity(2, 2) = 3.f;
  m.confidence(2, 2) = 1.f;
  m.apply(cue);  // the box is the whole map, clipped: 1 estimate of 25 valid pixels
  EXPECT_NEAR(m.confidence(2, 2), expectedFactor(24.f / 25.f), 1e-5f);
}

}  // namespace
