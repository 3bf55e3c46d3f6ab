#include "pyramid.hpp"

#include <algorithm>

namespace bdis {
namespace detail {
namespace {

// Rec. 601 luma in 8.8 fixed point (within 1 grey level of cv::cvtColor).
inline float bgrToGrey(const uchar* bgr) {
  return static_cast<float>((29 * bgr[0] + 150 * bgr[1] + 77 * bgr[2] + 128) >> 8);
}

// Grey level 0 and validity of one 8-bit image. A pixel is outside the
// rectified view when every channel is 0; judged on the input, not on the
// grey value, so a very dark but real pixel stays valid.
void toGrey(const cv::Mat& src, cv::Mat1f& grey, cv::Mat1b& valid) {
  const int channels = src.channels();
  for (int y = 0; y < src.rows; ++y) {
    const uchar* s = src.ptr<uchar>(y);
    float* g = grey[y];
    uchar* v = valid[y];
    if (channels == 1) {
      for (int x = 0; x < src.cols; ++x) {
        g[x] = s[x];
        v[x] = s[x] != 0;
      }
    } else {
      for (int x = 0; x < src.cols; ++x, s += 3) {
        g[x] = bgrToGrey(s);
        v[x] = (s[0] | s[1] | s[2]) != 0;
      }
    }
  }
}

// 2x2 box average; a coarse pixel is valid only when all four fine ones are,
// so black borders never bleed into darker-than-real tissue values.
void downsample(const cv::Mat1f& fine, const cv::Mat1b& fine_valid, cv::Mat1f& coarse,
                cv::Mat1b& coarse_valid) {
  for (int y = 0; y < coarse.rows; ++y) {
    const float* f0 = fine[2 * y];
    const float* f1 = fine[2 * y + 1];
    const uchar* v0 = fine_valid[2 * y];
    const uchar* v1 = fine_valid[2 * y + 1];
    float* c = coarse[y];
    uchar* cv = coarse_valid[y];
    for (int x = 0; x < coarse.cols; ++x) {
      const int a = 2 * x;
      c[x] = 0.25f * (f0[a] + f0[a + 1] + f1[a] + f1[a + 1]);
      cv[x] = v0[a] & v0[a + 1] & v1[a] & v1[a + 1];
    }
  }
}

// Central difference where both neighbours are valid, one-sided where only
// one is, 0 where neither is: invalid pixels never enter a gradient.
void horizontalGradient(const cv::Mat1f& img, const cv::Mat1b& valid, cv::Mat1f& gx) {
  const int w = img.cols;
  for (int y = 0; y < img.rows; ++y) {
    const float* p = img[y];
    const uchar* v = valid[y];
    float* g = gx[y];
    for (int x = 0; x < w; ++x) {
      const bool has_left = x > 0 && v[x - 1];
      const bool has_right = x + 1 < w && v[x + 1];
      if (!v[x]) {
        g[x] = 0.f;
      } else if (has_left && has_right) {
        g[x] = 0.5f * (p[x + 1] - p[x - 1]);
      } else if (has_right) {
        g[x] = p[x + 1] - p[x];
      } else if (has_left) {
        g[x] = p[x] - p[x - 1];
      } else {
        g[x] = 0.f;
      }
    }
  }
}

template <typename Src, typename Dst, typename F>
void integral(const cv::Mat_<Src>& src, cv::Mat_<Dst>& sum, F value) {
  std::fill(sum[0], sum[0] + sum.cols, Dst(0));
  for (int y = 0; y < src.rows; ++y) {
    const Src* s = src[y];
    const Dst* above = sum[y];
    Dst* out = sum[y + 1];
    out[0] = 0;
    Dst row = 0;
    for (int x = 0; x < src.cols; ++x) {
      row += value(s[x]);
      out[x + 1] = above[x + 1] + row;
    }
  }
}

void buildIntegrals(PyramidLevel& l) {
  integral(l.left_gx, l.gx_sum, [](float v) { return double(v); });
  integral(l.left_gx, l.gx_sq_sum, [](float v) { return double(v) * v; });
  integral(l.left_valid, l.left_invalid, [](uchar v) { return int(v == 0); });
  integral(l.right_valid, l.right_invalid, [](uchar v) { return int(v == 0); });
}

void allocate(PyramidLevel& l, int w, int h) {
  l.width = w;
  l.height = h;
  l.left.create(h, w);
  if (l.right_padded.rows != h || l.right_padded.cols != w + 2 * kRightPadding) {
    l.right_padded.create(h, w + 2 * kRightPadding);
    l.right_padded.setTo(0.f);  // only the padding stays 0; the view is rewritten per frame
    l.right = l.right_padded.colRange(kRightPadding, kRightPadding + w);
  }
  l.left_gx.create(h, w);
  l.left_valid.create(h, w);
  l.right_valid.create(h, w);
  l.gx_sum.create(h + 1, w + 1);
  l.gx_sq_sum.create(h + 1, w + 1);
  l.left_invalid.create(h + 1, w + 1);
  l.right_invalid.create(h + 1, w + 1);
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
                          int first_searched_level) {
  levels_.resize(static_cast<size_t>(num_levels));  // no-op once sized
  for (int s = 0; s < num_levels; ++s) {
    // Mat::create is a no-op when size and type are unchanged.
    allocate(levels_[s], left.cols >> s, left.rows >> s);
  }
  PyramidLevel& base = levels_[0];
  toGrey(left, base.left, base.left_valid);
  toGrey(right, base.right, base.right_valid);
  for (int s = 1; s < num_levels; ++s) {
    const PyramidLevel& fine = levels_[s - 1];
    PyramidLevel& coarse = levels_[s];
    downsample(fine.left, fine.left_valid, coarse.left, coarse.left_valid);
    downsample(fine.right, fine.right_valid, coarse.right, coarse.right_valid);
  }
  for (int s = first_searched_level; s < num_levels; ++s) {
    PyramidLevel& l = levels_[s];
    horizontalGradient(l.left, l.left_valid, l.left_gx);
    buildIntegrals(l);
  }
}

}  // namespace detail
}  // namespace bdis
