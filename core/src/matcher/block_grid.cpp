#include "block_grid.hpp"

#include <algorithm>
#include <cstdlib>

#include "bdis_stereo/pair_check.hpp"
#include "patch_kernels.hpp"  // BDIS_ROW_LOOP

namespace bdis {
namespace detail {
namespace {

constexpr long kMinStepsPerPhase = 256;

/// The flat steps of one row into one lane per phase; x from 1 to width - 1.
/// Whole blocks at a time, branch-free, so the compiler vectorises them; the
/// columns before the first whole block and after the last one by one.
BDIS_ROW_LOOP
void addRowSteps(const uchar* __restrict grey, const uchar* __restrict valid, int width, int* __restrict lane_sum,
                 int* __restrict lane_count) {
  int sums[kCodecBlock] = {}, counts[kCodecBlock] = {};
  auto one_step = [&](int x) {
    const int s = std::abs(int(grey[x]) - int(grey[x - 1]));
    const int flat = valid[x] & valid[x - 1] & int(s <= kMaxFlatStep);
    sums[x % kCodecBlock] += s * flat;
    counts[x % kCodecBlock] += flat;
  };
  for (int x = 1; x < std::min(width, kCodecBlock); ++x) one_step(x);
  int x = kCodecBlock;
  for (; x + kCodecBlock <= width; x += kCodecBlock) {
    const uchar* g = grey + x;
    const uchar* v = valid + x;
    for (int k = 0; k < kCodecBlock; ++k) {
      const int s = std::abs(int(g[k]) - int(g[k - 1]));
      const int flat = v[k] & v[k - 1] & int(s <= kMaxFlatStep);
      sums[k] += s * flat;
      counts[k] += flat;
    }
  }
  for (; x < width; ++x) one_step(x);
  std::copy(sums, sums + kCodecBlock, lane_sum);
  std::copy(counts, counts + kCodecBlock, lane_count);
}

}  // namespace

void PhaseSteps::add(int phase, int a, int b, bool both_valid) {
  const int step = std::abs(a - b);
  if (!both_valid || step > kMaxFlatStep) return;
  sum[phase] += step;
  count[phase] += 1;
}

void PhaseSteps::addRow(const uchar* grey, const uchar* valid, int width) {
  int lane_sum[kCodecBlock] = {}, lane_count[kCodecBlock] = {};
  addRowSteps(grey, valid, width, lane_sum, lane_count);
  for (int k = 0; k < kCodecBlock; ++k) {
    sum[k] += lane_sum[k];
    count[k] += lane_count[k];
  }
}

double PhaseSteps::contrast() const {
  double mean[kCodecBlock];
  for (int k = 0; k < kCodecBlock; ++k) {
    if (count[k] < kMinStepsPerPhase) return 1.0;
    mean[k] = sum[k] / static_cast<double>(count[k]);
  }
  std::sort(mean, mean + kCodecBlock);
  const double others_median = mean[(kCodecBlock - 1) / 2];  // the median of the other seven
  return others_median > 0 ? mean[kCodecBlock - 1] / others_median : 1.0;
}

int PhaseSteps::strongestPhase() const {
  int best = 0;
  double best_mean = -1.0;
  for (int k = 0; k < kCodecBlock; ++k) {
    const double mean = count[k] ? sum[k] / static_cast<double>(count[k]) : 0.0;
    if (mean > best_mean) {
      best = k;
      best_mean = mean;
    }
  }
  return best;
}

int alignedGridDisparity(const PhaseSteps& left_columns, const PhaseSteps& right_columns) {
  if (!BlockArtefactCheck{left_columns.contrast()}.looksBlockCompressed() ||
      !BlockArtefactCheck{right_columns.contrast()}.looksBlockCompressed()) {
    return -1;
  }
  // A seam at left column x_l = 8 i + a meets one at right column
  // x_r = 8 j + b where d = x_l - x_r = a - b modulo the block.
  return ((left_columns.strongestPhase() - right_columns.strongestPhase()) % kCodecBlock + kCodecBlock) %
         kCodecBlock;
}

}  // namespace detail
}  // namespace bdis
