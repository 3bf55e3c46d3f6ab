// Sliding box sums of two maps at once, for the confidence cues that look at
// a pixel's neighbourhood (slant_cue.hpp, support_cue.hpp): separable, in row
// loops that vectorise, with buffers kept for the next frame of the same size.
#pragma once

#include <algorithm>
#include <vector>

#include <opencv2/core.hpp>

namespace bdis {
namespace detail {

/// sum[x] += row[x] and sum[x] -= row[x] for x < w: a vertical box sliding
/// down one row in, one row out.
void addRow(int w, const float* row, float* sum);
void subtractRow(int w, const float* row, float* sum);

/// mean[x] = sum[x] / count[x] where a box holds an estimate (count >= 1),
/// kNoDisparity where it holds none.
void boxMeanRow(int w, const float* sum, const float* count, float* mean);

/// The derivative along one axis of box means from those `step` before and
/// after (kNoDisparity where a box holds no estimate), times `inv_step`:
/// central where both exist, one-sided against the centre where one does,
/// 0 where neither does. Branch-free.
inline float slopeAcross(float before, float centre, float after, float inv_step) {
  const bool has_before = before >= 0.f, has_after = after >= 0.f;
  const float hi = has_after ? after : centre;
  const float lo = has_before ? before : centre;
  const float halves = has_before && has_after ? 0.5f : 1.f;
  return (hi - lo) * halves * inv_step;
}

/// out[i] = the sum of values[j] over |j - i| <= half, j in 0..n-1: a box
/// along a line, clipped to it, summed as BoxSums sums a row. `padded`
/// is scratch (n + 2 half values), kept for the next call.
void boxSumsAlongLine(int n, int half, const float* values, std::vector<float>& padded, float* out);

/// flags[x] = 1 where a[x] and b[x] are both estimates (>= 0) that differ
/// by more than `jump`, else 0, for x < n: the jumps between two rows, or
/// between a row and itself shifted by one (edge_distance_cue.hpp,
/// scale_choice.hpp).
void jumpFlags(int n, const float* a, const float* b, float jump, unsigned char* flags);

/// The two raster passes of a city-block distance transform (steps of 1),
/// one row at a time: each value becomes the least of itself, the
/// neighbouring row's (`other`, null for none) plus 1, and, along the row,
/// its left (forward pass) or right (backward pass) neighbour's plus 1.
/// Rows start at 0 where the distance is measured from, far elsewhere.
void distanceForwardRow(int n, const float* other, float* row);
void distanceBackwardRow(int n, const float* other, float* row);

/// A row of 2 x 2 blocks' values onto the w pixels of a block row: pixel x
/// gets block x / 2 (`blocks` holds at least (w + 1) / 2 values).
void blocksToPixels(int w, const float* blocks, float* pixels);

/// blocks[bx] = columns[2 bx] + columns[2 bx + 1] for bx < bw: a row of
/// per-column values of w columns summed per 2 x 2 block. `columns` holds
/// 2 bw values; an odd width's missing column (index w) is set to 0 first.
void columnPairsToBlocks(int w, int bw, float* columns, float* blocks);

/// A block row's factors (one per 2 x 2 block of block row `by`) onto the
/// confidences of its pixel rows, where they have an estimate (disparity >=
/// 0). `pixel_factor` is scratch of one pixel row, kept for the next call.
void multiplyBlockRowAtEstimates(int by, const float* block_factor, std::vector<float>& pixel_factor,
                                 const cv::Mat1f& disparity, cv::Mat1f& confidence);

/// Half a patch side in 2 x 2 blocks, `patch_px` / 4 rounded half up (at
/// least 1): the radius of the patch-sized boxes of blocks (slant_cue.hpp,
/// neighbourhood_cue.hpp), 2 at the default patch side 8.
inline int halfPatchInBlocks(int patch_px) { return std::max(1, (patch_px / 2 + 1) / 2); }

/// The estimates (>= 0; none below) of a finest-level disparity map taken
/// in 2 x 2 blocks, one block row at a time: per block, their sum and their
/// count; the last block row and column are clipped to the map. For the cues
/// that work on blocks (consensus_cue.hpp, residual_fit_cue.hpp). Scratch is
/// kept for the next row and frame.
class BlockEstimates {
 public:
  /// Blocks 0..bw-1 (bw <= (w + 1) / 2) of block row `by` into sum and count.
  void row(const cv::Mat1f& disparity, int by, int bw, float* sum, float* count);
  /// The same with the sum of another map's `values` at the estimates.
  void row(const cv::Mat1f& disparity, const cv::Mat1f& values, int by, int bw, float* sum, float* count);

 private:
  std::vector<float> pair_sum_, pair_count_;  ///< the two rows' sums, per column
};

/// The sums of two maps A and B over a (2r+1) x (2r+1) box around each pixel,
/// the box clipped to the map, in one sweep down the rows: begin(), then
/// sweep(fill, use). `fill(y, a, b)` writes row y of A (and of B) at columns
/// 0..w-1 of `a` and `b` (r zero columns lie before and after them); `use(y,
/// sum_a, sum_b)` gets the box sums of row y. Rows are filled in order, each
/// once; row y is used once rows up to y + r are filled, so every row is
/// filled before it is used (`use` may change the maps `fill` reads, in rows
/// it is handed). Only 2r + 2 rows of horizontal sums are kept. With
/// begin(..., false) only A is summed (`b` and `sum_b` are null).
class BoxSums {
 public:
  void begin(int w, int h, int r, bool with_b = true);

  template <class Fill, class Use>
  void sweep(Fill&& fill, Use&& use) {
    const float *sum_a, *sum_b;
    for (int y = 0; y < h_ + r_; ++y) {
      if (y < h_) {
        fill(y, padded_a_.data() + r_, with_b_ ? padded_b_.data() + r_ : nullptr);
        sumRow(y);
      }
      if (y >= r_) {
        nextColumnSums(y - r_, sum_a, sum_b);
        use(y - r_, sum_a, sum_b);
      }
    }
  }

 private:
  /// The horizontal box sums of the filled row become row y's.
  void sumRow(int y);
  /// The box sums of row y, for y = 0, 1, ..., h-1 in turn: the vertical box
  /// slides down one row in, one row out (counts stay exact; the sums'
  /// rounding is far below what a cue resolves).
  void nextColumnSums(int y, const float*& a, const float*& b);

  int w_ = 0, h_ = 0, r_ = 0, ring_rows_ = 1;
  bool with_b_ = true;
  std::vector<float> padded_a_, padded_b_;  ///< a row, r zeros each side
  cv::Mat1f ring_a_, ring_b_;               ///< the last 2r + 2 rows' horizontal sums
  std::vector<float> column_a_, column_b_;  ///< one row of box sums
};

/// The mean of the estimates of `disparity` (>= 0) per 2 x 2 block (blocks
/// from `blocks`), over boxes of 2 rb + 1 blocks clipped to the map, into
/// `mean`: (h + 1) / 2 + 1 rows of (w + 1) / 2 + 2 rb columns, block (bx, by)
/// at mean(by, bx + rb); kNoDisparity where a box holds no estimate, in the
/// rb columns each side and in the last row, which stands in for the rows
/// beyond the map. Sums through `sums`; the buffers are kept for the next
/// frame of the same size.
void boxMeansOfBlockEstimates(const cv::Mat1f& disparity, int rb, BlockEstimates& blocks, BoxSums& sums,
                              cv::Mat1f& mean);

}  // namespace detail
}  // namespace bdis
