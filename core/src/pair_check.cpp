#include "bdis_stereo/pair_check.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <stdexcept>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "matcher/block_grid.hpp"
#include "matcher/pyramid.hpp"  // the matcher's grey levels and validity

namespace bdis {
namespace {

constexpr int kWorkWidth = 160;  // px: coarse enough to be cheap, fine enough for texture
constexpr int kPatch = 8;        // px at the work scale

cv::Mat workImage(const cv::Mat& image, double scale) {
  cv::Mat grey;
  if (image.channels() == 3) cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  else grey = image;
  cv::Mat small;
  cv::resize(grey, small, cv::Size(), scale, scale, cv::INTER_AREA);
  return small;
}

}  // namespace

DisparitySignCheck checkDisparitySign(const cv::Mat& left, const cv::Mat& right) {
  if (left.empty() || right.empty() || left.size() != right.size() || left.type() != right.type() ||
      left.depth() != CV_8U || (left.channels() != 1 && left.channels() != 3)) {
    throw std::invalid_argument("checkDisparitySign: equal-size 8-bit mono or BGR images expected");
  }
  const double scale = std::min(1.0, static_cast<double>(kWorkWidth) / left.cols);
  const cv::Mat l = workImage(left, scale), r = workImage(right, scale);
  const int range = l.cols / 4;
  DisparitySignCheck check;
  std::vector<double> costs(static_cast<size_t>(2 * range + 1));
  for (int y0 = 0; y0 + kPatch <= l.rows; y0 += kPatch) {
    for (int x0 = 0; x0 + kPatch <= l.cols; x0 += kPatch) {
      // Textured, fully inside the rectified view (no black pixel).
      double sum = 0, sum_sq = 0;
      bool black = false;
      for (int y = y0; y < y0 + kPatch; ++y) {
        const uint8_t* row = l.ptr<uint8_t>(y);
        for (int x = x0; x < x0 + kPatch; ++x) {
          black |= row[x] == 0;
          sum += row[x];
          sum_sq += double(row[x]) * row[x];
        }
      }
      const double n = kPatch * kPatch, mean = sum / n;
      if (black || sum_sq / n - mean * mean < 25.0) continue;  // std < 5 grey levels: flat
      // Mean-removed SAD at every shift s: left(x) against right(x - s).
      for (int s = -range; s <= range; ++s) {
        const int xr = x0 - s;
        double cost = std::numeric_limits<double>::infinity();
        if (xr >= 0 && xr + kPatch <= r.cols) {
          double rsum = 0;
          bool rblack = false;
          for (int y = y0; y < y0 + kPatch; ++y) {
            const uint8_t* row = r.ptr<uint8_t>(y);
            for (int x = xr; x < xr + kPatch; ++x) {
              rblack |= row[x] == 0;
              rsum += row[x];
            }
          }
          if (!rblack) {
            const double offset = (sum - rsum) / n;
            cost = 0;
            for (int y = y0; y < y0 + kPatch; ++y) {
              const uint8_t* lr = l.ptr<uint8_t>(y) + x0;
              const uint8_t* rr = r.ptr<uint8_t>(y) + xr;
              for (int x = 0; x < kPatch; ++x) cost += std::fabs(lr[x] - rr[x] - offset);
            }
          }
        }
        costs[static_cast<size_t>(s + range)] = cost;
      }
      // Distinct: the best cost clearly below the typical cost, and not tied
      // with a shift of the other sign.
      int best = 0;
      double best_pos = std::numeric_limits<double>::infinity(), best_neg = best_pos;
      std::vector<double> finite;
      for (int s = -range; s <= range; ++s) {
        const double c = costs[static_cast<size_t>(s + range)];
        if (!std::isfinite(c)) continue;
        finite.push_back(c);
        if (s >= 0 && c < best_pos) best_pos = c;
        if (s < 0 && c < best_neg) best_neg = c;
        if (c < costs[static_cast<size_t>(best + range)] || !std::isfinite(costs[static_cast<size_t>(best + range)]))
          best = s;
      }
      if (finite.size() < 8) continue;
      std::nth_element(finite.begin(), finite.begin() + static_cast<long>(finite.size() / 2), finite.end());
      const double typical = finite[finite.size() / 2];
      const double best_cost = std::min(best_pos, best_neg);
      const double other_sign = best < 0 ? best_pos : best_neg;
      if (!(best_cost < 0.5 * typical) || !(best_cost < 0.8 * other_sign)) continue;
      ++check.distinct_patches;
      if (best < 0) ++check.negative;
    }
  }
  return check;
}

namespace {

/// Grey levels and validity of the rows of a view, as the matcher takes them.
struct GreyRow {
  std::vector<uchar> grey, valid;
  explicit GreyRow(int width) : grey(static_cast<size_t>(width)), valid(static_cast<size_t>(width)) {}
  void load(const cv::Mat& image, int y) {
    const uchar* row = image.ptr<uchar>(y);
    constexpr int kNoSaturation = 256;  // a clipped highlight is texture-free, not a codec's
    if (image.channels() == 1) {
      std::copy(row, row + image.cols, grey.begin());
      detail::validityOfMonoRow(row, image.cols, kNoSaturation, valid.data());
    } else {
      detail::lumaOfBgrRow(row, image.cols, kNoSaturation, grey.data(), valid.data());
    }
  }
};

}  // namespace

BlockArtefactCheck checkBlockArtefacts(const cv::Mat& image) {
  if (image.empty() || image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3)) {
    throw std::invalid_argument("checkBlockArtefacts: an 8-bit mono or BGR image expected");
  }
  detail::PhaseSteps along_x, along_y;
  GreyRow above(image.cols), row(image.cols);
  for (int y = 0; y < image.rows; ++y) {
    row.load(image, y);
    along_x.addRow(row.grey.data(), row.valid.data(), image.cols);
    if (y > 0) {
      for (size_t x = 0; x < row.grey.size(); ++x) {
        along_y.add(y % detail::kCodecBlock, above.grey[x], row.grey[x], above.valid[x] && row.valid[x]);
      }
    }
    std::swap(above, row);
  }
  BlockArtefactCheck check;
  check.grid_contrast = 0.5 * (along_x.contrast() + along_y.contrast());
  return check;
}

}  // namespace bdis
