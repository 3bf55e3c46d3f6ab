#include "band_schedule.hpp"

#include <algorithm>

namespace bdis {
namespace detail {

int bandLevelRows(int band_patch_rows, int stride, int p, int level_height) {
  if (band_patch_rows <= 0) return level_height;
  return std::min(level_height, (band_patch_rows - 1) * stride + p);
}

void scheduleFinestBands(const PatchGrid& left, int left_band_rows, const PatchGrid* check,
                         int check_band_rows, std::vector<SearchBand>& out) {
  out.clear();
  const int left_rows = left.rows();
  const int check_rows = check ? check->rows() : 0;
  const int left_band = left_band_rows > 0 ? left_band_rows : left_rows;
  const int check_band = check_band_rows > 0 ? check_band_rows : check_rows;
  int left_top = 0, check_top = 0;
  int left_done = 0;  // level rows the left pass has searched
  while (left_top < left_rows || check_top < check_rows) {
    const int check_bottom = std::min(check_rows, check_top + check_band);
    // The check's next band waits until the left pass has searched every row it reads.
    const bool check_waits = check_top < check_rows && left_done < check->endRow(check_bottom);
    if (left_top < left_rows && (check_top >= check_rows || check_waits)) {
      const int bottom = std::min(left_rows, left_top + left_band);
      out.push_back({SearchBand::Pass::Left, left_top, bottom, left.firstRow(left_top), left.endRow(bottom)});
      left_top = bottom;
      left_done = left.endRow(bottom);
    } else {
      out.push_back({SearchBand::Pass::Check, check_top, check_bottom, check->firstRow(check_top),
                     check->endRow(check_bottom)});
      check_top = check_bottom;
    }
  }
}

}  // namespace detail
}  // namespace bdis
