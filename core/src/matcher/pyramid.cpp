#include "pyramid.hpp"

#include <algorithm>
#include <cstdint>
#include <cstring>

namespace bdis {
namespace detail {

// A pixel is outside the rectified view when every channel is 0; judged on
// the input, not on the grey value (a real pixel that is merely dark is the
// dark floor's matter: invalidateBelowFloor). A pixel whose grey level
// reaches `saturated` is left out too: a specular highlight sits at another
// place on the tissue in each view, and its clipped plateau holds no texture.
BDIS_ROW_LOOP
void validityOfMonoRow(const uchar* __restrict src, int w, int saturated, uchar* __restrict valid) {
  for (int x = 0; x < w; ++x) valid[x] = (src[x] != 0) & (src[x] < saturated);
}

// Read interleaved. Luma is a whole number: kept in 8 bits, a quarter of the
// memory traffic of floats.
BDIS_ROW_LOOP
void lumaOfBgrRowPortable(const uchar* __restrict bgr, int w, int saturated, uchar* __restrict grey,
                          uchar* __restrict valid) {
  for (int x = 0; x < w; ++x) {
    const uchar b = bgr[3 * x], gr = bgr[3 * x + 1], r = bgr[3 * x + 2];
    // Rec. 601 luma in 8.8 fixed point (within 1 grey level of cv::cvtColor).
    const uint16_t luma = static_cast<uint16_t>(29 * b + 150 * gr + 77 * r + 128);
    grey[x] = static_cast<uchar>(luma >> 8);
    valid[x] = ((b | gr | r) != 0) & ((luma >> 8) < saturated);
  }
}

void lumaOfBgrRow(const uchar* bgr, int w, int saturated, uchar* grey, uchar* valid) {
#ifdef BDIS_HAVE_AVX2_KERNELS
  // As the patch kernels: BDIS_SIMD=off or =baseline keeps the portable loop.
  static const bool use_avx2 = bestKernelIsa() == KernelIsa::Avx2;
  if (use_avx2) {
    lumaOfBgrRowAvx2(bgr, w, saturated, grey, valid);
    return;
  }
#endif
  lumaOfBgrRowPortable(bgr, w, saturated, grey, valid);
}

void StereoPyramid::scaleRightView(int s, float factor) {
  cv::Mat1f& right = levels_[static_cast<size_t>(s)].right;
  for (int y = 0; y < right.rows; ++y) {
    float* row = right[y];
    for (int x = 0; x < right.cols; ++x) row[x] *= factor;
  }
}

namespace {

// The seam invalidateSeams takes out (pyramid.hpp): up to this many pixels
// this dark after a row's black frame.
constexpr int kSeamWidth = 8;
constexpr uchar kSeamGrey = 20;

/// The first index from i towards `end` (exclusive; one step `side`, +1 or
/// -1) whose byte is non-zero, `end` if none. Eight bytes at a time: a black
/// frame is often a hundred pixels and more on each side.
int skipZeros(const uchar* bytes, int i, int end, int side) {
  std::uint64_t word;
  if (side > 0) {
    for (; i + 8 <= end; i += 8) {
      std::memcpy(&word, bytes + i, sizeof word);
      if (word != 0) break;
    }
  } else {
    for (; i - 8 >= end; i -= 8) {
      std::memcpy(&word, bytes + i - 7, sizeof word);
      if (word != 0) break;
    }
  }
  while (i != end && !bytes[i]) i += side;
  return i;
}

}  // namespace

void invalidateSeams(const uchar* grey, int w, uchar* valid) {
  for (const int side : {+1, -1}) {
    int i = side > 0 ? 0 : w - 1;
    const int end = side > 0 ? w : -1;
    if (valid[i]) continue;  // the row does not start (end) in black: the usual case
    i = skipZeros(valid, i, end, side);
    for (int n = 0; n < kSeamWidth && i != end && grey[i] <= kSeamGrey; ++n, i += side) valid[i] = 0;
    if (i != end) valid[i] = 0;  // the blended pixel
  }
}

BDIS_ROW_LOOP
void invalidateBelowFloor(const uchar* __restrict grey, int w, int floor, uchar* __restrict valid) {
  if (floor <= 0) return;
  const uchar below = static_cast<uchar>(std::min(floor, 256) - 1);  // grey <= below is dark
  for (int x = 0; x < w; ++x) valid[x] = grey[x] > below ? valid[x] : 0;
}

namespace {

/// Grey value and validity of row y of an 8-bit mono or BGR input: returns
/// the input row itself when it is mono, else `luma_row` filled.
const uchar* greyAndValidityRow(const cv::Mat& src, int y, int saturated, int dark_floor, uchar* luma_row,
                                uchar* valid_row) {
  const uchar* row = src.ptr<uchar>(y);
  const uchar* grey = row;
  if (src.channels() == 1) {
    validityOfMonoRow(row, src.cols, saturated, valid_row);
  } else {
    lumaOfBgrRow(row, src.cols, saturated, luma_row, valid_row);
    grey = luma_row;
  }
  // After the seams: a row that starts in dark tissue is no frame.
  invalidateSeams(grey, src.cols, valid_row);
  invalidateBelowFloor(grey, src.cols, dark_floor, valid_row);
  return grey;
}

BDIS_ROW_LOOP
void toFloatRow(const uchar* __restrict src, int w, float* __restrict dst) {
  for (int x = 0; x < w; ++x) dst[x] = src[x];
}

// 2x2 box average of two fine rows into a coarse row of width w (of 8-bit
// grey or of a float level: the sum of four whole numbers is exact either
// way, so both give the same values); a coarse pixel is valid only when all
// four fine ones are, so black borders never bleed into darker-than-real
// tissue values.
template <typename T>
BDIS_ROW_LOOP void downsampleRow(const T* __restrict f0, const T* __restrict f1,
                                 const uchar* __restrict v0, const uchar* __restrict v1, int w,
                                 float* __restrict c, uchar* __restrict cv) {
  for (int x = 0; x < w; ++x) {
    const int a = 2 * x;
    c[x] = 0.25f * (f0[a] + f0[a + 1] + f1[a] + f1[a + 1]);
    cv[x] = v0[a] & v0[a + 1] & v1[a] & v1[a + 1];
  }
}

void downsample(const cv::Mat1f& fine, const cv::Mat1b& fine_valid, cv::Mat1f& coarse,
                cv::Mat1b& coarse_valid) {
  for (int y = 0; y < coarse.rows; ++y) {
    downsampleRow(fine[2 * y], fine[2 * y + 1], fine_valid[2 * y], fine_valid[2 * y + 1], coarse.cols,
                  coarse[y], coarse_valid[y]);
  }
}

// Central difference where both neighbours are valid, one-sided where only
// one is, 0 where neither is: invalid pixels never enter a gradient.
float edgeGradient(const float* p, const uchar* v, int w, int x) {
  const bool has_left = x > 0 && v[x - 1];
  const bool has_right = x + 1 < w && v[x + 1];
  if (!v[x]) return 0.f;
  if (has_left && has_right) return 0.5f * (p[x + 1] - p[x - 1]);
  if (has_right) return p[x + 1] - p[x];
  if (has_left) return p[x] - p[x - 1];
  return 0.f;
}

/// Horizontal gradient of one row of w pixels, from valid neighbours only.
BDIS_ROW_LOOP
void gradientRow(const float* __restrict p, const uchar* __restrict v, int w, float* __restrict g) {
  if (w > 1 && std::memchr(v, 0, static_cast<size_t>(w)) == nullptr) {
    // A row without invalid pixels (the usual case): a loop that vectorises.
    g[0] = p[1] - p[0];
    for (int x = 1; x + 1 < w; ++x) g[x] = 0.5f * (p[x + 1] - p[x - 1]);
    g[w - 1] = p[w - 1] - p[w - 2];
    return;
  }
  // A row with invalid pixels (every row, with a black border down one
  // side): the interior without branches, so that it vectorises too.
  g[0] = edgeGradient(p, v, w, 0);
  for (int x = 1; x + 1 < w; ++x) {
    const bool has_left = v[x - 1] != 0, has_right = v[x + 1] != 0;
    const float central = 0.5f * (p[x + 1] - p[x - 1]);
    const float forward = p[x + 1] - p[x];
    const float backward = p[x] - p[x - 1];
    const float one_sided = has_right ? forward : has_left ? backward : 0.f;
    const float value = has_left && has_right ? central : one_sided;
    g[x] = v[x] != 0 ? value : 0.f;
  }
  if (w > 1) g[w - 1] = edgeGradient(p, v, w, w - 1);
}

/// Gradient of the first `rows` stored rows of a level's left image.
void horizontalGradient(PyramidLevel& l, int rows) {
  for (int y = 0; y < rows; ++y) gradientRow(l.left[y], l.left_valid[y], l.width, l.left_gx[y]);
}

/// dst row i = src row from + i flipped left-right, for src rows [from, to).
template <typename T>
BDIS_ROW_LOOP void mirrorRows(const cv::Mat_<T>& src, int from, int to, cv::Mat_<T>& dst) {
  const int w = src.cols;
  for (int y = from; y < to; ++y) {
    const T* s = src[y];
    T* d = dst[y - from];
    for (int x = 0; x < w; ++x) d[x] = s[w - 1 - x];
  }
}

bool allValid(const cv::Mat1b& valid) { return cv::countNonZero(valid) == valid.rows * valid.cols; }

void buildGradientAndValidityFlags(PyramidLevel& l) {
  horizontalGradient(l, l.height);
  l.left_all_valid = allValid(l.left_valid);
  l.right_all_valid = allValid(l.right_valid);
}

/// Level buffers for `rows` stored rows (the level's height unless only a
/// band of it is kept); a level that is not searched needs no gradient, and
/// level 0 needs only its left validity when it is not searched (the grey
/// input is downsampled straight to level 1).
void allocate(PyramidLevel& l, int w, int h, int s, bool searched, int rows) {
  l.width = w;
  l.height = h;
  l.first_row = 0;
  l.left_valid.create(rows, w);
  if (s == 0 && !searched) return;
  if (l.right_valid_padded.rows != rows || l.right_valid_padded.cols != w + 2 * kRightPadding) {
    // Outside the image counts as invalid: the masked kernels read the padding.
    l.right_valid_padded.create(rows, w + 2 * kRightPadding);
    l.right_valid_padded.setTo(0);
    l.right_valid = l.right_valid_padded.colRange(kRightPadding, kRightPadding + w);
  }
  l.left.create(rows, w);
  if (l.right_padded.rows != rows || l.right_padded.cols != w + 2 * kRightPadding) {
    l.right_padded.create(rows, w + 2 * kRightPadding);
    l.right_padded.setTo(0.f);  // only the padding stays 0; the view is rewritten per frame
    l.right = l.right_padded.colRange(kRightPadding, kRightPadding + w);
  }
  if (!searched) return;
  l.left_gx.create(rows, w);
}

/// Level rows [from, to) of `src`, mirrored, into the buffers of `l` (which
/// then hold exactly those rows), with their gradient.
void loadMirroredRows(PyramidLevel& l, const PyramidLevel& src, int from, int to) {
  CV_Assert(0 <= from && from < to && to <= l.height && to - from <= l.left.rows);
  l.first_row = from;
  mirrorRows(src.right, from, to, l.left);
  mirrorRows(src.left, from, to, l.right);
  mirrorRows(src.right_valid, from, to, l.left_valid);
  mirrorRows(src.left_valid, from, to, l.right_valid);
  horizontalGradient(l, to - from);
}

}  // namespace

int levelsThatFit(int width, int height, int patch_size, int wanted_levels) {
  int levels = 1;
  while (levels < wanted_levels && std::min(width >> levels, height >> levels) >= patch_size) {
    ++levels;
  }
  return levels;
}

void StereoPyramid::build(const cv::Mat& left, const cv::Mat& right, int num_levels,
                          int first_searched_level, int saturation_grey, int dark_floor_grey,
                          bool probe_block_grid) {
  saturated_ = saturation_grey;
  dark_floor_ = dark_floor_grey;
  probe_block_grid_ = probe_block_grid;
  size_ = left.size();
  levels_.resize(static_cast<size_t>(num_levels));  // no-op once sized
  for (int s = 0; s < num_levels; ++s) {
    // Mat::create is a no-op when size and type are unchanged.
    const int h = left.rows >> s;
    allocate(levels_[s], left.cols >> s, h, s, s >= first_searched_level, h);
  }
  PyramidLevel& base = levels_[0];
  int first_downsampled = 1;
  input_rows_.create(4, left.cols);
  left_columns_ = right_columns_ = PhaseSteps();
  if (first_searched_level == 0) {
    for (int y = 0; y < left.rows; ++y) {
      const uchar* grey = greyAndValidityRow(left, y, saturated_, dark_floor_, input_rows_[0], base.left_valid[y]);
      probeBlockGrid(true, y, grey, base.left_valid[y]);
      toFloatRow(grey, left.cols, base.left[y]);
      grey = greyAndValidityRow(right, y, saturated_, dark_floor_, input_rows_[0], base.right_valid[y]);
      probeBlockGrid(false, y, grey, base.right_valid[y]);
      toFloatRow(grey, left.cols, base.right[y]);
    }
  } else {
    downsampleInputs(left, right);
    first_downsampled = 2;
  }
  for (int s = first_downsampled; s < num_levels; ++s) {
    const PyramidLevel& fine = levels_[s - 1];
    PyramidLevel& coarse = levels_[s];
    downsample(fine.left, fine.left_valid, coarse.left, coarse.left_valid);
    downsample(fine.right, fine.right_valid, coarse.right, coarse.right_valid);
  }
  for (int s = first_searched_level; s < num_levels; ++s) buildGradientAndValidityFlags(levels_[s]);
}

void StereoPyramid::downsampleInputs(const cv::Mat& left, const cv::Mat& right) {
  PyramidLevel& base = levels_[0];
  PyramidLevel& one = levels_[1];
  for (const bool is_left : {true, false}) {
    const cv::Mat& src = is_left ? left : right;
    cv::Mat1f& coarse = is_left ? one.left : one.right;
    cv::Mat1b& coarse_valid = is_left ? one.left_valid : one.right_valid;
    for (int y = 0; y < coarse.rows; ++y) {
      const uchar* grey[2];
      const uchar* valid[2];
      for (int i = 0; i < 2; ++i) {
        // Level 0 keeps the left validity only: the output mask.
        uchar* valid_row = is_left ? base.left_valid[2 * y + i] : input_rows_[2 + i];
        grey[i] = greyAndValidityRow(src, 2 * y + i, saturated_, dark_floor_, input_rows_[i], valid_row);
        valid[i] = valid_row;
        probeBlockGrid(is_left, 2 * y + i, grey[i], valid_row);
      }
      downsampleRow(grey[0], grey[1], valid[0], valid[1], coarse.cols, coarse[y], coarse_valid[y]);
    }
    // An odd last row has no coarse row but belongs to the output mask.
    if (is_left && src.rows % 2) {
      greyAndValidityRow(src, src.rows - 1, saturated_, dark_floor_, input_rows_[0], base.left_valid[src.rows - 1]);
    }
  }
}

void StereoPyramid::probeBlockGrid(bool left_view, int y, const uchar* grey, const uchar* valid) {
  // A codec's seams run down every row of a column: every 16th row holds
  // enough steps (over 2000 a phase at 640x480) at a sixteenth of the cost.
  constexpr int kProbedRowStep = 2 * kCodecBlock;
  if (!probe_block_grid_ || y % kProbedRowStep != 0) return;
  (left_view ? left_columns_ : right_columns_).addRow(grey, valid, size_.width);
}

void MirroredPyramid::build(const StereoPyramid& source, int num_levels, int first_searched_level,
                            int finest_band_rows) {
  levels_.resize(static_cast<size_t>(num_levels));
  finest_ = first_searched_level;
  for (int s = first_searched_level; s < num_levels; ++s) {
    const PyramidLevel& from = source.level(s);
    PyramidLevel& l = levels_[static_cast<size_t>(s)];
    const bool banded = s == finest_;
    allocate(l, from.width, from.height, s, true,
             banded ? std::clamp(finest_band_rows, 1, from.height) : from.height);
    l.left_all_valid = from.right_all_valid;  // mirrored, not counted again
    l.right_all_valid = from.left_all_valid;
    if (!banded) loadMirroredRows(l, from, 0, from.height);
  }
}

void MirroredPyramid::loadFinestRows(const PyramidLevel& source_finest, int from, int to) {
  loadMirroredRows(levels_[static_cast<size_t>(finest_)], source_finest, from, to);
}

}  // namespace detail
}  // namespace bdis
