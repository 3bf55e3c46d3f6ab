// The block grid (block_grid.hpp) and its confidence cue (block_grid_cue.hpp):
// JPEG round trips show their grid's column phase, a view cropped after coding
// moves it, the views' phases give the disparity where their seams align, an
// uncoded view shows none; the pyramid gathers the steps only when asked; the
// cue's factor is exact near and away from the aligned disparities, and its
// seam term doubts more where the seams are all of the texture.
#include <algorithm>
#include <cstdio>
#include <vector>

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "bdis_stereo/matcher.hpp"
#include "cues_product_params.hpp"
#include "block_grid.hpp"
#include "block_grid_cue.hpp"
#include "pyramid.hpp"

namespace {

using bdis::kNoDisparity;
using bdis::detail::alignedGridDisparity;
using bdis::detail::PhaseSteps;

/// Weak smooth texture (grey 60..100), as tissue shows.
cv::Mat weakTexture(int width, int height, int seed) {
  cv::Mat noise(height, width, CV_32FC1), grey;
  cv::RNG rng(static_cast<uint64>(seed));
  rng.fill(noise, cv::RNG::UNIFORM, 0.0, 1.0);
  cv::GaussianBlur(noise, noise, cv::Size(0, 0), 3.0);
  cv::normalize(noise, noise, 60, 100, cv::NORM_MINMAX);
  noise.convertTo(grey, CV_8UC1);
  return grey;
}

cv::Mat jpegRoundTrip(const cv::Mat& image, int quality) {
  std::vector<uchar> bytes;
  cv::imencode(".jpg", image, bytes, {cv::IMWRITE_JPEG_QUALITY, quality});
  return cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
}

/// Every row's steps of a mono image.
PhaseSteps columnSteps(const cv::Mat& grey) {
  PhaseSteps steps;
  std::vector<uchar> valid(static_cast<size_t>(grey.cols));
  for (int y = 0; y < grey.rows; ++y) {
    const uchar* row = grey.ptr<uchar>(y);
    for (int x = 0; x < grey.cols; ++x) valid[static_cast<size_t>(x)] = row[x] != 0;
    steps.addRow(row, valid.data(), grey.cols);
  }
  return steps;
}

TEST(BlockGrid, ARowsStepsAreThoseOfEachPairOfNeighbours) {
  // The vectorised row against one add() per step, with invalid pixels and
  // steps above the flat limit among them, on widths around whole blocks.
  cv::RNG rng(5);
  for (int width : {3, 8, 9, 17, 64, 71}) {
    std::vector<uchar> grey(static_cast<size_t>(width)), valid(static_cast<size_t>(width));
    for (int x = 0; x < width; ++x) {
      grey[static_cast<size_t>(x)] = static_cast<uchar>(rng.uniform(0, 40));
      valid[static_cast<size_t>(x)] = rng.uniform(0, 5) != 0;
    }
    PhaseSteps row, one_by_one;
    row.addRow(grey.data(), valid.data(), width);
    for (int x = 1; x < width; ++x) {
      one_by_one.add(x % 8, grey[static_cast<size_t>(x)], grey[static_cast<size_t>(x - 1)],
                     valid[static_cast<size_t>(x)] && valid[static_cast<size_t>(x - 1)]);
    }
    for (int k = 0; k < 8; ++k) {
      EXPECT_EQ(row.sum[k], one_by_one.sum[k]) << width << " " << k;
      EXPECT_EQ(row.count[k], one_by_one.count[k]) << width << " " << k;
    }
  }
}

TEST(BlockGrid, TheViewsPhasesGiveTheDisparityWhereTheirSeamsAlign) {
  const cv::Mat coded = jpegRoundTrip(weakTexture(336, 240, 3), 75);
  const PhaseSteps left = columnSteps(coded.colRange(0, 320));
  EXPECT_GE(left.contrast(), 1.2);
  EXPECT_EQ(left.strongestPhase(), 0);  // seams between columns 8 i - 1 and 8 i
  EXPECT_EQ(alignedGridDisparity(left, left), 0);
  // Cropped by 3 columns after coding: seams at x = 8 i - 3, phase 5; the
  // left's at 8 i meet them at d = 8 i - (8 j - 3), 3 modulo 8.
  const PhaseSteps right = columnSteps(coded.colRange(3, 323));
  EXPECT_EQ(right.strongestPhase(), 5);
  EXPECT_EQ(alignedGridDisparity(left, right), 3);
  EXPECT_EQ(alignedGridDisparity(right, left), 5);
}

TEST(BlockGrid, AnUncodedViewHasNoGridToAlign) {
  const cv::Mat plain = weakTexture(320, 240, 3);
  const PhaseSteps coded = columnSteps(jpegRoundTrip(plain, 75));
  const PhaseSteps uncoded = columnSteps(plain);
  EXPECT_LT(uncoded.contrast(), 1.1);
  EXPECT_EQ(alignedGridDisparity(coded, uncoded), -1);
  EXPECT_EQ(alignedGridDisparity(uncoded, coded), -1);
  EXPECT_EQ(alignedGridDisparity(PhaseSteps(), PhaseSteps()), -1);  // no steps at all
}

TEST(BlockGrid, ThePyramidGathersTheStepsOnlyWhenAsked) {
  const cv::Mat coded = jpegRoundTrip(weakTexture(320, 240, 4), 75);
  for (int first_searched_level : {0, 1}) {
    bdis::detail::StereoPyramid pyramid;
    pyramid.build(coded, coded, 3, first_searched_level);
    EXPECT_EQ(alignedGridDisparity(pyramid.columnSteps(true), pyramid.columnSteps(false)), -1);
    pyramid.build(coded, coded, 3, first_searched_level, 256, 0, /*probe_block_grid=*/true);
    EXPECT_EQ(alignedGridDisparity(pyramid.columnSteps(true), pyramid.columnSteps(false)), 0);
    EXPECT_GT(pyramid.columnSteps(true).count[0], 256);  // every 16th row of 240
  }
}

/// The median confidence (the cues' product, which the cue scales) of the
/// estimates of a pair at disparity `shift` (weak texture), both views cut
/// from one image and then, if `quality` > 0, JPEG-coded each on its own (so
/// their grids align at multiples of 8).
double medianConfidence(int shift, int quality) {
  const cv::Mat texture = weakTexture(320 + shift, 240, 9);
  cv::Mat left = texture.colRange(0, 320).clone(), right = texture.colRange(shift, 320 + shift).clone();
  if (quality > 0) {
    left = jpegRoundTrip(left, quality);
    right = jpegRoundTrip(right, quality);
  }
  bdis::Matcher matcher(bdis_test::cuesProductParams());
  bdis::MatchResult result;
  matcher.compute(left, right, result);
  std::vector<float> confidence;
  for (int y = 0; y < result.disparity.rows; ++y) {
    for (int x = 0; x < result.disparity.cols; ++x) {
      if (result.disparity.at<float>(y, x) >= 0.f) confidence.push_back(result.confidence.at<float>(y, x));
    }
  }
  EXPECT_GT(confidence.size(), 20000u) << shift << " " << quality;
  std::nth_element(confidence.begin(), confidence.begin() + confidence.size() / 2, confidence.end());
  return confidence.empty() ? 0.0 : confidence[confidence.size() / 2];
}

TEST(BlockGridCue, TheMatcherLowersEstimatesWhereCodedViewsGridsAlign) {
  // The same texture at 24 px (the grids align) and at 28 px (half a block
  // from it): coded, the first keeps about a quarter of the second's
  // confidence (the cue's 1 - 3/4); uncoded, as much. Measured: the medians'
  // ratio 0.26 coded, 1.00 uncoded.
  const double coded = medianConfidence(24, 75) / medianConfidence(28, 75);
  const double uncoded = medianConfidence(24, 0) / medianConfidence(28, 0);
  std::printf("median confidence at 24 px over 28 px: coded %.2f, uncoded %.2f\n", coded, uncoded);
  EXPECT_GT(coded, 0.15);
  EXPECT_LT(coded, 0.4);
  EXPECT_GT(uncoded, 0.7);
  EXPECT_LT(uncoded, 1.4);
}

TEST(BlockGridCue, LowersEstimatesNearTheAlignedDisparitiesOnly) {
  // Level 1 (scale 2), grids aligned at 3 modulo 8, reach 1 px, doubt 0.75:
  // an estimate at 11 or 19 input px keeps a quarter, at half a px from them
  // five eighths, a px or more away all of it.
  const std::vector<float> input_px = {11.f, 19.f, 3.f, 10.5f, 19.5f, 12.f, 10.f, 15.f, 7.f, 0.f};
  const std::vector<float> expected = {0.25f, 0.25f, 0.25f, 0.625f, 0.625f, 1.f, 1.f, 1.f, 1.f, 1.f};
  cv::Mat1f d(1, static_cast<int>(input_px.size()) + 1), c(d.size(), 0.8f);
  for (size_t i = 0; i < input_px.size(); ++i) d(0, static_cast<int>(i)) = input_px[i] / 2.f;
  d(0, d.cols - 1) = kNoDisparity;
  bdis::detail::BlockGridCue cue;
  const bdis::detail::BlockGridDoubts plain{1.f, 0.75f, 2.f, 0.f};
  cue.apply(d, 2, {3, 0}, cv::Mat1f(), cv::Mat1b(), 8, plain, c);
  for (size_t i = 0; i < expected.size(); ++i) EXPECT_NEAR(c(0, static_cast<int>(i)), 0.8f * expected[i], 1e-6f) << i;
  EXPECT_EQ(c(0, d.cols - 1), 0.8f);  // no estimate
  // Views without a grid: nothing changes.
  const cv::Mat1f before = c.clone();
  cue.apply(d, 2, {-1, 0}, cv::Mat1f(), cv::Mat1b(), 8, plain, c);
  EXPECT_EQ(cv::norm(c, before, cv::NORM_INF), 0.0);
}

/// A level-1 grey map (scale 2: a codec block is 4 columns) with the given
/// step energy on the seam columns and off them: `seam_step` grey levels
/// across every seam (columns 4k - 1 to 4k, the left phase 0) and `other_step`
/// across every other column pair, all pixels valid.
cv::Mat1f levelOneSteps(int w, int h, float seam_step, float other_step) {
  cv::Mat1f grey(h, w);
  for (int y = 0; y < h; ++y) {
    float g = 100.f;
    for (int x = 0; x < w; ++x) {
      if (x > 0) g += (x % 4 == 0 ? seam_step : other_step) * (((x / 4) % 2) ? -1.f : 1.f);
      grey(y, x) = g;
    }
  }
  return grey;
}

TEST(BlockGridCue, DoubtsMoreWhereTheSeamsAreAllOfTheTexture) {
  // Level 1, grids aligned at 0 modulo 8, seam term reach 2 px, doubt 0.9.
  // Flat blocks with 4-level seams: the seams hold all the step energy, so
  // an estimate at 16 input px keeps 0.25 x 0.1 of its confidence, at 17 px
  // (the plain term's reach, half the seam term's) 1 x 0.55. Texture with
  // equal steps on every column: the seams hold their gridless share (the
  // box's seam columns over its columns), so only the plain term applies
  // (0.25, then 1).
  const int w = 40, h = 20;
  const cv::Mat1b valid(h, w, uchar{1});
  const bdis::detail::BlockGridDoubts doubts{1.f, 0.75f, 2.f, 0.9f};
  cv::Mat1f d(h, w, kNoDisparity);
  // Columns whose 9-column box holds two seams; column 20's holds three,
  // and its gridless share is three in nine, not one in four.
  d(10, 18) = 16.f / 2.f;
  d(10, 20) = 16.f / 2.f;
  d(10, 22) = 17.f / 2.f;
  d(10, 26) = 20.f / 2.f;  // half a block from the aligned disparities: nothing
  bdis::detail::BlockGridCue cue;
  struct Case {
    float seam_step, other_step, at16, at17;
  };
  for (const Case& k : {Case{4.f, 0.f, 0.25f * 0.1f, 0.55f}, Case{3.f, 3.f, 0.25f, 1.f}}) {
    cv::Mat1f c(h, w, 0.8f);
    cue.apply(d, 2, {0, 0}, levelOneSteps(w, h, k.seam_step, k.other_step), valid, 8, doubts, c);
    EXPECT_NEAR(c(10, 18), 0.8f * k.at16, 1e-4f) << k.seam_step << " / " << k.other_step;
    EXPECT_NEAR(c(10, 20), 0.8f * k.at16, 1e-4f) << k.seam_step << " / " << k.other_step;
    EXPECT_NEAR(c(10, 22), 0.8f * k.at17, 1e-4f) << k.seam_step << " / " << k.other_step;
    EXPECT_NEAR(c(10, 26), 0.8f, 1e-6f);
    EXPECT_EQ(c(0, 0), 0.8f);  // no estimate
  }
  // The left view's seams one input column later (phase 2: level column 1
  // modulo 4): the same flat blocks' seams now lie off the counted columns,
  // their share below the gridless one, and only the plain term applies.
  cv::Mat1f c(h, w, 0.8f);
  cue.apply(d, 2, {0, 2}, levelOneSteps(w, h, 4.f, 0.f), valid, 8, doubts, c);
  EXPECT_NEAR(c(10, 18), 0.8f * 0.25f, 1e-4f);
}

}  // namespace
