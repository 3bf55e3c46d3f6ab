// The regular grid of square patches laid over one pyramid level.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace bdis {
namespace detail {

/// Patch grid spacing at a level searched with the given overlap:
/// max(1, round(p * (1 - overlap))).
inline int patchStride(int p, double overlap) {
  return std::max(1, static_cast<int>(std::lround(p * (1.0 - overlap))));
}

/// Patch origins along one axis: a regular stride plus one patch flush with
/// the far border, so every pixel is covered. clear() keeps capacity.
inline void patchAxis(int extent, int p, int stride, std::vector<int>& out) {
  out.clear();
  for (int x = 0; x + p <= extent; x += stride) out.push_back(x);
  if (out.empty() || out.back() != extent - p) out.push_back(extent - p);
}

/// Patches of side p at origins xs x ys, numbered row by row.
struct PatchGrid {
  int p = 0;
  std::vector<int> xs, ys;

  void layout(int width, int height, int patch_size, int stride) {
    p = patch_size;
    patchAxis(width, p, stride, xs);
    patchAxis(height, p, stride, ys);
  }
  int columns() const { return static_cast<int>(xs.size()); }
  int rows() const { return static_cast<int>(ys.size()); }
  size_t size() const { return xs.size() * ys.size(); }
  /// Level rows that patch rows [top, bottom) read: [firstRow, endRow).
  int firstRow(int top) const { return ys[static_cast<size_t>(top)]; }
  int endRow(int bottom) const { return ys[static_cast<size_t>(bottom - 1)] + p; }
};

}  // namespace detail
}  // namespace bdis
