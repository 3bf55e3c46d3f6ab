// Image pyramid for the matcher: grey float images, gradients and validity
// masks (level 0 only the left validity unless it is searched). Every buffer
// is sized once per input size; build() on a frame of the same size
// allocates nothing.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "block_grid.hpp"
#include "patch_kernels.hpp"  // kRightPadding

namespace bdis {
namespace detail {

/// Validity of an 8-bit mono row: 0 where the pixel is black (outside the
/// rectified view) or its grey level reaches `saturated` (256: never).
void validityOfMonoRow(const uchar* src, int w, int saturated, uchar* valid);
/// Grey level (Rec. 601 luma, as the matcher takes it) and validity of a BGR
/// row: the AVX2 kernel where the patch kernels are AVX2 ones (bestKernelIsa),
/// else the portable loop. Both give the same bytes.
void lumaOfBgrRow(const uchar* bgr, int w, int saturated, uchar* grey, uchar* valid);
void lumaOfBgrRowPortable(const uchar* bgr, int w, int saturated, uchar* grey, uchar* valid);
#ifdef BDIS_HAVE_AVX2_KERNELS
void lumaOfBgrRowAvx2(const uchar* bgr, int w, int saturated, uchar* grey, uchar* valid);
#endif
/// Rectification leaves more than black outside the view: interpolating the
/// image against its black frame gives a seam of dark pixels (grey 1-20 in
/// endoscope recordings) and one blended pixel before the tissue. As a
/// texture, that frame edge matches the other view's frame edge, which sits
/// at another offset: a strip of wrong disparities along the border. So where
/// a row starts or ends in black (the frame always reaches the image's edge),
/// the dark pixels (grey <= 20) after the black, up to 8 of them, and the
/// pixel after those are made invalid too. Black holes inside the view (dead
/// pixels, a masked tool) are not frames and keep their neighbours.
void invalidateSeams(const uchar* grey, int w, uchar* valid);
/// Pixels darker than `floor` made invalid (0: none). A near-black surface
/// without texture of its own (a dark instrument shaft, a dark corner) holds
/// little above the sensor's noise: a patch on it matches the texture of its
/// lighter neighbours, at their depth.
void invalidateBelowFloor(const uchar* grey, int w, int floor, uchar* valid);

/// Levels a pyramid may have: coarsest_level is at most 10 (see params).
constexpr int kMaxPyramidLevels = 11;

/// One pyramid level of one stereo pair.
struct PyramidLevel {
  int width = 0;
  int height = 0;
  cv::Mat1f left;        ///< grey, 0..255
  cv::Mat1f right;       ///< a view into right_padded: kRightPadding zero columns each side
  cv::Mat1f right_padded;
  cv::Mat1f left_gx;     ///< horizontal gradient of left, from valid neighbours only
  cv::Mat1b left_valid;  ///< 1 where the pixel lies inside the rectified view
  cv::Mat1b right_valid;  ///< a view into right_valid_padded: kRightPadding columns of 0 each side
  cv::Mat1b right_valid_padded;
  bool left_all_valid = false;   ///< no invalid left pixel
  bool right_all_valid = false;  ///< no invalid right pixel
  /// The level row held in row 0 of the buffers above: 0 when they hold the
  /// whole level, else the first row of the band that
  /// MirroredPyramid::loadFinestRows loaded last. Rows are read through the
  /// accessors below, by level row.
  int first_row = 0;
  const float* leftRow(int y) const { return left[y - first_row]; }
  const float* gradientRow(int y) const { return left_gx[y - first_row]; }
  const float* rightRow(int y) const { return right[y - first_row]; }
  const uchar* leftValidRow(int y) const { return left_valid[y - first_row]; }
  const uchar* rightValidRow(int y) const { return right_valid[y - first_row]; }
};

/// The pyramid of a stereo pair: levels 0..numLevels()-1, level s the
/// input downsampled by 2^s.
class StereoPyramid {
 public:
  /// Builds levels 0..num_levels-1 from 8-bit mono or BGR inputs of equal size;
  /// gradients only from `first_searched_level` on. Pixels black in every
  /// channel, the dark seam rectification leaves next to a black frame,
  /// pixels of grey level `saturation_grey` or brighter and pixels darker
  /// than `dark_floor_grey` are invalid.
  /// With `probe_block_grid`, columnSteps() are gathered too.
  void build(const cv::Mat& left, const cv::Mat& right, int num_levels, int first_searched_level,
             int saturation_grey = 256, int dark_floor_grey = 0, bool probe_block_grid = false);
  const PyramidLevel& level(int s) const { return levels_[static_cast<size_t>(s)]; }
  int numLevels() const { return static_cast<int>(levels_.size()); }
  cv::Size size() const { return size_; }  ///< of the input (level 0)
  /// The flat grey steps along every 16th input row of the left (true) or
  /// right view, by column phase: what shows a block codec's grid. Empty
  /// unless build() was asked to probe.
  const PhaseSteps& columnSteps(bool left_view) const { return left_view ? left_columns_ : right_columns_; }
  /// Multiplies the right view's grey levels of level s (a searched one) by
  /// `factor`; validity unchanged.
  void scaleRightView(int s, float factor);

 private:
  /// Level 1 straight from the 8-bit inputs when level 0 is not searched:
  /// two input rows at a time to grey and validity in `input_rows_`, which
  /// the 2x2 average reads while they are in cache. Level 0 is not stored,
  /// except the left validity (the output mask).
  void downsampleInputs(const cv::Mat& left, const cv::Mat& right);

  std::vector<PyramidLevel> levels_;
  cv::Size size_;
  int saturated_ = 256;  ///< grey level from which a pixel is invalid
  int dark_floor_ = 0;   ///< grey level below which a pixel is invalid
  /// Row scratch of the 8-bit conversion: rows 0 and 1 the grey of a colour
  /// input's rows; rows 2 and 3 the right validity of the two rows
  /// downsampleInputs averages (level 0 stores none when not searched).
  cv::Mat1b input_rows_;
  PhaseSteps left_columns_, right_columns_;
  bool probe_block_grid_ = false;
  /// Adds input row y's steps to its view's columnSteps() if y is sampled.
  void probeBlockGrid(bool left_view, int y, const uchar* grey, const uchar* valid);
};

/// The searched levels of the mirrored pair (the right image, flipped, as
/// the left one and vice versa), made from a StereoPyramid's levels without
/// converting or downsampling again: a search of the mirrored pair is the
/// search with the right image as reference. Its first (finest) searched
/// level holds only a band of rows at a time, mirrored by loadFinestRows
/// just before they are searched: written just before they are read, they
/// stay in cache, and the band is all the memory the level takes (at
/// 1920x1080 about 0.6 MB instead of 7).
class MirroredPyramid {
 public:
  /// Mirrors levels first_searched_level+1 .. num_levels-1 of `source`
  /// whole and makes room for `finest_band_rows` rows of its level
  /// first_searched_level.
  void build(const StereoPyramid& source, int num_levels, int first_searched_level, int finest_band_rows);
  /// Makes the finest level hold level rows [from, to) (at most
  /// finest_band_rows of them) of `source_finest`, mirrored: the
  /// first_searched_level of the pyramid given to build().
  void loadFinestRows(const PyramidLevel& source_finest, int from, int to);
  const PyramidLevel& level(int s) const { return levels_[static_cast<size_t>(s)]; }

 private:
  std::vector<PyramidLevel> levels_;
  int finest_ = 0;
};

/// Largest level count (>= 1) whose coarsest level still holds one patch of `patch_size`.
int levelsThatFit(int width, int height, int patch_size, int wanted_levels);

}  // namespace detail
}  // namespace bdis
