// The specular lobe cue (specular_lobe_cue.hpp) on hand-made level images: a
// clipped highlight inside a broad lobe over faint texture, the same over
// strong texture, a bright lobe without a clipped pixel and a black frame,
// and a brute-force reference of the same definition, on odd-sized images.
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include <gtest/gtest.h>

#include "bdis_stereo/matcher.hpp"
#include "specular_lobe_cue.hpp"

namespace {

using bdis::kNoDisparity;
using bdis::detail::SpecularLobeCue;

constexpr int kPatch = 8;
constexpr float kHalving = 0.5f;
constexpr int kSaturation = 255;

struct LevelImage {
  cv::Mat1f grey, gradient;
  cv::Mat1b valid;
};

/// A Gaussian lobe of `peak` grey levels (sigma `lobe_sigma` px) centred at
/// (cx, cy) on a base of 60, plus a texture of `texture` grey levels
/// (products of sines, a few px per period); grey levels of 255 and more are
/// clipped: 255 and invalid. The gradient is the central difference over
/// valid neighbours, as the pyramid's.
LevelImage lobeImage(int w, int h, float cx, float cy, float lobe_sigma, float peak, float texture) {
  LevelImage im{cv::Mat1f(h, w), cv::Mat1f(h, w, 0.f), cv::Mat1b(h, w, uchar{1})};
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const float r2 = ((x - cx) * (x - cx) + (y - cy) * (y - cy)) / (lobe_sigma * lobe_sigma);
      const float g = 60.f + peak * std::exp(-0.5f * r2) + texture * std::sin(1.7f * x) * std::sin(1.3f * y + 0.4f);
      if (g >= 255.f) im.valid(y, x) = 0;
      im.grey(y, x) = std::min(g, 255.f);
    }
  }
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (!im.valid(y, x)) continue;
      const bool left = x > 0 && im.valid(y, x - 1), right = x + 1 < w && im.valid(y, x + 1);
      if (left && right) im.gradient(y, x) = 0.5f * (im.grey(y, x + 1) - im.grey(y, x - 1));
      else if (right) im.gradient(y, x) = im.grey(y, x + 1) - im.grey(y, x);
      else if (left) im.gradient(y, x) = im.grey(y, x) - im.grey(y, x - 1);
    }
  }
  return im;
}

/// Estimates everywhere the image is valid.
cv::Mat1f estimatesWhereValid(const LevelImage& im) {
  cv::Mat1f d(im.grey.size(), kNoDisparity);
  d.setTo(12.f, im.valid);
  return d;
}

cv::Mat1f applyCue(const LevelImage& im, const cv::Mat1f& d, int saturation = kSaturation) {
  cv::Mat1f c(d.size(), 0.9f);
  SpecularLobeCue cue;
  cue.apply(d, im.grey, im.valid, im.gradient, saturation, kPatch, kHalving, c);
  return c;
}

/// The cue's definition for the block of pixel (x, y), block by block, with
/// boxes clipped to the image.
float referenceFactor(const LevelImage& im, int x, int y) {
  const int w = im.grey.cols, h = im.grey.rows, bw = (w + 1) / 2, bh = (h + 1) / 2;
  const int bx = x / 2, by = y / 2;
  auto clipped = [&](int u, int v) {
    return !im.valid(v, u) && im.grey(v, u) >= SpecularLobeCue::kClippedGreyShare * kSaturation;
  };
  int distance = std::numeric_limits<int>::max();
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      if (clipped(u, v)) distance = std::min(distance, std::abs(u / 2 - bx) + std::abs(v / 2 - by));
    }
  }
  const int fade = SpecularLobeCue::kFadePatches * kPatch;
  if (distance > SpecularLobeCue::kReachFades * fade / 2) return 1.f;
  // The mean grey of the pixels of a box of blocks (an odd size's last
  // blocks hold fewer pixels and weigh less).
  auto smooth = [&](int i, int j) {
    const int r = std::max(1, kPatch / 8);
    double sum = 0, n = 0;
    for (int v = 2 * std::max(0, j - r); v <= std::min(2 * (j + r) + 1, h - 1); ++v) {
      for (int u = 2 * std::max(0, i - r); u <= std::min(2 * (i + r) + 1, w - 1); ++u) {
        sum += im.grey(v, u);
        n += 1;
      }
    }
    return sum / n;
  };
  double smooth_energy = 0, texture_energy = 0;
  const int r = std::max(1, kPatch / 4);
  for (int j = std::max(0, by - r); j <= std::min(bh - 1, by + r); ++j) {
    for (int i = std::max(0, bx - r); i <= std::min(bw - 1, bx + r); ++i) {
      const int a = std::max(i - 1, 0), b = std::min(i + 1, bw - 1);
      const double s = b > a ? (smooth(b, j) - smooth(a, j)) / (2.0 * (b - a)) : 0.0;
      for (int v = 2 * j; v <= std::min(2 * j + 1, h - 1); ++v) {
        for (int u = 2 * i; u <= std::min(2 * i + 1, w - 1); ++u) {
          if (!im.valid(v, u)) continue;
          smooth_energy += s * s;
          texture_energy += (im.gradient(v, u) - s) * (im.gradient(v, u) - s);
        }
      }
    }
  }
  texture_energy = std::max(texture_energy, 1e-6);
  if (!(smooth_energy > texture_energy)) return 1.f;
  const double excess = (std::sqrt(smooth_energy / texture_energy) - 1.0) *
                        std::exp(-2.0 * distance / fade);
  return static_cast<float>(1.0 / (1.0 + excess * excess / (kHalving * kHalving)));
}

/// The estimates `inner`-`outer` px from the lobe's centre (64, 48): how
/// many, and how many of them have a confidence `c` passes.
template <class Pass>
std::pair<int, int> ringCount(const cv::Mat1f& d, const cv::Mat1f& c, Pass pass, float inner = 8.f,
                              float outer = 16.f) {
  int ring = 0, passed = 0;
  for (int y = 0; y < d.rows; ++y) {
    for (int x = 0; x < d.cols; ++x) {
      const float r = std::hypot(x - 64.f, y - 48.f);
      if (r < inner || r > outer || d(y, x) < 0.f) continue;
      ++ring;
      passed += pass(c(y, x)) ? 1 : 0;
    }
  }
  return {ring, passed};
}

TEST(SpecularLobeCue, LowersTheRingOfALobeOverFaintTexture) {
  // A lobe of sigma 14 px whose core (about 9 px across) is clipped, on
  // texture of 2 grey levels.
  const LevelImage im = lobeImage(128, 96, 64.f, 48.f, 14.f, 215.f, 2.f);
  ASSERT_GT(cv::countNonZero(im.valid == 0), 20);
  const cv::Mat1f d = estimatesWhereValid(im);
  const cv::Mat1f c = applyCue(im, d);
  // The ring around the clipped core: mostly halved or less.
  const auto [ring, lowered] = ringCount(d, c, [](float v) { return v < 0.45f; });
  EXPECT_GT(ring, 300);
  EXPECT_GT(lowered, ring * 3 / 4) << lowered << " of " << ring;
  // Two to three patch sides out the ramp still outweighs the texture:
  // 657 of 876 below 0.6 with the cue fading over two patch sides, 211 when
  // it faded over one.
  const auto [outer_ring, outer_lowered] = ringCount(d, c, [](float v) { return v < 0.6f; }, 20.f, 26.f);
  EXPECT_GT(outer_ring, 300);
  EXPECT_GT(outer_lowered, outer_ring * 2 / 3) << outer_lowered << " of " << outer_ring;
  // Beyond the reach (8 patch sides from the core), untouched.
  EXPECT_EQ(c(2, 2), 0.9f);
  EXPECT_EQ(c(93, 125), 0.9f);
  // Pixels without an estimate keep what they had.
  EXPECT_EQ(c(48, 64), 0.9f);
}

TEST(SpecularLobeCue, StrongTextureOutweighsTheLobe) {
  // The same lobe over texture of 40 grey levels: the patches match the
  // texture, and near every ring pixel keeps its confidence.
  const LevelImage im = lobeImage(128, 96, 64.f, 48.f, 14.f, 215.f, 40.f);
  const cv::Mat1f d = estimatesWhereValid(im);
  const auto [ring, kept] = ringCount(d, applyCue(im, d), [](float v) { return v > 0.85f; });
  EXPECT_GT(kept, ring * 9 / 10) << kept << " of " << ring;
}

TEST(SpecularLobeCue, NoClippedPixelNoChange) {
  // A lobe that peaks below the clip, a black frame (invalid, dark) beside
  // a ramp, and a clipped lobe with the saturation rule off: all unchanged.
  const LevelImage unclipped = lobeImage(128, 96, 64.f, 48.f, 14.f, 180.f, 2.f);
  ASSERT_EQ(cv::countNonZero(unclipped.valid == 0), 0);
  cv::Mat1f c = applyCue(unclipped, estimatesWhereValid(unclipped));
  EXPECT_EQ(cv::countNonZero(c != 0.9f), 0);

  LevelImage framed = lobeImage(128, 96, 100.f, 48.f, 30.f, 120.f, 1.f);
  framed.grey.colRange(0, 20).setTo(0.f);
  framed.grey.colRange(20, 22).setTo(15.f);  // the dark seam
  framed.valid.colRange(0, 22).setTo(0);
  c = applyCue(framed, estimatesWhereValid(framed));
  EXPECT_EQ(cv::countNonZero(c != 0.9f), 0);

  const LevelImage clipped = lobeImage(128, 96, 64.f, 48.f, 14.f, 215.f, 2.f);
  c = applyCue(clipped, estimatesWhereValid(clipped), 256);
  EXPECT_EQ(cv::countNonZero(c != 0.9f), 0);
}

TEST(SpecularLobeCue, EqualsItsDefinition) {
  // Two lobes (one clipped), a faint texture and holes in the estimates,
  // against the reference pixel by pixel.
  LevelImage im = lobeImage(73, 55, 30.f, 26.f, 9.f, 230.f, 3.f);
  const LevelImage second = lobeImage(73, 55, 58.f, 40.f, 12.f, 120.f, 3.f);
  im.grey = cv::max(im.grey, second.grey);
  // The gradient again, of the combined image.
  const LevelImage combined = [&] {
    LevelImage c = im;
    c.gradient.setTo(0.f);
    for (int y = 0; y < c.grey.rows; ++y) {
      for (int x = 0; x < c.grey.cols; ++x) {
        if (!c.valid(y, x)) continue;
        const bool l = x > 0 && c.valid(y, x - 1), r = x + 1 < c.grey.cols && c.valid(y, x + 1);
        if (l && r) c.gradient(y, x) = 0.5f * (c.grey(y, x + 1) - c.grey(y, x - 1));
        else if (r) c.gradient(y, x) = c.grey(y, x + 1) - c.grey(y, x);
        else if (l) c.gradient(y, x) = c.grey(y, x) - c.grey(y, x - 1);
      }
    }
    return c;
  }();
  cv::Mat1f d = estimatesWhereValid(combined);
  d(cv::Rect(50, 10, 6, 5)).setTo(kNoDisparity);
  const cv::Mat1f c = applyCue(combined, d);
  int checked = 0, lowered = 0;
  for (int y = 0; y < d.rows; ++y) {
    for (int x = 0; x < d.cols; ++x) {
      if (d(y, x) < 0.f) {
        ASSERT_EQ(c(y, x), 0.9f);
        continue;
      }
      // The sliding float sums round (box_sums.hpp): within a thousandth.
      ASSERT_NEAR(c(y, x), 0.9f * referenceFactor(combined, x, y), 1e-3f) << x << "," << y;
      ++checked;
      lowered += c(y, x) < 0.8f;
    }
  }
  EXPECT_GT(checked, 3500);
  EXPECT_GT(lowered, 50);  // the reference is not trivially 1
}

}  // namespace
