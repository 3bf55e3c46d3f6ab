// The order in which the finest level is searched (docs/method.md, "Search
// order"): in bands of patch rows from the top, so that the forward and the
// backward pass of a band find its rows in cache; and, with the left-right
// check, the mirrored pair's bands in step with the left pass's, each as
// soon as the left pass has searched every level row it reads, so that the
// rows it mirrors are still in cache. The order changes no result: the check
// only reads the left pass's pyramid, which neither pass writes.
#pragma once

#include <vector>

#include "patch_grid.hpp"

namespace bdis {
namespace detail {

/// Level rows that a band of `band_patch_rows` patch rows (0: the whole
/// level) spans at most on a level `level_height` rows high searched with
/// patches of side p at the given stride.
int bandLevelRows(int band_patch_rows, int stride, int p, int level_height);

/// One band of the finest level's search.
struct SearchBand {
  enum class Pass { Left, Check };
  Pass pass;
  int top, bottom;          ///< patch rows [top, bottom) of the pass's grid
  int first_row, end_row;   ///< level rows [first_row, end_row) they read
};

/// Bands of `left_band_rows` patch rows of `left` (0: one band) and, when
/// `check` is given, of `check_band_rows` of `check`, in the order
/// described above, into `out` (cleared first; it keeps its capacity).
/// Every patch row of both grids lies in exactly one band.
void scheduleFinestBands(const PatchGrid& left, int left_band_rows, const PatchGrid* check,
                         int check_band_rows, std::vector<SearchBand>& out);

}  // namespace detail
}  // namespace bdis
