#include "image_border_cue.hpp"

#include <algorithm>
#include <cmath>

#include "box_sums.hpp"  // boxSumsAlongLine, boxMeanRow
#include "confidence.hpp"
#include "patch_kernels.hpp"  // BDIS_ROW_LOOP

namespace bdis {
namespace detail {
namespace {

/// Means of the estimates in boxes of side 2 half + 1 (clipped to the image)
/// centred on row `line` (along_rows) or column `line` (!along_rows), one per
/// position along it; kNoDisparity where a box holds none. `sum`, `count`,
/// `box_sum`, `box_count` and `padded` are scratch.
void boxMeansAlongLine(const cv::Mat1f& disparity, bool along_rows, int line, int half, std::vector<float>& sum,
                       std::vector<float>& count, std::vector<float>& box_sum, std::vector<float>& box_count,
                       std::vector<float>& padded, std::vector<float>& mean) {
  const int n = along_rows ? disparity.cols : disparity.rows;
  const int across = along_rows ? disparity.rows : disparity.cols;
  sum.assign(static_cast<size_t>(n), 0.f);
  count.assign(static_cast<size_t>(n), 0.f);
  const int first = std::max(0, line - half), last = std::min(across - 1, line + half);
  if (along_rows) {
    for (int a = first; a <= last; ++a) {
      const float* d = disparity[a];
      for (int i = 0; i < n; ++i) {
        const bool estimate = d[i] >= 0.f;
        sum[static_cast<size_t>(i)] += estimate ? d[i] : 0.f;
        count[static_cast<size_t>(i)] += estimate ? 1.f : 0.f;
      }
    }
  } else {
    for (int i = 0; i < n; ++i) {
      const float* d = disparity[i];
      float s = 0.f, c = 0.f;
      for (int a = first; a <= last; ++a) {
        const bool estimate = d[a] >= 0.f;
        s += estimate ? d[a] : 0.f;
        c += estimate ? 1.f : 0.f;
      }
      sum[static_cast<size_t>(i)] = s;
      count[static_cast<size_t>(i)] = c;
    }
  }
  // The same box along the line.
  box_sum.resize(static_cast<size_t>(n));
  box_count.resize(static_cast<size_t>(n));
  mean.resize(static_cast<size_t>(n));
  boxSumsAlongLine(n, half, sum.data(), padded, box_sum.data());
  boxSumsAlongLine(n, half, count.data(), padded, box_count.data());
  boxMeanRow(n, box_sum.data(), box_count.data(), mean.data());
}

/// What one row of the cue needs besides its columns.
struct BorderRow {
  float kept;         ///< the share kept for the start at the row's distance from the top or bottom
  float from_top;     ///< distance carried from the top edge (0 a patch side in and beyond)
  float from_bottom;  ///< likewise from the bottom edge
  float left_slope;   ///< the slope towards the left edge on this row
  float right_slope;  ///< likewise towards the right edge
};

/// Columns [x0, x1) of one row: the confidence of each estimate times the
/// share kept for the start and the agreement of the largest shortfall.
BDIS_ROW_LOOP
void lowerBorderRow(int x0, int x1, const BorderRow& row, const float* __restrict top, const float* __restrict bottom,
                    const float* __restrict from_left, const float* __restrict from_right,
                    const float* __restrict column_kept, float inv_halving_sq, const float* __restrict d,
                    float* __restrict c) {
  const BorderRow r = row;  // by value: the stores to c cannot change it, so the loop vectorises
  for (int x = x0; x < x1; ++x) {
    const float shortfall = std::max(std::max(top[x] * r.from_top, bottom[x] * r.from_bottom),
                                     std::max(r.left_slope * from_left[x], r.right_slope * from_right[x]));
    const float share = std::min(r.kept, column_kept[x]) * agreement(shortfall * shortfall, inv_halving_sq);
    c[x] = d[x] >= 0.f ? c[x] * share : c[x];
  }
}

}  // namespace

void ImageBorderCue::edgeSlopes(const cv::Mat1f& disparity, bool along_rows, int edge, int inward, int patch_px,
                                std::vector<float>& slope) {
  const int half = patch_px / 2;
  boxMeansAlongLine(disparity, along_rows, edge + inward * half, half, sum_, count_, box_sum_, box_count_, padded_,
                    near_);
  boxMeansAlongLine(disparity, along_rows, edge + inward * (patch_px + half), half, sum_, count_, box_sum_,
                    box_count_, padded_, far_);
  slope.resize(near_.size());
  for (size_t i = 0; i < slope.size(); ++i) {
    const bool both = near_[i] >= 0.f && far_[i] >= 0.f;  // a box without estimates: no slope
    slope[i] = both ? std::fabs(far_[i] - near_[i]) / static_cast<float>(patch_px) : 0.f;
  }
}

void ImageBorderCue::apply(const cv::Mat1f& disparity, int patch_px, float halving, cv::Mat1f& confidence) {
  CV_Assert(confidence.size() == disparity.size());
  const int w = disparity.cols, h = disparity.rows, p = patch_px;
  if (p < 2 || w < 2 * p + 1 || h < 2 * p + 1) return;
  edgeSlopes(disparity, true, 0, 1, p, top_);
  edgeSlopes(disparity, true, h - 1, -1, p, bottom_);
  edgeSlopes(disparity, false, 0, 1, p, left_);
  edgeSlopes(disparity, false, w - 1, -1, p, right_);
  // The distance carried: from a patch side in (where patches reach from
  // both sides) out to the pixel.
  auto carried = [p](int distance_from_edge) { return static_cast<float>(std::max(0, p - distance_from_edge)); };
  // The one-sided start: within a patch side of the next coarser level (two
  // here) of the edge, the start the search refined was carried out to the
  // edge as well, whatever the slope. The share kept rises with the distance
  // from the nearest edge, so it is the smaller of the row's and the column's.
  const int reach = std::min(2 * p, std::min(w, h) / 2);
  const float rise = (1.f - kImageBorderKeptAtEdge) / static_cast<float>(reach);
  auto kept = [&](int distance_from_edge) {
    return std::min(1.f, kImageBorderKeptAtEdge + rise * static_cast<float>(distance_from_edge));
  };
  from_left_.resize(static_cast<size_t>(w));
  from_right_.resize(static_cast<size_t>(w));
  column_kept_.resize(static_cast<size_t>(w));
  for (int x = 0; x < w; ++x) {
    from_left_[static_cast<size_t>(x)] = carried(x);
    from_right_[static_cast<size_t>(x)] = carried(w - 1 - x);
    column_kept_[static_cast<size_t>(x)] = kept(std::min(x, w - 1 - x));
  }
  const float inv_halving_sq = 1.f / (halving * halving);
  for (int y = 0; y < h; ++y) {
    const size_t iy = static_cast<size_t>(y);
    const BorderRow row{kept(std::min(y, h - 1 - y)), carried(y), carried(h - 1 - y), left_[iy], right_[iy]};
    auto lower = [&](int x0, int x1) {
      lowerBorderRow(x0, x1, row, top_.data(), bottom_.data(), from_left_.data(), from_right_.data(),
                     column_kept_.data(), inv_halving_sq, disparity[y], confidence[y]);
    };
    if (std::min(y, h - 1 - y) < reach) {
      lower(0, w);
    } else {  // only the side bands reach
      lower(0, reach);
      lower(w - reach, w);
    }
  }
}

}  // namespace detail
}  // namespace bdis
