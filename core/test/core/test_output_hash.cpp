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
      {"coarser_look_variance",
       [](MatcherParams& p) {
         p.coarser_look = true;
         p.compute_variance = true;
       }},
      {"gain_compensation", [](MatcherParams& p) { p.gain_compensation = true; }},
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
    {"balanced", 0x38b169dbacd82dfbull, 0x32c356bcfa8c94beull, 0xc109a8f6e22c3c3aull},
    {"fast", 0x94a473e58565ba69ull, 0xd1fed18e8ac19f21ull, 0xac3fd755b71bf687ull},
    {"accurate", 0x7b9071453c0d9259ull, 0x833dd01c2536694bull, 0xaf1c639241292962ull},
    {"balanced_variance", 0xd115646c80e380a9ull, 0xaaac0a260d6156bbull, 0xd22144d180569218ull},
    {"accurate_variance", 0x658220e390d12ecdull, 0x4d6ab0c74407631cull, 0x3e708980c8e24dbeull},
    {"finest_0", 0x1972d8d9eb87b026ull, 0x2ed6795075d75dc4ull, 0x731a4957f901237full},
    {"finest_2", 0x6b272d993777f184ull, 0x07d9fc5eb622c4d4ull, 0x2e5994128a94c09eull},
    {"levels_3_3", 0x4fd88a4f4d20f9daull, 0xcf83d6428a48863full, 0x6f4ea21e08abcce4ull},
    {"whole_level_search", 0xf4c3cb1c6c03b519ull, 0x12144f4ffcf5fb62ull, 0x2321221ea7284c2dull},
    {"one_row_bands", 0x6e88d6d68a0e81c3ull, 0x7cb2851f0b5d9126ull, 0xae7617ac6f43aea9ull},
    {"no_check", 0xdd47b7d33ac5a19bull, 0xc9127410ce9a575aull, 0xb21afa5c032355caull},
    {"no_propagation_no_mean", 0xa4509f1787be4ad7ull, 0x74df227498ed44d2ull, 0x51f3ceafbf35b03eull},
    {"half_pixel_window", 0x18dd801ad9fe1ac8ull, 0x07e97cdc47aad655ull, 0x8b619ef79beb1431ull},
    {"patch_4", 0x9b9d7828284016edull, 0xb1b3f6918cc7d432ull, 0x9b9d7828284016edull},
    {"patch_12", 0x60eb164b0ca1c98dull, 0x4a224fbe8fafb846ull, 0x60eb164b0ca1c98dull},
    {"patch_7_variance", 0xabfe125a6e96a068ull, 0xabfe125a6e96a068ull, 0xabfe125a6e96a068ull},
    {"paper_posterior", 0x418d3da1969ce38full, 0xf602cc2d0cf0072cull, 0xe7bb37209867fc59ull},
    {"twelve_iterations_variance", 0x28dd41e1740f9a19ull, 0xfdeb7dec7908e75eull, 0x6076668fba0af040ull},
    {"strict_validity", 0x25249843dd62df82ull, 0xa52f8fa5c49f80b2ull, 0x5ed7532ff3f3f08dull},
    {"tiny_sigma_s_variance", 0x92d8a3613b79404cull, 0x3c1c4e3499054874ull, 0xab74ee3e58ed4c7bull},
    {"coarser_look_variance", 0x4569c98eaf50b3a7ull, 0x53207059d14c7998ull, 0xad820f92a97642efull},
    {"gain_compensation", 0x69e06226966ece2cull, 0x001240b7aa8e3c0aull, 0x02d13e68e4778083ull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0x535b073718a2872full, 0x38d7338a8ed8c146ull, 0x9c0e83ab75ed1f2dull},
    {"fast", 0xae3f68c660b3ebadull, 0xdfa44491934c467full, 0x6a67304381d70751ull},
    {"accurate", 0x388ae62729648be4ull, 0xbe63bd130b982ae6ull, 0x3ef01f1f82816ebeull},
    {"balanced_variance", 0x0e722b1f0b1db346ull, 0x1d4261e3c11b8d45ull, 0x842a2a4bad8c5843ull},
    {"accurate_variance", 0x96868fdc1c120600ull, 0x381b3862e84445afull, 0xb10577ed78dd9143ull},
    {"finest_0", 0xab3ce409fe1172eeull, 0x2010cf130bc6078aull, 0x5518ed0399ff6c86ull},
    {"finest_2", 0xb098fe44d8f33589ull, 0x9ed73d7c40c2e99bull, 0x4549cb9df8edbeddull},
    {"levels_3_3", 0xbfd638787e6ae79cull, 0xb564f752131809ddull, 0x82384c345d85ced9ull},
    {"whole_level_search", 0xc42a44619728e642ull, 0xe38416310b4f9a0eull, 0x037e4b5dad9c2b8aull},
    {"one_row_bands", 0xaf5ce38cc51b9b23ull, 0x5334270f78b89e82ull, 0x52c8037f8b0842a8ull},
    {"no_check", 0xd8be90dea18b514full, 0x2168ce7084e4b468ull, 0xc115295dd5f53663ull},
    {"no_propagation_no_mean", 0x292dc526cb207d58ull, 0xdac8ab39c866a93full, 0xf019a3b00d6f9991ull},
    {"half_pixel_window", 0xb7ac7e4e52d87972ull, 0x0a6f5957b4a55643ull, 0x05a1617e9809cffbull},
    {"patch_4", 0x75606a7631cceb3full, 0x7f4bf3378a3dff75ull, 0x75606a7631cceb3full},
    {"patch_12", 0xf60bdc68c0b6127eull, 0x4d15e2f95ee2e2a8ull, 0xf60bdc68c0b6127eull},
    {"patch_7_variance", 0x0efe42236b9931b9ull, 0x0efe42236b9931b9ull, 0x0efe42236b9931b9ull},
    {"paper_posterior", 0xcf1bae38e65b7c93ull, 0xc246b439ac62cde8ull, 0x51a075ae80a429fcull},
    {"twelve_iterations_variance", 0xa23f3ee477bad896ull, 0xa5f709fdb39506a8ull, 0xc84cdd48ebe6400eull},
    {"strict_validity", 0x33a821008cc98242ull, 0x0975b50003065908ull, 0x62c53ab1582f9553ull},
    {"tiny_sigma_s_variance", 0x5fd5c83b8b2ea00cull, 0x9b938c235ae26675ull, 0x97e2767d6f65ab3eull},
    {"coarser_look_variance", 0x56a505ecf9ea6490ull, 0xef85cc4367b27c0bull, 0xdbff8cfa4a2ec194ull},
    {"gain_compensation", 0xce484e2d5ca8b988ull, 0x11162cc768133057ull, 0xfcf1833564a98080ull},
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
