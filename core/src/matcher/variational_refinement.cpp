#include "variational_refinement.hpp"

#include <algorithm>
#include <cmath>

#include "bdis_stereo/matcher.hpp"  // kNoDisparity
#include "fusion.hpp"               // coarserLevelRow
#include "patch_cost.hpp"           // supportContrastShareSq
#include "patch_kernels.hpp"        // BDIS_ROW_LOOP

namespace bdis {
namespace detail {
namespace {

// The robust terms' constants, as OpenCV's VariationalRefinement has them:
// the data terms' weights (brightness, gradient constancy), the
// normalisation's floor (zeta^2: a flat pixel's data term stays finite), the
// Charbonnier epsilon^2, the over-relaxation and the sweeps per step.
constexpr float kBrightnessWeight = 5.f;
constexpr float kGradientWeight = 10.f;
constexpr float kZetaSq = 0.1f * 0.1f;
constexpr float kEpsilonSq = 0.001f * 0.001f;
constexpr float kOmega = 1.9f;
constexpr int kSweeps = 3;

/// A smoothness link between two pixels whose left grey levels differ by g
/// keeps 1 / (1 + (g / h)^2) of its weight, h this many grey levels, scaled
/// below a grey level of kSupportFullContrastGrey as the support weights'
/// are (patch_cost.hpp). An instrument's outline or a fold's rim is an edge
/// in the image and mostly a depth edge too; across it the smoothness would
/// carry the outline's disparity, which the data term pins there, into
/// weakly textured tissue beside it.
constexpr float kEdgeGrey = 16.f;

/// The squared grey difference at which a link between pixels of grey
/// levels a and b halves.
inline float edgeHalvingSq(float a, float b) {
  return supportContrastShareSq(0.5f * (a + b)) * (kEdgeGrey * kEdgeGrey);
}

/// d/dx by central differences, one-sided at the ends.
inline void derivativeX(int w, const float* __restrict in, float* __restrict out) {
  out[0] = in[1] - in[0];
  for (int x = 1; x < w - 1; ++x) out[x] = 0.5f * (in[x + 1] - in[x - 1]);
  out[w - 1] = in[w - 1] - in[w - 2];
}

/// The data term's coefficients of one row, constant over the fixed-point
/// steps: the x derivatives of the average and of the difference, and each
/// constancy term's normalisation by its squared gradient along x (OpenCV's
/// VariationalRefinement normalises by the 2-D gradient; along x alone,
/// since only x observes a disparity), 0 where `data` is 0.
BDIS_ROW_LOOP
void dataTermRow(int w, const float* __restrict average, const float* __restrict difference,
                 const float* __restrict data, float* __restrict ix, float* __restrict ixx, float* __restrict ixz,
                 float* __restrict norm, float* __restrict norm_x) {
  derivativeX(w, average, ix);
  derivativeX(w, ix, ixx);
  derivativeX(w, difference, ixz);
  for (int x = 0; x < w; ++x) {
    norm[x] = data[x] / (ix[x] * ix[x] + kZetaSq);
    norm_x[x] = data[x] / (ixx[x] * ixx[x] + kZetaSq);
  }
}

/// One row of the linear system for the increment t of d = start + t,
/// into `inv_diagonal` (the diagonal's inverse) and `rhs`. The data terms
/// linearise right(x - d) as warped - ix * t and its x derivative as
/// warped_x - ixx * t, each robust (Charbonnier) in its own normalised
/// residual; each smoothness link adds its weight to the diagonal and pulls
/// towards the neighbour's start. `right` as smoothnessRow writes it, `up`
/// / `down` the links to the rows above and below (0 where there is none),
/// `start*` padded by one column each side.
BDIS_ROW_LOOP
void systemRow(int w, const float* __restrict ix, const float* __restrict iz, const float* __restrict norm,
               const float* __restrict ixx, const float* __restrict ixz, const float* __restrict norm_x,
               const float* __restrict t, const float* __restrict right, const float* __restrict up,
               const float* __restrict down, const float* __restrict start, const float* __restrict start_above,
               const float* __restrict start_below, float* __restrict inv_diagonal, float* __restrict rhs) {
  for (int x = 0; x < w; ++x) {
    const float r = iz[x] - ix[x] * t[x];
    const float wb = (0.5f * kBrightnessWeight) * norm[x] / std::sqrt(r * r * norm[x] + kEpsilonSq);
    const float rx = ixz[x] - ixx[x] * t[x];
    const float wg = (0.5f * kGradientWeight) * norm_x[x] / std::sqrt(rx * rx * norm_x[x] + kEpsilonSq);
    const float diagonal =
        wb * ix[x] * ix[x] + wg * ixx[x] * ixx[x] + kZetaSq + right[x] + right[x + 1] + up[x] + down[x];
    inv_diagonal[x] = 1.f / diagonal;
    rhs[x] = wb * ix[x] * iz[x] + wg * ixx[x] * ixz[x] + right[x + 1] * (start[x + 1] - start[x]) +
             right[x] * (start[x - 1] - start[x]) + up[x] * (start_above[x] - start[x]) +
             down[x] * (start_below[x] - start[x]);
  }
}

/// Where each pixel's match falls in the right row, x - start: the left
/// one of the two right pixels the interpolation reads, and the fraction
/// towards the next (-1 when the match falls outside the row).
BDIS_ROW_LOOP
void matchPositionRow(int w, const float* __restrict start, int* __restrict index, float* __restrict fraction) {
  const float last = static_cast<float>(w - 1);
  for (int x = 0; x < w; ++x) {
    const float xs = static_cast<float>(x) - start[x];
    const bool inside = xs >= 0.f && xs <= last;
    const int x0 = inside ? std::min(static_cast<int>(xs), w - 2) : 0;
    index[x] = x0;
    fraction[x] = inside ? xs - static_cast<float>(x0) : -1.f;
  }
}

/// The two right pixels each match reads, and 1 where both are valid and
/// so is the left pixel (scalar: the compiler does not gather).
void gatherRow(int w, const int* __restrict index, const float* __restrict right, const uchar* __restrict right_valid,
               const uchar* __restrict left_valid, float* __restrict first, float* __restrict second,
               float* __restrict both_valid) {
  for (int x = 0; x < w; ++x) {
    const int i = index[x];
    first[x] = right[i];
    second[x] = right[i + 1];
    both_valid[x] = left_valid[x] && right_valid[i] && right_valid[i + 1] ? 1.f : 0.f;
  }
}

/// The right image warped by the start (linear interpolation), as the
/// average with the left image and the difference from it; `data` 1 where
/// the pixel and both right pixels its match reads are valid (else the
/// average is the left pixel and the difference 0).
BDIS_ROW_LOOP
void warpRow(int w, const float* __restrict left, const float* __restrict fraction, const float* __restrict first,
             const float* __restrict second, const float* __restrict both_valid, float* __restrict average,
             float* __restrict difference, float* __restrict data) {
  for (int x = 0; x < w; ++x) {
    const float warped = first[x] + fraction[x] * (second[x] - first[x]);
    const bool ok = fraction[x] >= 0.f && both_valid[x] > 0.f;
    data[x] = ok ? 1.f : 0.f;
    average[x] = ok ? 0.5f * (left[x] + warped) : left[x];
    difference[x] = ok ? warped - left[x] : 0.f;
  }
}

/// The start of one row: the estimates, the holes from `coarser_row` (the
/// coarser level's disparity at each pixel of the row).
BDIS_ROW_LOOP
void startRow(int w, const float* __restrict disparity, const float* __restrict coarser_row,
              float* __restrict start, float* __restrict t) {
  for (int x = 0; x < w; ++x) {
    start[x] = disparity[x] >= 0.f ? disparity[x] : std::max(0.f, coarser_row[x]);
    t[x] = 0.f;
  }
}

/// The refined estimates back into `disparity`; holes stay holes. An
/// estimate moves only to where its match stays in the right image (0 <= d
/// <= x): beyond, the refinement had no data term, only its neighbours (or,
/// with extreme settings, a solver that did not settle), and the estimate
/// keeps its start.
BDIS_ROW_LOOP
void refinedRow(int w, const float* __restrict start, const float* __restrict t, float* __restrict disparity) {
  for (int x = 0; x < w; ++x) {
    const float refined = start[x] + t[x];
    const bool inside = refined >= 0.f && refined <= static_cast<float>(x);
    disparity[x] = disparity[x] >= 0.f ? (inside ? refined : start[x]) : disparity[x];
  }
}

/// The smoothness weight of each pixel's links to its right and lower
/// neighbours, robust in the current disparity's forward differences and
/// cut at the left image's edges (kEdgeGrey; `grey` the row's left grey
/// levels): `right` gets the weight of pixel x's link at x + 1 (column 0
/// holds the link left of the first pixel, 0), `down` at x; `below` and
/// `grey_below` null on the last row (no lower link, weight 0).
BDIS_ROW_LOOP
void smoothnessRow(int w, float half_alpha, const float* __restrict start, const float* __restrict t,
                   const float* __restrict grey, const float* __restrict start_below,
                   const float* __restrict t_below, const float* __restrict grey_below, float* __restrict right,
                   float* __restrict down) {
  right[0] = 0.f;
  for (int x = 0; x < w - 1; ++x) {
    const float d = start[x] + t[x];
    const float dx = start[x + 1] + t[x + 1] - d;
    const float dy = start_below ? start_below[x] + t_below[x] - d : 0.f;
    const float gx = grey[x + 1] - grey[x];
    const float hx = edgeHalvingSq(grey[x + 1], grey[x]);
    const float gy = start_below ? grey_below[x] - grey[x] : 0.f;
    const float hy = start_below ? edgeHalvingSq(grey_below[x], grey[x]) : 1.f;
    // weight * h / (h + g^2) for both links over one division.
    const float ex = hx + gx * gx, ey = hy + gy * gy;
    const float common = half_alpha / (std::sqrt(dx * dx + dy * dy + kEpsilonSq) * ex * ey);
    right[x + 1] = common * hx * ey;
    down[x] = start_below ? common * hy * ex : 0.f;
  }
  right[w] = 0.f;
  down[w - 1] = 0.f;
  if (start_below) {
    const float dy = start_below[w - 1] + t_below[w - 1] - start[w - 1] - t[w - 1];
    const float gy = grey_below[w - 1] - grey[w - 1];
    const float hy = edgeHalvingSq(grey_below[w - 1], grey[w - 1]);
    down[w - 1] = half_alpha / std::sqrt(dy * dy + kEpsilonSq) * hy / (hy + gy * gy);
  }
}

/// One colour of a red-black SOR sweep over a row: the pixels with x
/// from `first` in steps of 2 move to their over-relaxed Gauss-Seidel
/// value; their neighbours, of the other colour, stay as they are. `t` has
/// one padding column each side. The candidates of the whole row first
/// (contiguous loads, which vectorise better than every other pixel's),
/// then the colour's are kept.
BDIS_ROW_LOOP
void sorRow(int w, int first, const float* __restrict right, const float* __restrict up,
            const float* __restrict down, const float* __restrict rhs, const float* __restrict inv_diagonal,
            const float* __restrict t_above, const float* __restrict t_below, float* __restrict t,
            float* __restrict candidate) {
  for (int x = 0; x < w; ++x) {
    const float pulled = rhs[x] + right[x] * t[x - 1] + right[x + 1] * t[x + 1] + up[x] * t_above[x] +
                         down[x] * t_below[x];
    candidate[x] = (1.f - kOmega) * t[x] + kOmega * pulled * inv_diagonal[x];
  }
  for (int x = first; x < w; x += 2) t[x] = candidate[x];
}

}  // namespace

void VariationalRefinement::configure(int iterations, float smoothness) {
  iterations_ = iterations;
  smoothness_ = smoothness;
}

void VariationalRefinement::apply(const PyramidLevel& level, const cv::Mat1f& coarser, cv::Mat1f& disparity) {
  if (iterations_ <= 0) return;
  const int h = disparity.rows, w = disparity.cols;
  if (w < 2 || h < 2) return;
  start_.create(h, w + 2);
  increment_.create(h + 2, w + 2);  // a border of 0 the SOR reads past the ends
  data_rows_.create(kDataRows, w);
  system_rows_.create(2 * kRingRows, w);
  weight_right_.create(kRingRows, w + 1);
  weight_down_.create(kRingRows, w);
  scratch_.create(kScratchRows, w);
  match_index_.create(1, w);
  std::fill(increment_[0], increment_[0] + w + 2, 0.f);
  std::fill(increment_[h + 1], increment_[h + 1] + w + 2, 0.f);
  // The holes start from the coarser level's dense disparity, as the
  // fusion's initialisation reads it.
  float* coarser_row = scratch_[0];
  for (int y = 0; y < h; ++y) {
    // Rows 2k and 2k + 1 read the same coarser row.
    if (y % 2 == 0) {
      coarserLevelRow(coarser, y, w, coarser_row);
    }
    float* s = start(y);
    startRow(w, disparity[y], coarser_row, s, t(y));
    s[-1] = s[0];
    s[w] = s[w - 1];
    t(y)[-1] = t(y)[w] = 0.f;
  }
  for (int k = 0; k < iterations_; ++k) fixedPointStep(level, k + 1 == iterations_ ? &disparity : nullptr);
}

void VariationalRefinement::prepareDataTermRow(const PyramidLevel& level, int y) {
  const int w = start_.cols - 2;
  float* fraction = scratch_[0];
  float* first = scratch_[1];
  float* second = scratch_[2];
  float* both_valid = scratch_[3];
  float* average = scratch_[4];
  float* data = scratch_[5];
  int* index = match_index_.ptr<int>();
  matchPositionRow(w, start(y), index, fraction);
  gatherRow(w, index, level.rightRow(y), level.rightValidRow(y), level.leftValidRow(y), first, second, both_valid);
  warpRow(w, level.leftRow(y), fraction, first, second, both_valid, average, data_rows_[kDifference], data);
  dataTermRow(w, average, data_rows_[kDifference], data, data_rows_[kIx], data_rows_[kIxx], data_rows_[kIxz],
               data_rows_[kNorm], data_rows_[kNormX]);
}

void VariationalRefinement::fixedPointStep(const PyramidLevel& level, cv::Mat1f* refined) {
  const int h = start_.rows, w = start_.cols - 2;
  const float half_alpha = 0.5f * smoothness_;
  // Ring rows: row y of the level's system and links sits in slot y % kRingRows.
  auto slot = [](int y) { return y & (kRingRows - 1); };
  auto inv_diagonal = [&](int y) { return system_rows_[slot(y)]; };
  auto rhs = [&](int y) { return system_rows_[kRingRows + slot(y)]; };
  auto right = [&](int y) { return weight_right_[slot(y)]; };
  // down(y) links rows y - 1 and y; down(0) and down(h) are 0.
  auto down = [&](int y) { return weight_down_[slot(y)]; };
  std::fill(down(0), down(0) + w, 0.f);
  // Red-black SOR: each half-sweep (stage) moves one colour from the other
  // colour's values of the stage before, so the order of the rows inside a
  // stage does not matter. The stages run as a wavefront, stage k on row
  // step - k, each row after the rows it reads: every sweep in one pass over
  // the rows while they are in cache, with the same result as stage after
  // stage over the whole level. Row `step` gets its data term, links and
  // system just before its first stage: they read the increment before the
  // step, which no stage has touched on rows step and below, and the ring
  // holds the rows the stages still read (kStages + 1 of them).
  constexpr int kStages = 2 * kSweeps;
  static_assert(kRingRows >= kStages + 2, "the ring holds every row the stages read");
  static_assert((kRingRows & (kRingRows - 1)) == 0, "slot() masks: a power of two");
  for (int step = 0; step < h + kStages - 1; ++step) {
    if (step < h) {
      const int y = step;
      const bool has_below = y + 1 < h;
      smoothnessRow(w, half_alpha, start(y), t(y), level.leftRow(y), has_below ? start(y + 1) : nullptr,
                    has_below ? t(y + 1) : nullptr, has_below ? level.leftRow(y + 1) : nullptr, right(y), down(y + 1));
      prepareDataTermRow(level, y);
      // The top and bottom rows have their vertical links on the inside only,
      // so those links' pull towards the next row's start is one-sided: on a
      // surface slanted along the columns it drags the row towards flat (too
      // far where the surface rises towards the side), where a row inside is
      // pulled both ways and stays. They read their own start for the row
      // beyond instead, which leaves that pull out; their increments stay
      // linked to the next row's.
      const bool side_row = y == 0 || y == h - 1;
      systemRow(w, data_rows_[kIx], data_rows_[kDifference], data_rows_[kNorm], data_rows_[kIxx], data_rows_[kIxz],
                data_rows_[kNormX], t(y), right(y), down(y), down(y + 1), start(y), side_row ? start(y) : start(y - 1),
                side_row ? start(y) : start(y + 1), inv_diagonal(y), rhs(y));
    }
    for (int k = 0; k < kStages; ++k) {
      const int y = step - k;
      if (y < 0 || y >= h) continue;
      sorRow(w, (y + k) & 1, right(y), down(y), down(y + 1), rhs(y), inv_diagonal(y), t(y - 1), t(y + 1), t(y),
             scratch_[0]);
    }
    // The last stage has finished its row: with it, the rows above it are final too.
    const int done = step - (kStages - 1);
    if (refined && done >= 0) refinedRow(w, start(done), t(done), (*refined)[done]);
  }
}

}  // namespace detail
}  // namespace bdis
