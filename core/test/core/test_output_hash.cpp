// Golden hashes of the matcher's outputs: a fixed set of configurations run on
// a fixed set of generated pairs (and the first frame of each colon sequence
// when the shared data is there), every output hashed bit for bit. A change
// meant to keep behaviour (a restructuring, a faster kernel) must keep every
// hash; a change of behaviour updates the table in the same commit, saying
// why. To print the table for the current build:
//   BDIS_PRINT_OUTPUT_HASHES=1 test_core --gtest_filter='OutputHash*'
// Hashes are per kernel instruction set (the scalar, baseline and AVX2
// kernels round differently); an ISA this CPU lacks is skipped.
#include <gtest/gtest.h>

#include <array>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "bdis_stereo/evaluation.hpp"
#include "bdis_stereo/matcher.hpp"
#include "patch_kernels.hpp"
#include "test_images.hpp"

namespace {

using bdis::MatcherParams;
using bdis::detail::KernelIsa;
using namespace bdis_test;

struct NamedConfig {
  const char* name;
  std::function<void(MatcherParams&)> change;
};

const std::vector<NamedConfig>& configs() {
  static const std::vector<NamedConfig> list = {
      {"balanced", [](MatcherParams&) {}},
      {"fast", [](MatcherParams& p) { p = MatcherParams::preset("fast"); }},
      {"accurate", [](MatcherParams& p) { p = MatcherParams::preset("accurate"); }},
      {"balanced_variance", [](MatcherParams& p) { p.compute_variance = true; }},
      {"accurate_variance",
       [](MatcherParams& p) {
         p = MatcherParams::preset("accurate");
         p.compute_variance = true;
       }},
      {"finest_0", [](MatcherParams& p) { p.finest_level = 0; }},
      {"finest_2", [](MatcherParams& p) { p.finest_level = 2; }},
      {"levels_3_3", [](MatcherParams& p) { p.coarsest_level = p.finest_level = 3; }},
      {"whole_level_search", [](MatcherParams& p) { p.search_band_rows = 0; }},
      {"one_row_bands", [](MatcherParams& p) { p.search_band_rows = 1; }},
      {"no_check", [](MatcherParams& p) { p.lr_check_tolerance = 0.f; }},
      {"no_propagation_no_mean",
       [](MatcherParams& p) {
         p.propagation = false;
         p.mean_normalization = false;
       }},
      {"half_pixel_window",
       [](MatcherParams& p) {
         p.window_step = 0.5f;
         p.window_half_width = 3;
       }},
      {"patch_4", [](MatcherParams& p) { p.patch_size = 4; }},
      {"patch_12", [](MatcherParams& p) {
         p.patch_size = 12;
         p.overlap = 0.5f;
       }},
      {"patch_7_variance",
       [](MatcherParams& p) {
         p.patch_size = 7;
         p.compute_variance = true;
       }},
      {"paper_posterior", [](MatcherParams& p) {
         p.contrast_share = 0.f;
         p.sigma_r = 4.f;
       }},
      {"twelve_iterations_variance",
       [](MatcherParams& p) {
         p.iterations = 12;
         p.compute_variance = true;
       }},
      {"strict_validity", [](MatcherParams& p) { p.min_valid_share = 0.75f; }},
      {"tiny_sigma_s_variance",
       [](MatcherParams& p) {
         p.sigma_s = 0.3f;
         p.compute_variance = true;
       }},
  };
  return list;
}

struct NamedPair {
  std::string name;
  cv::Mat left, right;
};

/// A textured plane slanted in x, black borders of different widths in the
/// two views and a black hole inside the left view.
NamedPair slantedWithBorders(bool colour, int width, int height) {
  StereoPair p = texturedPair(width, height, {6.0, 0.03}, 21);
  p.left.colRange(0, 9).setTo(0);
  p.right.colRange(0, 5).setTo(0);
  p.right.rowRange(height - 7, height).setTo(0);
  p.left(cv::Rect(width / 2, height / 3, 6, 5)).setTo(0);
  NamedPair out{colour ? "slanted_bgr" : "slanted_mono", p.left, p.right};
  if (colour) {
    // Channels that differ, so that the luma conversion is exercised.
    cv::Mat channels_l[] = {p.left, p.left * 0.8, p.left * 0.6};
    cv::Mat channels_r[] = {p.right, p.right * 0.8, p.right * 0.6};
    cv::merge(channels_l, 3, out.left);
    cv::merge(channels_r, 3, out.right);
  }
  return out;
}

/// A strip at 20 px in front of a background at 4 px: an occluded band.
NamedPair occludingStrip() {
  constexpr int w = 200, h = 96, x0 = 80, x1 = 140;
  const Texture background(3), foreground(4);
  std::vector<double> xs(w), xs_bg(w), xs_fg(w);
  for (int x = 0; x < w; ++x) {
    xs[static_cast<size_t>(x)] = x;
    xs_bg[static_cast<size_t>(x)] = x + 4.0;
    xs_fg[static_cast<size_t>(x)] = x + 20.0;
  }
  NamedPair p{"occluding_strip", background.render(xs, h), background.render(xs_bg, h)};
  foreground.render(xs, h).colRange(x0, x1).copyTo(p.left.colRange(x0, x1));
  foreground.render(xs_fg, h).colRange(x0 - 20, x1 - 20).copyTo(p.right.colRange(x0 - 20, x1 - 20));
  return p;
}

/// A flat disk, a highlight saturated in the left view only and a dark corner.
NamedPair flatSaturatedDark() {
  StereoPair p = texturedPair(144, 112, {9.0, 0.0}, 5);
  cv::circle(p.left, {50, 50}, 14, cv::Scalar(140), cv::FILLED);
  cv::circle(p.right, {41, 50}, 14, cv::Scalar(140), cv::FILLED);
  cv::circle(p.left, {100, 70}, 8, cv::Scalar(255), cv::FILLED);
  for (cv::Mat* m : {&p.left, &p.right}) {
    cv::Mat corner = (*m)(cv::Rect(0, 80, 40, 32));
    corner = corner * 0.08 + 1.0;  // near the noise floor, but not black
  }
  return {"flat_saturated_dark", p.left, p.right};
}

/// The smallest accepted size and odd sides.
NamedPair smallOdd() {
  cv::Mat left, right;
  blurredNoisePair(7, 3, 37, 33, 1.5, left, right);
  return {"small_odd", left, right};
}

std::vector<NamedPair> generatedPairs() {
  return {slantedWithBorders(false, 160, 120), slantedWithBorders(true, 161, 97), occludingStrip(),
          flatSaturatedDark(), smallOdd()};
}

/// FNV-1a over the bytes of every output row; every NaN hashed as one pattern.
class Fnv1a {
 public:
  void add(const void* data, size_t n) {
    const auto* b = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < n; ++i) h_ = (h_ ^ b[i]) * 1099511628211ull;
  }
  void add(const cv::Mat& m) {
    const int dims[] = {m.rows, m.cols, m.type()};
    add(dims, sizeof dims);
    if (m.empty()) return;
    CV_Assert(m.type() == CV_32FC1);
    for (int y = 0; y < m.rows; ++y) {
      const float* row = m.ptr<float>(y);
      for (int x = 0; x < m.cols; ++x) {
        const float v = std::isnan(row[x]) ? std::numeric_limits<float>::quiet_NaN() : row[x];
        add(&v, sizeof v);
      }
    }
  }
  uint64_t value() const { return h_; }

 private:
  uint64_t h_ = 1469598103934665603ull;
};

/// One hash per configuration over every pair: disparity, confidence and variance.
uint64_t hashConfig(const NamedConfig& config, const std::vector<NamedPair>& pairs) {
  MatcherParams params;
  config.change(params);
  bdis::Matcher matcher(params);
  bdis::MatchResult result;
  Fnv1a h;
  for (const NamedPair& pair : pairs) {
    matcher.compute(pair.left, pair.right, result);
    h.add(result.disparity);
    h.add(result.confidence);
    h.add(result.variance);
  }
  return h.value();
}

struct Expected {
  const char* config;
  uint64_t scalar, baseline, avx2;
};

const char* isaName(KernelIsa isa) {
  switch (isa) {
    case KernelIsa::Scalar: return "scalar";
    case KernelIsa::Baseline: return "baseline";
    case KernelIsa::Avx2: return "avx2";
  }
  return "?";
}

/// Sets BDIS_SIMD for the matchers constructed while it lives.
class ForcedIsa {
 public:
  explicit ForcedIsa(KernelIsa isa) {
    const char* saved = std::getenv("BDIS_SIMD");
    had_ = saved != nullptr;
    if (had_) saved_ = saved;
    setenv("BDIS_SIMD", isa == KernelIsa::Scalar ? "off" : isa == KernelIsa::Baseline ? "baseline" : "", 1);
  }
  ~ForcedIsa() {
    if (had_) setenv("BDIS_SIMD", saved_.c_str(), 1);
    else unsetenv("BDIS_SIMD");
  }

 private:
  bool had_ = false;
  std::string saved_;
};

/// Compares (or, with BDIS_PRINT_OUTPUT_HASHES set, prints) the hash of every
/// configuration on `pairs` under every kernel ISA this CPU runs.
void checkHashes(const std::vector<NamedPair>& pairs, const std::vector<Expected>& expected,
                 const char* table_name) {
  const bool print = std::getenv("BDIS_PRINT_OUTPUT_HASHES") != nullptr;
  if (!print) {
    ASSERT_EQ(expected.size(), configs().size()) << "one expected row per configuration";
  }
  std::vector<std::array<uint64_t, 3>> got(configs().size(), {0, 0, 0});
  for (KernelIsa isa : {KernelIsa::Scalar, KernelIsa::Baseline, KernelIsa::Avx2}) {
    if (!bdis::detail::kernelIsaAvailable(isa)) {
      std::printf("[skipped] %s kernels: not available on this CPU\n", isaName(isa));
      continue;
    }
    const ForcedIsa forced(isa);
    for (size_t i = 0; i < configs().size(); ++i) {
      const uint64_t h = hashConfig(configs()[i], pairs);
      got[i][static_cast<size_t>(isa)] = h;
      if (print) continue;
      const Expected& e = expected[i];
      ASSERT_STREQ(e.config, configs()[i].name);
      const uint64_t want = isa == KernelIsa::Scalar ? e.scalar : isa == KernelIsa::Baseline ? e.baseline : e.avx2;
      EXPECT_EQ(h, want) << table_name << ": outputs of configuration " << e.config << " with the "
                         << isaName(isa) << " kernels changed";
    }
  }
  if (!print) return;
  std::printf("const std::vector<Expected> %s = {\n", table_name);
  for (size_t i = 0; i < configs().size(); ++i) {
    std::printf("    {\"%s\", 0x%016" PRIx64 "ull, 0x%016" PRIx64 "ull, 0x%016" PRIx64 "ull},\n",
                configs()[i].name, got[i][0], got[i][1], got[i][2]);
  }
  std::printf("};\n");
}

// Hashes of the generated pairs, per configuration: scalar, baseline, AVX2 kernels.
const std::vector<Expected> kGeneratedPairHashes = {
    {"balanced", 0x7527dea7b4e203e6ull, 0xa17b319322b0ac49ull, 0xd2aa372a43d4ad1bull},
    {"fast", 0xca6abc9c8cdbb40eull, 0x6d9d5616d41518e1ull, 0x24802ed90e0fbfc4ull},
    {"accurate", 0xe1fdb769658efbacull, 0xd4468fea6d2b6e14ull, 0x4a490d49ef2aad08ull},
    {"balanced_variance", 0x7a58dd1b3d2d6143ull, 0x9eaade4052441370ull, 0xd757ec768f031ca3ull},
    {"accurate_variance", 0xba75da545f184033ull, 0xcff133daf81fae3eull, 0xe965a3d414eb7255ull},
    {"finest_0", 0xce00c683f327e2faull, 0xa95989afdf02d440ull, 0x59fe6973192fa656ull},
    {"finest_2", 0x9891dde252b2860cull, 0x84e093ee9698335dull, 0x92a42c00889f228full},
    {"levels_3_3", 0x93ace0924d3d144cull, 0xe8e1270340e3cd18ull, 0x382baef9fde456a6ull},
    {"whole_level_search", 0xa621bd4cb89ccab1ull, 0xe67d09381860f4f9ull, 0xd8bb96b1a11cb5e8ull},
    {"one_row_bands", 0x0c367d6eea7cb6d3ull, 0x26a8dc052f311a86ull, 0xf2d980294142536dull},
    {"no_check", 0x466271e1cebc1deeull, 0x130ecc222d437d77ull, 0x00a0c3f196c559fcull},
    {"no_propagation_no_mean", 0xb9ab4fbb91ed9ba4ull, 0x2794c5b723a9a43dull, 0xe1d5a47ffe920a24ull},
    {"half_pixel_window", 0xcdd56c0709ab18d6ull, 0xc73ae539188c405eull, 0xaab9020507a4c410ull},
    {"patch_4", 0xa57192863e089ce6ull, 0x6a2cdecc240c5cc3ull, 0xa57192863e089ce6ull},
    {"patch_12", 0x0d5fb92dfe049e53ull, 0x0c6455f97311b244ull, 0x0d5fb92dfe049e53ull},
    {"patch_7_variance", 0xb7c29e395a5a5953ull, 0xb7c29e395a5a5953ull, 0xb7c29e395a5a5953ull},
    {"paper_posterior", 0x9f57af1b2b514ed1ull, 0xbaa0c75c99f3b5eeull, 0xa9abf168222442d0ull},
    {"twelve_iterations_variance", 0x32340ddca5bdb57cull, 0x6b7dff93c2e8b866ull, 0xd221da7f486450fbull},
    {"strict_validity", 0xbfce1e2bcb0d9641ull, 0xe965cf2f0c75437aull, 0x6c930a77f030b31dull},
    {"tiny_sigma_s_variance", 0xd5fcded5356ade81ull, 0xa18c751a1322de21ull, 0x7c36cf5125f1f9c5ull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0x398abffb0cc55572ull, 0x78bcaee0d3921c5cull, 0x773203184b2c4204ull},
    {"fast", 0x87c0d5fc71f4a7f4ull, 0xf6aada02417a48deull, 0x782e850631d28290ull},
    {"accurate", 0x1f7c88504b9f8a29ull, 0xe8af4e7cb8d3dfcdull, 0xe9d65c9e6c0bf901ull},
    {"balanced_variance", 0x8027fac132f95413ull, 0xbf3fd7e3e1f184efull, 0x48839917bdf31c8aull},
    {"accurate_variance", 0x0fcc3b7a47cb4c47ull, 0x757a3b9e0c2c66dbull, 0x45fcc834b86e1b83ull},
    {"finest_0", 0xf96cede975d29425ull, 0x14fa99e293bf1b61ull, 0x34b15a2839e42803ull},
    {"finest_2", 0xd2988746fc6979b8ull, 0x0ace8acb38d74ee4ull, 0xd2873e5665dd4970ull},
    {"levels_3_3", 0x3df2dece5273354full, 0xfb6da90d1adf0934ull, 0xd8a552ad5b6361eaull},
    {"whole_level_search", 0xc27230c4c2385c09ull, 0xd5243037d44693eaull, 0xab1ba3ebb1a393b2ull},
    {"one_row_bands", 0xd1030cc503633d75ull, 0x8b4d9c188b8e95d3ull, 0x9a0d5992111b7dffull},
    {"no_check", 0x42db03b7bea2ea3full, 0xa9f15df2f7124026ull, 0xdc0d268d37d9937dull},
    {"no_propagation_no_mean", 0x32bdadbe49fe4125ull, 0x7213ce2a96ff42f5ull, 0x6e2055a0be2dc1a2ull},
    {"half_pixel_window", 0x96f9c0e49b6014b0ull, 0x8ba010cf46640695ull, 0x44c74a1e3196fae5ull},
    {"patch_4", 0x9be08cd40d9927d8ull, 0xa2779f40de6e3f4full, 0x9be08cd40d9927d8ull},
    {"patch_12", 0xf7fbef5ffb220825ull, 0xf3f77048c7f6ae7aull, 0xf7fbef5ffb220825ull},
    {"patch_7_variance", 0xcd506f239b053547ull, 0xcd506f239b053547ull, 0xcd506f239b053547ull},
    {"paper_posterior", 0x180f290035808b61ull, 0xe758b7cce8a73a4cull, 0x99dc7dee80ac802eull},
    {"twelve_iterations_variance", 0xf0f696be5f85bc52ull, 0xec86185515b03022ull, 0x289265511e352644ull},
    {"strict_validity", 0x82617f911218d825ull, 0x20ff793011294490ull, 0x549ddc9762c02341ull},
    {"tiny_sigma_s_variance", 0x78b255d901f13944ull, 0x5dad9d0050bacae8ull, 0x72eeb4b852f44e66ull},
};

}  // namespace

TEST(OutputHash, GeneratedPairsGiveTheRecordedOutputs) {
  checkHashes(generatedPairs(), kGeneratedPairHashes, "kGeneratedPairHashes");
}

TEST(OutputHash, ColonFramesGiveTheRecordedOutputs) {
  const std::string data = bdis::findDataDir();
  if (data.empty()) {
    if (std::getenv("CI") && std::string(std::getenv("CI")) == "true") {
      FAIL() << "shared data not found (set BDIS_DATA_DIR)";
    }
    GTEST_SKIP() << "shared data not found (set BDIS_DATA_DIR)";
  }
  std::vector<NamedPair> pairs;
  for (const char* seq : {"synthetic_colon_diffuse", "synthetic_colon_specular"}) {
    const bdis::StereoSequence s = bdis::StereoSequence::open(data + "/" + seq);
    pairs.push_back({seq, s.left(0), s.right(0)});
  }
  checkHashes(pairs, kColonFrameHashes, "kColonFrameHashes");
}
