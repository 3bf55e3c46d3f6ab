#include "block_grid_cue.hpp"

#include <algorithm>
#include <cmath>

#include "block_grid.hpp"
#include "patch_kernels.hpp"  // BDIS_ROW_LOOP

namespace bdis {
namespace detail {

namespace {

/// One row's squared grey steps, each between pixels x - 1 and x (0 at x = 0
/// and where either is invalid), capped as PhaseSteps caps them, into `all`.
BDIS_ROW_LOOP
void stepEnergyRow(int w, const float* __restrict grey, const uchar* __restrict valid, float* __restrict all) {
  all[0] = 0.f;
  for (int x = 1; x < w; ++x) {
    const float step = std::min(std::fabs(grey[x] - grey[x - 1]), static_cast<float>(kMaxFlatStep));
    all[x] = static_cast<float>((valid[x] != 0) & (valid[x - 1] != 0)) * (step * step);  // & : no branch
  }
}

/// The same steps on the seam columns only (x = seam_column modulo period).
void seamStepsRow(int w, const float* all, int period, int seam_column, float* seam) {
  std::fill(seam, seam + w, 0.f);
  for (int x = seam_column; x < w; x += period) seam[x] = all[x];
}

/// A gridless texture's seam share in each column's box: the box's seam
/// columns over its columns, both counted among those that carry a step
/// (1..w-1), as the box sums clip the box to the row. An odd box over an
/// even period holds one seam column more or less depending on where it
/// sits, so a fixed one column in `period` would read a gridless texture
/// as partly seams at one phase and too little at the other.
void gridlessSeamShare(int w, int half, int period, int seam_column, std::vector<float>& scratch,
                       std::vector<float>& seam_columns, std::vector<float>& base) {
  seam_columns.assign(static_cast<size_t>(w), 0.f);
  for (int x = seam_column == 0 ? period : seam_column; x < w; x += period) seam_columns[static_cast<size_t>(x)] = 1.f;
  base.resize(static_cast<size_t>(w));
  boxSumsAlongLine(w, half, seam_columns.data(), scratch, base.data());
  for (int x = 0; x < w; ++x) {
    const int columns = std::min(w - 1, x + half) - std::max(1, x - half) + 1;
    base[x] = columns > 0 ? base[x] / static_cast<float>(columns) : 1.f / static_cast<float>(period);
  }
}

/// One row's seam share above a gridless texture's (`base`, per column),
/// scaled to 0..1 (0 where the box has no steps).
BDIS_ROW_LOOP
void seamShareRow(int w, const float* __restrict seam_sum, const float* __restrict all_sum,
                  const float* __restrict base, float* __restrict share) {
  for (int x = 0; x < w; ++x) {
    const float s = all_sum[x] > 1e-3f ? seam_sum[x] / all_sum[x] : base[x];
    // A box of one step on a seam column has a base of 1: share 0, not 0 / 0.
    share[x] = std::min(1.f, std::max(0.f, (s - base[x]) / std::max(1e-6f, 1.f - base[x])));
  }
}

/// One row of the cue; `shift` = 1.5 blocks - aligned, so that the blocks'
/// count below is positive for any estimate (d >= 0) and truncation rounds.
/// `seams` null: the plain term only.
BDIS_ROW_LOOP
void blockGridRow(int w, const float* __restrict d, float scale, float shift, float inv_reach, float doubt,
                  float inv_seam_reach, float seam_doubt, const float* __restrict seams, float* __restrict c) {
  const float block = static_cast<float>(kCodecBlock), inv_block = 1.f / block;
  for (int x = 0; x < w; ++x) {
    // One block and a half more than the distance from the aligned disparity
    // below (0 for kNoDisparity, whose result is not used).
    const float t = std::max(0.f, d[x] * scale + shift);
    const float nearest = block * static_cast<float>(static_cast<int>(t * inv_block));
    const float r = std::fabs(t - nearest - 0.5f * block);
    float factor = 1.f - doubt * std::max(0.f, 1.f - r * inv_reach);
    if (seams) factor *= 1.f - seam_doubt * std::max(0.f, 1.f - r * inv_seam_reach) * seams[x];
    c[x] = d[x] >= 0.f ? c[x] * factor : c[x];  // kNoDisparity: no estimate
  }
}

}  // namespace

void BlockGridCue::apply(const cv::Mat1f& disparity, int level_scale, const BlockGridLayout& layout,
                         const cv::Mat1f& grey, const cv::Mat1b& valid, int patch_px, const BlockGridDoubts& doubts,
                         cv::Mat1f& confidence) {
  if (layout.aligned < 0) return;
  CV_Assert(confidence.size() == disparity.size() && doubts.reach > 0.f && doubts.seam_reach > 0.f &&
            level_scale >= 1);
  const float scale = static_cast<float>(level_scale);
  const float shift = 1.5f * static_cast<float>(kCodecBlock) - static_cast<float>(layout.aligned);
  const int w = disparity.cols, h = disparity.rows;
  const int period = kCodecBlock / level_scale;  // level columns a block
  if (doubts.seam_doubt <= 0.f || period < 2) {
    for (int y = 0; y < h; ++y) {
      blockGridRow(w, disparity[y], scale, shift, 1.f / doubts.reach, doubts.doubt, 0.f, 0.f, nullptr, confidence[y]);
    }
    return;
  }
  CV_Assert(grey.size() == disparity.size() && valid.size() == disparity.size());
  // The seam between input columns k - 1 and k lies between level columns
  // q - 1 and q, q = k / 2^s rounded (inside a level pixel for odd k at
  // level 1: then the nearer step carries it).
  const int seam_column = ((layout.left_phase + level_scale / 2) / level_scale) % period;
  const int half = std::max(1, patch_px / 2);
  gridlessSeamShare(w, half, period, seam_column, line_scratch_, seam_columns_, gridless_share_);
  seams_.resize(static_cast<size_t>(w));
  sums_.begin(w, h, half);
  sums_.sweep(
      [&](int y, float* seam, float* all) {
        stepEnergyRow(w, grey[y], valid[y], all);
        seamStepsRow(w, all, period, seam_column, seam);
      },
      [&](int y, const float* seam_sum, const float* all_sum) {
        seamShareRow(w, seam_sum, all_sum, gridless_share_.data(), seams_.data());
        blockGridRow(w, disparity[y], scale, shift, 1.f / doubts.reach, doubts.doubt, 1.f / doubts.seam_reach,
                     doubts.seam_doubt, seams_.data(), confidence[y]);
      });
}

}  // namespace detail
}  // namespace bdis
