// The mirrored pyramid of the left-right check (pyramid.hpp): its
// finest level holds one search band of rows at a time, and every row it
// holds must equal the row of the whole mirrored level, bit for bit. And the
// rectification seams each input row loses with its black frame.
#include <gtest/gtest.h>

#include <cstring>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "pyramid.hpp"

namespace {

using bdis::detail::lumaOfBgrRow;
using bdis::detail::lumaOfBgrRowPortable;
using bdis::detail::MirroredPyramid;
using bdis::detail::PyramidLevel;
using bdis::detail::StereoPyramid;

/// A textured BGR pair with what makes validity matter: a black border down
/// the left side of the left image, a black hole in the right one.
std::pair<cv::Mat, cv::Mat> texturedPairWithInvalidPixels(int w, int h) {
  cv::RNG rng(7);
  cv::Mat left(h, w, CV_8UC3), right(h, w, CV_8UC3);
  // Not darker than a rectification seam: only the pixel next to the black
  // border is taken for the blend between frame and image.
  rng.fill(left, cv::RNG::UNIFORM, 21, 255);
  rng.fill(right, cv::RNG::UNIFORM, 21, 255);
  left.colRange(0, 9).setTo(cv::Scalar::all(0));
  right(cv::Rect(w / 2, h / 3, 15, 11)).setTo(cv::Scalar::all(0));
  return {left, right};
}

template <typename T>
bool sameRow(const T* a, const T* b, int n) {
  return std::memcmp(a, b, sizeof(T) * static_cast<size_t>(n)) == 0;
}

/// Rows [from, to) of `banded` against the same level rows of `whole`.
void expectSameRows(const PyramidLevel& banded, const PyramidLevel& whole, int from, int to) {
  const int w = whole.width;
  for (int y = from; y < to; ++y) {
    SCOPED_TRACE("level row " + std::to_string(y));
    EXPECT_TRUE(sameRow(banded.leftRow(y), whole.leftRow(y), w));
    EXPECT_TRUE(sameRow(banded.gradientRow(y), whole.gradientRow(y), w));
    EXPECT_TRUE(sameRow(banded.rightRow(y), whole.rightRow(y), w));
    EXPECT_TRUE(sameRow(banded.leftValidRow(y), whole.leftValidRow(y), w));
    EXPECT_TRUE(sameRow(banded.rightValidRow(y), whole.rightValidRow(y), w));
    // The kernels read the zero padding around the right rows and their validity.
    EXPECT_EQ(banded.rightRow(y)[-1], 0.f);
    EXPECT_EQ(banded.rightRow(y)[w], 0.f);
    EXPECT_EQ(banded.rightValidRow(y)[-1], 0);
    EXPECT_EQ(banded.rightValidRow(y)[w], 0);
  }
}

TEST(MirroredPyramid, WholeLevelIsTheFlippedPair) {
  const auto [left, right] = texturedPairWithInvalidPixels(203, 121);
  StereoPyramid source;
  MirroredPyramid mirrored;
  source.build(left, right, 3, 1);
  const int h = source.level(1).height;
  mirrored.build(source, 3, 1, h);
  mirrored.loadFinestRows(source.level(1), 0, h);
  const PyramidLevel& from = source.level(1);
  const PyramidLevel& l = mirrored.level(1);
  ASSERT_EQ(l.width, 101);
  ASSERT_EQ(l.height, 60);
  int invalid_left = 0, invalid_right = 0;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < l.width; ++x) {
      const int fx = l.width - 1 - x;
      ASSERT_EQ(l.leftRow(y)[x], from.right(y, fx)) << x << "," << y;
      ASSERT_EQ(l.rightRow(y)[x], from.left(y, fx)) << x << "," << y;
      ASSERT_EQ(l.leftValidRow(y)[x], from.right_valid(y, fx)) << x << "," << y;
      ASSERT_EQ(l.rightValidRow(y)[x], from.left_valid(y, fx)) << x << "," << y;
      invalid_left += l.leftValidRow(y)[x] == 0;
      invalid_right += l.rightValidRow(y)[x] == 0;
    }
  }
  // The right image's hole (15x11 at level 0) and the left image's border
  // (9 columns and the blended one after them) reach level 1; the flags say
  // what the rows say.
  EXPECT_GT(invalid_left, 20);
  EXPECT_EQ(invalid_right, 5 * h);
  EXPECT_FALSE(l.left_all_valid);
  EXPECT_FALSE(l.right_all_valid);
}

TEST(MirroredPyramid, BandedLevelHoldsTheRowsOfTheWholeOne) {
  const auto [left, right] = texturedPairWithInvalidPixels(203, 121);
  StereoPyramid source;
  MirroredPyramid whole, banded;
  source.build(left, right, 3, 1);
  const int h = source.level(1).height;  // 60
  constexpr int kBandRows = 13;
  whole.build(source, 3, 1, h);
  whole.loadFinestRows(source.level(1), 0, h);
  banded.build(source, 3, 1, kBandRows);
  // Bands as the search loads them (overlapping, the last one flush with
  // the bottom, one shorter than the capacity), then one back at the top.
  for (const auto& [from, to] : std::vector<std::pair<int, int>>{
           {0, 13}, {10, 23}, {20, 33}, {47, 60}, {52, 60}, {0, 13}}) {
    SCOPED_TRACE("band " + std::to_string(from) + ".." + std::to_string(to));
    banded.loadFinestRows(source.level(1), from, to);
    EXPECT_EQ(banded.level(1).first_row, from);
    expectSameRows(banded.level(1), whole.level(1), from, to);
  }
  // The band is all the memory the level takes.
  EXPECT_EQ(banded.level(1).left.rows, kBandRows);
  EXPECT_EQ(banded.level(1).left_gx.rows, kBandRows);
  // A band taller than that is a caller's error, not a write past the buffer.
  EXPECT_THROW(banded.loadFinestRows(source.level(1), 0, kBandRows + 1), cv::Exception);
  // Coarser levels are mirrored whole.
  EXPECT_EQ(banded.level(2).first_row, 0);
  expectSameRows(banded.level(2), whole.level(2), 0, whole.level(2).height);
}

/// What invalidateSeams must do, one pixel at a time.
void seamsOnePixelAtATime(const uchar* grey, int w, uchar* valid) {
  for (const int side : {+1, -1}) {
    int i = side > 0 ? 0 : w - 1;
    const int end = side > 0 ? w : -1;
    if (valid[i]) continue;
    while (i != end && !valid[i]) i += side;
    for (int n = 0; n < 8 && i != end && grey[i] <= 20; ++n, i += side) valid[i] = 0;
    if (i != end) valid[i] = 0;
  }
}

// Black frames of every width on either side (none, a few pixels, past a
// word of eight, the whole row), dark seams of every length behind them,
// black holes inside: the frame, its seam and the blended pixel are taken
// out, nothing else.
TEST(StereoPyramid, SeamsAfterTheBlackFrameAreOutsideTheView) {
  cv::RNG rng(3);
  int rows_with_frames = 0, seam_pixels = 0;
  for (const int w : {1, 7, 8, 9, 31, 200}) {
    for (int trial = 0; trial < 400; ++trial) {
      std::vector<uchar> grey(static_cast<size_t>(w)), valid(grey.size());
      for (uchar& g : grey) g = static_cast<uchar>(rng.uniform(21, 256));
      const int left = rng.uniform(0, w + 1), right = rng.uniform(0, w + 1);
      for (int x = 0; x < left; ++x) grey[static_cast<size_t>(x)] = 0;
      for (int x = w - right; x < w; ++x) grey[static_cast<size_t>(x)] = 0;
      for (int k = rng.uniform(0, 10), x = left; k > 0 && x < w; --k, ++x) {
        if (grey[static_cast<size_t>(x)] != 0) grey[static_cast<size_t>(x)] = static_cast<uchar>(rng.uniform(1, 21));
      }
      for (int x = w - right - 1, k = rng.uniform(0, 10); k > 0 && x >= 0; --k, --x) {
        if (grey[static_cast<size_t>(x)] != 0) grey[static_cast<size_t>(x)] = static_cast<uchar>(rng.uniform(1, 21));
      }
      if (w > 20 && rng.uniform(0, 2)) grey[static_cast<size_t>(w / 2)] = 0;  // a hole, not a frame
      for (size_t x = 0; x < grey.size(); ++x) valid[x] = grey[x] != 0;
      std::vector<uchar> expected = valid;
      seamsOnePixelAtATime(grey.data(), w, expected.data());
      bdis::detail::invalidateSeams(grey.data(), w, valid.data());
      ASSERT_EQ(valid, expected) << "w " << w << ", frames " << left << " / " << right;
      rows_with_frames += left > 0 || right > 0;
      for (size_t x = 0; x < grey.size(); ++x) seam_pixels += grey[x] != 0 && !valid[x];
    }
  }
  EXPECT_GT(rows_with_frames, 2000);
  EXPECT_GT(seam_pixels, 4000);  // 4935 with this seed
}

TEST(StereoPyramid, PixelsBelowTheDarkFloorAreOutsideTheView) {
  // Grey below dark_floor_grey in either view is invalid, like black; the
  // floor's own grey level and 0 (no floor) leave the pixel valid.
  cv::Mat left(64, 64, CV_8UC1, cv::Scalar(120)), right(64, 64, CV_8UC1, cv::Scalar(120));
  left(cv::Rect(10, 10, 4, 4)).setTo(9);
  left(cv::Rect(30, 10, 4, 4)).setTo(10);
  right(cv::Rect(40, 20, 2, 2)).setTo(3);
  for (const int floor : {0, 10}) {
    StereoPyramid p;
    p.build(left, right, 2, 0, 256, floor);
    const PyramidLevel& l0 = p.level(0);
    const bool dark_invalid = floor == 10;
    EXPECT_EQ(l0.leftValidRow(11)[11] == 0, dark_invalid) << floor;
    EXPECT_EQ(l0.rightValidRow(21)[41] == 0, dark_invalid) << floor;
    EXPECT_EQ(l0.leftValidRow(11)[31], 1) << floor;
    EXPECT_EQ(l0.leftValidRow(30)[30], 1) << floor;
    EXPECT_EQ(p.level(1).leftValidRow(5)[5] == 0, dark_invalid) << floor;
  }
  // The BGR path, whose luma has its own kernel, the same.
  cv::Mat left_bgr, right_bgr;
  cv::cvtColor(left, left_bgr, cv::COLOR_GRAY2BGR);
  cv::cvtColor(right, right_bgr, cv::COLOR_GRAY2BGR);
  StereoPyramid p;
  p.build(left_bgr, right_bgr, 2, 1, 256, 10);
  EXPECT_EQ(p.level(0).leftValidRow(11)[11], 0);
  EXPECT_EQ(p.level(0).leftValidRow(11)[31], 1);
  EXPECT_EQ(p.level(1).leftValidRow(5)[5], 0);
  EXPECT_EQ(p.level(1).rightValidRow(10)[20], 0);
  EXPECT_EQ(p.level(1).leftValidRow(20)[20], 1);
}

TEST(StereoPyramid, ClippedPixelsAreOutsideTheView) {
  // Grey 255 in either view (a clipped highlight) is invalid from
  // saturation_grey 255 on, like black; 256 leaves every lit pixel valid.
  cv::Mat left(64, 64, CV_8UC1, cv::Scalar(120)), right(64, 64, CV_8UC1, cv::Scalar(120));
  left(cv::Rect(10, 10, 4, 4)).setTo(255);
  right(cv::Rect(40, 20, 2, 2)).setTo(255);
  for (const int saturation : {255, 256}) {
    StereoPyramid p;
    p.build(left, right, 2, 0, saturation);
    const PyramidLevel& l0 = p.level(0);
    const bool clipped_invalid = saturation == 255;
    EXPECT_EQ(l0.leftValidRow(11)[11] == 0, clipped_invalid) << saturation;
    EXPECT_EQ(l0.rightValidRow(21)[41] == 0, clipped_invalid) << saturation;
    EXPECT_EQ(l0.leftValidRow(30)[30], 1) << saturation;
    // Level 1 averages 2x2 pixels: valid only where all four are.
    EXPECT_EQ(p.level(1).leftValidRow(5)[5] == 0, clipped_invalid) << saturation;
  }
}

TEST(StereoPyramid, GreyAndValidityOfBgrRowsFollowTheLumaFormula) {
  // Rec. 601 luma in 8.8 fixed point; black pixels and grey levels from
  // `saturated` on invalid. Every row width from 1 to 100 takes the SIMD
  // kernel's whole blocks and its tail apart; the dispatching function and
  // the portable loop must give the same bytes.
  cv::RNG rng(3);
  int black = 0, clipped = 0;
  for (int w = 1; w <= 100; ++w) {
    for (const int saturated : {-1, 0, 1, 128, 250, 255, 256, 300}) {
      cv::Mat row(1, w, CV_8UC3);
      rng.fill(row, cv::RNG::UNIFORM, 0, 256);
      for (int x = 0; x < w; ++x) {
        const int kind = rng.uniform(0, 6);
        if (kind == 0) row.at<cv::Vec3b>(0, x) = cv::Vec3b(0, 0, 0);
        if (kind == 1) row.at<cv::Vec3b>(0, x) = cv::Vec3b(255, 255, 255);
        if (kind == 2) row.at<cv::Vec3b>(0, x) = cv::Vec3b(0, 0, static_cast<uchar>(rng.uniform(1, 256)));
      }
      std::vector<uchar> grey(w), valid(w), portable_grey(w), portable_valid(w);
      lumaOfBgrRow(row.ptr(), w, saturated, grey.data(), valid.data());
      lumaOfBgrRowPortable(row.ptr(), w, saturated, portable_grey.data(), portable_valid.data());
      for (int x = 0; x < w; ++x) {
        const cv::Vec3b px = row.at<cv::Vec3b>(0, x);
        const int expected_grey = (29 * px[0] + 150 * px[1] + 77 * px[2] + 128) >> 8;
        const bool is_black = px == cv::Vec3b(0, 0, 0);
        const int expected_valid = !is_black && expected_grey < saturated;
        black += is_black;
        clipped += !is_black && expected_grey >= saturated;
        ASSERT_EQ(grey[x], expected_grey) << "w " << w << " x " << x;
        ASSERT_EQ(valid[x], expected_valid) << "w " << w << " x " << x << " saturated " << saturated;
        ASSERT_EQ(portable_grey[x], grey[x]) << "w " << w << " x " << x;
        ASSERT_EQ(portable_valid[x], valid[x]) << "w " << w << " x " << x;
      }
    }
  }
  EXPECT_GT(black, 3000);    // both validity cases occur often
  EXPECT_GT(clipped, 10000);
}

}  // namespace
