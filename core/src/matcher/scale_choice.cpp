#include "scale_choice.hpp"

#include <algorithm>

#include "box_sums.hpp"       // jumpFlags
#include "patch_kernels.hpp"  // BDIS_ROW_LOOP

namespace bdis {
namespace detail {
namespace {

/// marks[x] = 1 where pixel x of a row takes part in a jump with a
/// 4-neighbour: `right` holds the jumps to the right neighbour (w - 1 of
/// them), `up` and `down` those to the rows above and below (0 at the map's
/// top and bottom).
BDIS_ROW_LOOP
void jumpMarksRow(int w, const unsigned char* __restrict right, const unsigned char* __restrict up,
                  const unsigned char* __restrict down, unsigned char* __restrict marks) {
  for (int x = 0; x < w; ++x) marks[x] = up[x] | down[x];
  for (int x = 0; x + 1 < w; ++x) marks[x] |= right[x];
  for (int x = 1; x < w; ++x) marks[x] |= right[x - 1];
}

/// out[x] = in[x] | in[x + offset] for x < n.
BDIS_ROW_LOOP
void orShifted(int n, int offset, const unsigned char* __restrict in, unsigned char* __restrict out) {
  for (int x = 0; x < n; ++x) out[x] = in[x] | in[x + offset];
}

/// last[x] = y where `marked[x]`.
BDIS_ROW_LOOP
void noteMarkedRow(int w, int y, const unsigned char* __restrict marked, int* __restrict last) {
  for (int x = 0; x < w; ++x) last[x] = marked[x] ? y : last[x];
}

/// Where both have an estimate, `coarser` is more confident and no jump was
/// marked at or after row `first_row` in the column, the row takes the
/// coarser estimate; returns how many it took.
BDIS_ROW_LOOP
int takeMoreConfidentRow(int w, int first_row, const int* __restrict last_jump, const float* __restrict cd,
                         const float* __restrict cc, const float* __restrict cv, float* __restrict d,
                         float* __restrict c, float* __restrict v) {
  int taken = 0;
  for (int x = 0; x < w; ++x) {
    const bool take = (d[x] >= 0.f) & (cd[x] >= 0.f) & (cc[x] > c[x]) & (last_jump[x] < first_row);
    d[x] = take ? cd[x] : d[x];
    c[x] = take ? cc[x] : c[x];
    if (v) v[x] = take ? cv[x] : v[x];
    taken += take;
  }
  return taken;
}

}  // namespace

void ScaleChoice::dilateRow(int w, int reach_px) {
  // The marks padded by reach_px zeros each side; a window of 2^k columns
  // from two of 2^(k-1), then the box as two windows that overlap.
  const int side = 2 * reach_px + 1;
  const int n = w + 2 * reach_px;
  unsigned char* in = marks_.data();
  unsigned char* out = windows_.data();
  int window = 1;
  while (2 * window <= side) {
    orShifted(n - 2 * window + 1, window, in, out);
    std::swap(in, out);
    window *= 2;
  }
  orShifted(w, side - window, in, near_row_.data());
}

int ScaleChoice::keepMoreConfident(const MatchResult& coarser, float jump_px, int reach_px, MatchResult& result) {
  CV_Assert(coarser.disparity.size() == result.disparity.size() && coarser.confidence.size() == result.disparity.size() &&
            result.confidence.size() == result.disparity.size() && result.disparity.type() == CV_32FC1);
  // Row y changes after the marks of row y + reach_px are made, which read
  // the disparities of rows y + reach_px - 1 .. y + reach_px + 1: with a
  // reach of 1 px or more, every jump is found on the disparities as they were.
  CV_Assert(reach_px >= 1);
  const bool with_variance = !result.variance.empty();
  CV_Assert(!with_variance || coarser.variance.size() == result.disparity.size());
  const int w = result.disparity.cols, h = result.disparity.rows;
  const auto row = [&](int y) { return result.disparity.ptr<float>(y); };
  right_.resize(static_cast<size_t>(w));
  up_.assign(static_cast<size_t>(w), 0);
  down_.resize(static_cast<size_t>(w));
  marks_.resize(static_cast<size_t>(w + 2 * reach_px));
  windows_.resize(marks_.size());
  near_row_.resize(static_cast<size_t>(w));
  // Per column, the last row with a jump marked within reach_px columns.
  last_jump_.assign(static_cast<size_t>(w), -2 * reach_px - 2);
  int taken = 0;
  for (int y_marks = 0; y_marks < h + reach_px; ++y_marks) {
    if (y_marks < h) {
      jumpFlags(w - 1, row(y_marks), row(y_marks) + 1, jump_px, right_.data());
      if (y_marks + 1 < h) {
        jumpFlags(w, row(y_marks), row(y_marks + 1), jump_px, down_.data());
      } else {
        std::fill(down_.begin(), down_.end(), 0);
      }
      // The padding too: the windows of the row before may have overwritten it.
      std::fill(marks_.begin(), marks_.begin() + reach_px, 0);
      std::fill(marks_.end() - reach_px, marks_.end(), 0);
      jumpMarksRow(w, right_.data(), up_.data(), down_.data(), marks_.data() + reach_px);
      std::swap(up_, down_);  // the jumps down from this row are the next row's up
      dilateRow(w, reach_px);
      noteMarkedRow(w, y_marks, near_row_.data(), last_jump_.data());
    }
    const int y = y_marks - reach_px;
    if (y < 0) continue;
    taken += takeMoreConfidentRow(w, y - reach_px, last_jump_.data(), coarser.disparity.ptr<float>(y),
                                  coarser.confidence.ptr<float>(y),
                                  with_variance ? coarser.variance.ptr<float>(y) : nullptr, row(y),
                                  result.confidence.ptr<float>(y),
                                  with_variance ? result.variance.ptr<float>(y) : nullptr);
  }
  return taken;
}

}  // namespace detail
}  // namespace bdis
