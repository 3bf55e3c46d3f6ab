// The finest level's search order (band_schedule.hpp).
#include <gtest/gtest.h>

#include <vector>

#include "band_schedule.hpp"

namespace {

using bdis::detail::bandLevelRows;
using bdis::detail::PatchGrid;
using bdis::detail::scheduleFinestBands;
using bdis::detail::SearchBand;

PatchGrid grid(int height, int p, int stride) {
  PatchGrid g;
  g.layout(64, height, p, stride);
  return g;
}

/// Every patch row of `g` in exactly one band of `pass`, top to bottom.
void expectCoveredOnceInOrder(const std::vector<SearchBand>& bands, SearchBand::Pass pass, const PatchGrid& g) {
  int next = 0;
  for (const SearchBand& b : bands) {
    if (b.pass != pass) continue;
    EXPECT_EQ(b.top, next);
    EXPECT_GT(b.bottom, b.top);
    EXPECT_EQ(b.first_row, g.ys[static_cast<size_t>(b.top)]);
    EXPECT_EQ(b.end_row, g.ys[static_cast<size_t>(b.bottom - 1)] + g.p);
    next = b.bottom;
  }
  EXPECT_EQ(next, g.rows());
}

TEST(BandSchedule, LevelRowsOfABand) {
  EXPECT_EQ(bandLevelRows(8, 3, 8, 240), 7 * 3 + 8);
  EXPECT_EQ(bandLevelRows(8, 3, 8, 20), 20);   // no more than the level
  EXPECT_EQ(bandLevelRows(0, 3, 8, 240), 240); // 0: the whole level
  EXPECT_EQ(bandLevelRows(1, 5, 8, 240), 8);
}

TEST(BandSchedule, LeftPassAloneInBandsFromTheTop) {
  const PatchGrid left = grid(120, 8, 3);  // 39 patch rows, the last flush with the bottom
  std::vector<SearchBand> bands;
  scheduleFinestBands(left, 8, nullptr, 0, bands);
  ASSERT_EQ(bands.size(), 5u);  // 8, 8, 8, 8, 7
  expectCoveredOnceInOrder(bands, SearchBand::Pass::Left, left);
  EXPECT_EQ(bands.back().bottom - bands.back().top, left.rows() - 32);
  EXPECT_EQ(bands.back().end_row, 120);
  // 0: one band over the whole level.
  scheduleFinestBands(left, 0, nullptr, 0, bands);
  ASSERT_EQ(bands.size(), 1u);
  EXPECT_EQ(bands[0].bottom, left.rows());
}

TEST(BandSchedule, CheckBandsFollowAsSoonAsTheirRowsAreSearched) {
  for (int band_rows : {1, 4, 8, 0}) {
    SCOPED_TRACE("band rows " + std::to_string(band_rows));
    const PatchGrid left = grid(150, 8, 3), check = grid(150, 8, 5);
    std::vector<SearchBand> bands;
    scheduleFinestBands(left, band_rows, &check, band_rows, bands);
    expectCoveredOnceInOrder(bands, SearchBand::Pass::Left, left);
    expectCoveredOnceInOrder(bands, SearchBand::Pass::Check, check);
    int left_done = 0;  // level rows the left pass has searched so far
    for (size_t i = 0; i < bands.size(); ++i) {
      const SearchBand& b = bands[i];
      if (b.pass == SearchBand::Pass::Left) {
        // No sooner: a left band runs only while the next check band still waits for rows.
        for (size_t j = i + 1; j < bands.size(); ++j) {
          if (bands[j].pass != SearchBand::Pass::Check) continue;
          EXPECT_LT(left_done, bands[j].end_row) << "band " << i << " ran although check band " << j << " was ready";
          break;
        }
        left_done = b.end_row;
      } else {
        // No later than needed, and never before its rows are searched.
        EXPECT_GE(left_done, b.end_row) << "check band " << i << " reads rows the left pass has not searched";
      }
    }
  }
}

}  // namespace
