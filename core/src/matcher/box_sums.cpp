#include "box_sums.hpp"

#include <algorithm>
#include <cmath>

#include "bdis_stereo/matcher.hpp"  // kNoDisparity
#include "patch_kernels.hpp"        // BDIS_ROW_LOOP

namespace bdis {
namespace detail {
namespace {

/// out[x] = sum of padded[x .. x + side - 1], summed in that order.
BDIS_ROW_LOOP
void boxRowAnySide(int w, int side, const float* __restrict padded, float* __restrict out) {
  for (int x = 0; x < w; ++x) out[x] = 0.f;
  for (int k = 0; k < side; ++k) {
    for (int x = 0; x < w; ++x) out[x] += padded[x + k];
  }
}

// The same sums for a side known when compiling: the terms stay in a
// register (a load and an add per term, one store per pixel, instead of a
// load, an add and a store per term), summed in the same order, so the
// results are bit for bit those of boxRowAnySide.
#define BDIS_BOX_ROW_FIXED(SIDE)                                                        \
  BDIS_ROW_LOOP                                                                         \
  void boxRow##SIDE(int w, const float* __restrict padded, float* __restrict out) {    \
    for (int x = 0; x < w; ++x) {                                                       \
      float sum = 0.f;                                                                  \
      for (int k = 0; k < SIDE; ++k) sum += padded[x + k];                              \
      out[x] = sum;                                                                     \
    }                                                                                   \
  }
// The boxes of the default patch side, 8: in 2 x 2 blocks, the slant and
// neighbourhood cues' and the correction's slope's 5, the support cue's 7
// and the consensus cue's 17; along the image border cue's lines, 9 px.
BDIS_BOX_ROW_FIXED(5)
BDIS_BOX_ROW_FIXED(7)
BDIS_BOX_ROW_FIXED(9)
BDIS_BOX_ROW_FIXED(17)
#undef BDIS_BOX_ROW_FIXED

void boxRow(int w, int side, const float* padded, float* out) {
  switch (side) {
    case 5: return boxRow5(w, padded, out);
    case 7: return boxRow7(w, padded, out);
    case 9: return boxRow9(w, padded, out);
    case 17: return boxRow17(w, padded, out);
    default: return boxRowAnySide(w, side, padded, out);
  }
}

/// Per column, the sum of the values at the estimates of rows a and b (the
/// estimates themselves or another map's values there) and their count (b
/// may be a again, with weight 0: the last block row of an odd height).
BDIS_ROW_LOOP
void pairOfRows(int w, const float* __restrict a, const float* __restrict b, const float* __restrict value_a,
                const float* __restrict value_b, float b_weight, float* __restrict sum, float* __restrict count) {
  for (int x = 0; x < w; ++x) {
    const float has_a = a[x] >= 0.f ? 1.f : 0.f;
    const float has_b = b[x] >= 0.f ? b_weight : 0.f;
    sum[x] = has_a * value_a[x] + has_b * value_b[x];
    count[x] = has_a + has_b;
  }
}

}  // namespace

void BlockEstimates::row(const cv::Mat1f& disparity, int by, int bw, float* sum, float* count) {
  row(disparity, disparity, by, bw, sum, count);
}

void BlockEstimates::row(const cv::Mat1f& disparity, const cv::Mat1f& values, int by, int bw, float* sum,
                         float* count) {
  const int w = disparity.cols, h = disparity.rows;
  CV_Assert(bw <= (w + 1) / 2 && 2 * by < h && values.size() == disparity.size());
  pair_sum_.resize(static_cast<size_t>(bw) * 2);
  pair_count_.resize(static_cast<size_t>(bw) * 2);
  const int y1 = std::min(2 * by + 1, h - 1);
  const int columns = std::min(w, 2 * bw);
  pairOfRows(columns, disparity[2 * by], disparity[y1], values[2 * by], values[y1], y1 > 2 * by ? 1.f : 0.f,
             pair_sum_.data(), pair_count_.data());
  columnPairsToBlocks(w, bw, pair_sum_.data(), sum);
  columnPairsToBlocks(w, bw, pair_count_.data(), count);
}

BDIS_ROW_LOOP
void addRow(int w, const float* __restrict row, float* __restrict sum) {
  for (int x = 0; x < w; ++x) sum[x] += row[x];
}

BDIS_ROW_LOOP
void subtractRow(int w, const float* __restrict row, float* __restrict sum) {
  for (int x = 0; x < w; ++x) sum[x] -= row[x];
}

BDIS_ROW_LOOP
void boxMeanRow(int w, const float* __restrict sum, const float* __restrict count, float* __restrict mean) {
  for (int x = 0; x < w; ++x) mean[x] = count[x] > 0.5f ? sum[x] / std::max(count[x], 1.f) : kNoDisparity;
}

BDIS_ROW_LOOP
void jumpFlags(int n, const float* __restrict a, const float* __restrict b, float jump,
               unsigned char* __restrict flags) {
  for (int x = 0; x < n; ++x) flags[x] = (a[x] >= 0.f) & (b[x] >= 0.f) & (std::fabs(a[x] - b[x]) > jump);
}

void boxSumsAlongLine(int n, int half, const float* values, std::vector<float>& padded, float* out) {
  padded.assign(static_cast<size_t>(n + 2 * half), 0.f);
  std::copy(values, values + n, padded.begin() + half);
  boxRow(n, 2 * half + 1, padded.data(), out);
}

namespace {

BDIS_ROW_LOOP
void distanceFromRow(int n, const float* __restrict other, float* __restrict row) {
  for (int x = 0; x < n; ++x) row[x] = std::min(row[x], other[x] + 1.f);
}

}  // namespace

void distanceForwardRow(int n, const float* other, float* row) {
  if (other) distanceFromRow(n, other, row);
  for (int x = 1; x < n; ++x) row[x] = std::min(row[x], row[x - 1] + 1.f);
}

void distanceBackwardRow(int n, const float* other, float* row) {
  if (other) distanceFromRow(n, other, row);
  for (int x = n - 2; x >= 0; --x) row[x] = std::min(row[x], row[x + 1] + 1.f);
}

BDIS_ROW_LOOP
void blocksToPixels(int w, const float* __restrict blocks, float* __restrict pixels) {
  const int pairs = w / 2;
  for (int bx = 0; bx < pairs; ++bx) {
    pixels[2 * bx] = blocks[bx];
    pixels[2 * bx + 1] = blocks[bx];
  }
  if (w % 2 != 0) pixels[w - 1] = blocks[pairs];
}

namespace {

BDIS_ROW_LOOP
void addColumnPairs(int bw, const float* __restrict columns, float* __restrict blocks) {
  for (int bx = 0; bx < bw; ++bx) blocks[bx] = columns[2 * bx] + columns[2 * bx + 1];
}

}  // namespace

void columnPairsToBlocks(int w, int bw, float* columns, float* blocks) {
  if (2 * bw > w) columns[w] = 0.f;  // an odd width's last block has one column
  addColumnPairs(bw, columns, blocks);
}

namespace {

BDIS_ROW_LOOP
void multiplyAtEstimatesRow(int w, const float* __restrict factor, const float* __restrict disparity,
                            float* __restrict confidence) {
  for (int x = 0; x < w; ++x) confidence[x] = disparity[x] >= 0.f ? confidence[x] * factor[x] : confidence[x];
}

}  // namespace

void multiplyBlockRowAtEstimates(int by, const float* block_factor, std::vector<float>& pixel_factor,
                                 const cv::Mat1f& disparity, cv::Mat1f& confidence) {
  const int w = disparity.cols, h = disparity.rows;
  pixel_factor.resize(static_cast<size_t>(w));
  blocksToPixels(w, block_factor, pixel_factor.data());
  for (int y = 2 * by; y < std::min(2 * by + 2, h); ++y) {
    multiplyAtEstimatesRow(w, pixel_factor.data(), disparity[y], confidence[y]);
  }
}

void BoxSums::begin(int w, int h, int r, bool with_b) {
  w_ = w;
  h_ = h;
  r_ = r;
  ring_rows_ = 2 * r + 2;
  with_b_ = with_b;
  // Only the padding is set here; every other element is written per row.
  padded_a_.resize(static_cast<size_t>(w + 2 * r));
  padded_b_.resize(static_cast<size_t>(w + 2 * r));
  for (std::vector<float>* padded : {&padded_a_, &padded_b_}) {
    std::fill(padded->begin(), padded->begin() + r, 0.f);
    std::fill(padded->end() - r, padded->end(), 0.f);
  }
  ring_a_.create(ring_rows_, w);
  if (with_b) ring_b_.create(ring_rows_, w);
  column_a_.resize(static_cast<size_t>(w));
  column_b_.resize(static_cast<size_t>(w));
}

void BoxSums::sumRow(int y) {
  boxRow(w_, 2 * r_ + 1, padded_a_.data(), ring_a_[y % ring_rows_]);
  if (with_b_) boxRow(w_, 2 * r_ + 1, padded_b_.data(), ring_b_[y % ring_rows_]);
}

void BoxSums::nextColumnSums(int y, const float*& a, const float*& b) {
  // The rows added: y + r, and at the start the r above it; the row
  // subtracted, y - r - 1, was filled at most 2r + 1 rows before y + r, so
  // the ring still holds it.
  if (y == 0) {
    std::fill(column_a_.begin(), column_a_.end(), 0.f);
    std::fill(column_b_.begin(), column_b_.end(), 0.f);
    for (int j = 0; j < std::min(h_, r_); ++j) {
      addRow(w_, ring_a_[j % ring_rows_], column_a_.data());
      if (with_b_) addRow(w_, ring_b_[j % ring_rows_], column_b_.data());
    }
  }
  if (y + r_ < h_) {
    addRow(w_, ring_a_[(y + r_) % ring_rows_], column_a_.data());
    if (with_b_) addRow(w_, ring_b_[(y + r_) % ring_rows_], column_b_.data());
  }
  if (y - r_ - 1 >= 0) {
    subtractRow(w_, ring_a_[(y - r_ - 1) % ring_rows_], column_a_.data());
    if (with_b_) subtractRow(w_, ring_b_[(y - r_ - 1) % ring_rows_], column_b_.data());
  }
  a = column_a_.data();
  b = with_b_ ? column_b_.data() : nullptr;
}

namespace {

/// `mean` as h + 1 rows of w + 2r columns: the r columns each side and the
/// last row kNoDisparity, the rest left for the box means.
void paddedMeanRows(int w, int h, int r, cv::Mat1f& mean) {
  mean.create(h + 1, w + 2 * r);
  for (int y = 0; y < h; ++y) {
    std::fill(mean[y], mean[y] + r, kNoDisparity);
    std::fill(mean[y] + r + w, mean[y] + w + 2 * r, kNoDisparity);
  }
  std::fill(mean[h], mean[h] + w + 2 * r, kNoDisparity);  // (setTo() would allocate)
}

}  // namespace

void boxMeansOfBlockEstimates(const cv::Mat1f& disparity, int rb, BlockEstimates& blocks, BoxSums& sums,
                              cv::Mat1f& mean) {
  const int bw = (disparity.cols + 1) / 2, bh = (disparity.rows + 1) / 2;
  paddedMeanRows(bw, bh, rb, mean);
  sums.begin(bw, bh, rb);
  sums.sweep([&](int by, float* sum, float* count) { blocks.row(disparity, by, bw, sum, count); },
             [&](int by, const float* sum, const float* count) { boxMeanRow(bw, sum, count, mean[by] + rb); });
}

}  // namespace detail
}  // namespace bdis
