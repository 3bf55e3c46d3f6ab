// checkDisparitySign: a pair in the right order has its matches at d >= 0,
// a swapped pair at d < 0; flat or unequal input gives no verdict or throws.
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include <opencv2/imgproc.hpp>

#include "bdis_stereo/evaluation.hpp"
#include "bdis_stereo/pair_check.hpp"
#include "test_images.hpp"

namespace {

// Smooth random texture; right = left shifted by `shift` px (left(x) = right(x - shift)).
void makePair(int shift, cv::Mat& left, cv::Mat& right, int width = 320, int height = 240) {
  bdis_test::blurredNoisePair(7, shift, width, height, 2.0, left, right);
}

TEST(PairCheck, RightOrderHasNoNegativeMatches) {
  cv::Mat l, r;
  makePair(16, l, r);
  const bdis::DisparitySignCheck c = bdis::checkDisparitySign(l, r);
  EXPECT_GE(c.distinct_patches, 100);
  EXPECT_LT(c.negativeShare(), 0.05);
  EXPECT_FALSE(c.looksSwapped());
}

TEST(PairCheck, SwappedViewsLookSwapped) {
  cv::Mat l, r;
  makePair(16, l, r);
  const bdis::DisparitySignCheck c = bdis::checkDisparitySign(r, l);
  EXPECT_GE(c.distinct_patches, 100);
  EXPECT_GT(c.negativeShare(), 0.95);
  EXPECT_TRUE(c.looksSwapped());
}

TEST(PairCheck, FlatOrBlackImagesGiveNoVerdict) {
  const cv::Mat flat(240, 320, CV_8UC1, cv::Scalar(128)), black(240, 320, CV_8UC3, cv::Scalar::all(0));
  EXPECT_EQ(bdis::checkDisparitySign(flat, flat).distinct_patches, 0);
  EXPECT_FALSE(bdis::checkDisparitySign(flat, flat).looksSwapped());
  EXPECT_EQ(bdis::checkDisparitySign(black, black).distinct_patches, 0);
}

TEST(PairCheck, BadInputThrows) {
  cv::Mat l, r;
  makePair(4, l, r);
  EXPECT_THROW(bdis::checkDisparitySign(l, r.colRange(0, 100)), std::invalid_argument);
  EXPECT_THROW(bdis::checkDisparitySign(cv::Mat(), cv::Mat()), std::invalid_argument);
  cv::Mat l16;
  l.convertTo(l16, CV_16UC1);
  EXPECT_THROW(bdis::checkDisparitySign(l16, l16), std::invalid_argument);
}

// The real sequences (specular highlights, black borders, dark periphery).
TEST(PairCheck, SharedSequencesInOrderAndSwapped) {
  const std::string data = bdis::findDataDir();
  if (data.empty()) {
    const char* ci = std::getenv("CI");
    if (ci && std::string(ci) == "true") FAIL() << "CI=true but the shared data folder was not found";
    GTEST_SKIP() << "shared data folder not found; set BDIS_DATA_DIR";
  }
  for (const char* name : {"synthetic_colon_diffuse", "synthetic_colon_specular", "invivo_hamlyn_a",
                           "invivo_hamlyn_b"}) {
    const bdis::StereoSequence seq = bdis::StereoSequence::open(data + "/" + name);
    for (size_t f = 0; f < seq.names.size(); f += 3) {
      const cv::Mat l = seq.left(f), r = seq.right(f);
      const bdis::DisparitySignCheck in_order = bdis::checkDisparitySign(l, r);
      const bdis::DisparitySignCheck swapped = bdis::checkDisparitySign(r, l);
      EXPECT_FALSE(in_order.looksSwapped()) << name << " frame " << f << ": " << in_order.negative << " of "
                                            << in_order.distinct_patches << " negative";
      EXPECT_TRUE(swapped.looksSwapped()) << name << " frame " << f << " swapped: " << swapped.negative
                                          << " of " << swapped.distinct_patches << " negative";
    }
  }
}

}  // namespace
