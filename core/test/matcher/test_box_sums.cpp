// Box sums (box_sums.hpp): the sliding 2-D boxes and the 1-D box along a line
// give the sums of the boxes clipped to the map, for the patch sides the
// cues use (compiled for their side) and for any other.
#include <algorithm>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "box_sums.hpp"

namespace {

using bdis::detail::BoxSums;
using bdis::detail::boxSumsAlongLine;

std::vector<float> randomValues(int n, int seed) {
  cv::RNG rng(static_cast<uint64>(seed));
  std::vector<float> values(static_cast<size_t>(n));
  for (float& v : values) v = rng.uniform(-50.f, 50.f);
  return values;
}

// Halves 4, 7 and 8 take the sides compiled in (9, 15, 17); 0, 1 and 5 the
// general loop. Lines shorter than the box clip it at both ends.
TEST(BoxSums, AlongALineEqualsTheClippedBoxSummedInOrder) {
  std::vector<float> padded, out;
  for (int half : {0, 1, 4, 5, 7, 8}) {
    for (int n : {1, 3, 9, 17, 40, 101}) {
      const std::vector<float> values = randomValues(n, 7 * n + half);
      out.assign(static_cast<size_t>(n), -1.f);
      boxSumsAlongLine(n, half, values.data(), padded, out.data());
      for (int i = 0; i < n; ++i) {
        float expected = 0.f;
        for (int j = i - half; j <= i + half; ++j) expected += (j >= 0 && j < n) ? values[static_cast<size_t>(j)] : 0.f;
        ASSERT_EQ(out[static_cast<size_t>(i)], expected) << "half " << half << ", n " << n << ", i " << i;
      }
    }
  }
}

TEST(BoxSums, AlongALineCountsTheOnesInTheBox) {
  std::vector<float> padded, out(10);
  const std::vector<float> ones(10, 1.f);
  boxSumsAlongLine(10, 3, ones.data(), padded, out.data());
  EXPECT_EQ(out, std::vector<float>({4, 5, 6, 7, 7, 7, 7, 6, 5, 4}));
}

// The 2-D sums slide down the rows (one row in, one out), so they may round
// differently from a sum in order, but far below what a cue resolves; the
// counts (small integers) stay exact. Radii 12 and 30 make boxes taller than
// the map (23 rows).
TEST(BoxSums, TwoMapsOverTheClippedBoxes) {
  const int w = 37, h = 23;
  cv::Mat1f a(h, w), b(h, w);
  cv::RNG rng(3);
  rng.fill(a, cv::RNG::UNIFORM, -50.f, 50.f);
  rng.fill(b, cv::RNG::UNIFORM, 0.f, 2.f);
  cv::Mat1f ones_b = b.clone();
  for (float& v : ones_b) v = std::floor(v);  // 0 or 1: a count
  for (int r : {1, 4, 7, 12, 30}) {
    BoxSums sums;
    sums.begin(w, h, r);
    int filled = 0, used = 0;
    sums.sweep(
        [&](int y, float* row_a, float* row_b) {
          ASSERT_EQ(y, filled++);
          std::copy(a[y], a[y] + w, row_a);
          std::copy(ones_b[y], ones_b[y] + w, row_b);
        },
        [&](int y, const float* sa, const float* sb) {
          ASSERT_EQ(y, used++);
          ASSERT_EQ(filled, std::min(h, y + r + 1)) << "row " << y << " is used once the rows of its box are filled";
          for (int x = 0; x < w; ++x) {
            double expected_a = 0.0, expected_b = 0.0;
            for (int v = std::max(0, y - r); v <= std::min(h - 1, y + r); ++v) {
              for (int u = std::max(0, x - r); u <= std::min(w - 1, x + r); ++u) {
                expected_a += a(v, u);
                expected_b += ones_b(v, u);
              }
            }
            ASSERT_NEAR(sa[x], expected_a, 1e-3) << "r " << r << " at " << x << ", " << y;
            ASSERT_EQ(sb[x], static_cast<float>(expected_b)) << "r " << r << " at " << x << ", " << y;
          }
        });
    EXPECT_EQ(used, h);
  }
}

}  // namespace
