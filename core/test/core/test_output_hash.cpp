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
    {"balanced", 0x2b630cc0f542c05cull, 0xd791b7296403b8b3ull, 0x5948bdcf83ac3bb0ull},
    {"fast", 0x04cd0e9a41b85965ull, 0x6affc9293782614eull, 0x4c40ac8260a6d51eull},
    {"accurate", 0x3607357bde411834ull, 0xfb716683bdc5db13ull, 0x9b172815e0d055ccull},
    {"balanced_variance", 0xe7b1541df930476full, 0xdcdc7e307832c0efull, 0x6c187b3c608ded89ull},
    {"accurate_variance", 0x0d33d82c0be1603cull, 0xcc610411fb708d04ull, 0xccc002d41ad1682cull},
    {"finest_0", 0x9886d155b83b7818ull, 0x75d282343e8a2da0ull, 0xf318ab7000fba658ull},
    {"finest_2", 0x618f023962903d0cull, 0x5d689676d13721f2ull, 0xcd19df77292a2ac9ull},
    {"levels_3_3", 0xdd2adc699689fc37ull, 0x5bd905395247d27bull, 0xe472890d07b1eb78ull},
    {"whole_level_search", 0xba35d60a9cc56cc3ull, 0x01f5a3aa04ab0181ull, 0x537456786f5df319ull},
    {"one_row_bands", 0x87336b88460fb8abull, 0x01f9e96794e00a24ull, 0x7101015c218d3bc0ull},
    {"no_check", 0xddbf6243528f4b03ull, 0x7d6faf801e9a3518ull, 0x6225de9e05bdb347ull},
    {"no_propagation_no_mean", 0x67885d1834d66510ull, 0xd59f88d98b652d8dull, 0x4242184aee58c1daull},
    {"half_pixel_window", 0xa9cf6d598d94ae6dull, 0x424f877d97db09b0ull, 0xf520289d6c80b1f1ull},
    {"patch_4", 0x8a9157ac9a2fb1d7ull, 0x702817dfa7a39becull, 0x8a9157ac9a2fb1d7ull},
    {"patch_12", 0xecaec3a25b8c6fdbull, 0xdf91dd4a6df30cb9ull, 0xecaec3a25b8c6fdbull},
    {"patch_7_variance", 0xe84dd9a6f8250e4full, 0xe84dd9a6f8250e4full, 0xe84dd9a6f8250e4full},
    {"paper_posterior", 0xf3b8910d0e64e9ceull, 0x95144bd615750358ull, 0xcd90a4150279edb1ull},
    {"twelve_iterations_variance", 0x38ed66316c5ced43ull, 0x7fd8628133ff75c9ull, 0x3a693b21808f1503ull},
    {"strict_validity", 0xf2e70b05841a5e1full, 0xb57fe721fd485540ull, 0x28f3e5f757e722d4ull},
    {"tiny_sigma_s_variance", 0x99e6d1af7d40e4d5ull, 0xca48e2f48e9aa865ull, 0x2a298fea96b39d1dull},
    {"coarser_look_variance", 0x272616112cfa1901ull, 0xba265a3fd2ea27f2ull, 0xe624e2ede8ce5e90ull},
    {"gain_compensation", 0x5deb0024edf69d07ull, 0x951aafef5326c187ull, 0x68d807bc62c639e2ull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0xb19de95b19d344e6ull, 0x81bd2fc07a2957cdull, 0xd2c094d52b4c6ef9ull},
    {"fast", 0x442a2d160426d514ull, 0xa7b0d17e581ed950ull, 0x2bec95c3ec5aed48ull},
    {"accurate", 0x03555d34ce1f827eull, 0xa360788544c7c5d4ull, 0xe1cb85ec760a9ef7ull},
    {"balanced_variance", 0x5bfffd12223f2e86ull, 0x54729688cc28d77cull, 0xe27aec1cf232f1c0ull},
    {"accurate_variance", 0xdc3a835264ea6fecull, 0x327f52c0e7a7c811ull, 0x752d88ded91a304bull},
    {"finest_0", 0xc2c6f3b7b9cc9f64ull, 0xa48ec808b978d7bbull, 0x0df0879322582663ull},
    {"finest_2", 0xae894ddcd188dcf2ull, 0x24856195d5811676ull, 0x39483cab6f942c2eull},
    {"levels_3_3", 0x384f492dce648410ull, 0x87ffa38d5dcb3e27ull, 0x9c88ed94f4559092ull},
    {"whole_level_search", 0x10d6d3653e8b60c9ull, 0x297af762def3b50eull, 0x213f101a0c23c581ull},
    {"one_row_bands", 0xfa8ad8a2ec89ff5dull, 0x706fef8d98d2c78full, 0x59caeba053e2ff61ull},
    {"no_check", 0xad0f1cc4cec2303bull, 0x30070d0f85a80b0full, 0xfa46b0f40d746e81ull},
    {"no_propagation_no_mean", 0x8646a13f46044380ull, 0x96c85e238f51d318ull, 0x459357e0d9561978ull},
    {"half_pixel_window", 0x1763bc1265b5db9aull, 0x7aeb95ce6b79e636ull, 0xa76faf13ae78e843ull},
    {"patch_4", 0x303c0e999bb87704ull, 0x314006b2ec408c77ull, 0x303c0e999bb87704ull},
    {"patch_12", 0xfd999cd588aeaa11ull, 0x60e8d3b31077d2ccull, 0xfd999cd588aeaa11ull},
    {"patch_7_variance", 0x818dae928f1c288full, 0x818dae928f1c288full, 0x818dae928f1c288full},
    {"paper_posterior", 0xd18530ce9ca4f151ull, 0x3f04f0a0d703c100ull, 0xcd4e3dcf97cbee24ull},
    {"twelve_iterations_variance", 0xd0f1912fcefde948ull, 0xc8e5c275e59de413ull, 0xe0ab545c30e6f8ceull},
    {"strict_validity", 0xac817ab3bc25fe44ull, 0xb89689e36aab51fcull, 0x9a3ff2dac40b5b74ull},
    {"tiny_sigma_s_variance", 0xc2511a315732c7dfull, 0x6c70317464d679b7ull, 0x28bbf7891d384ce3ull},
    {"coarser_look_variance", 0xc671b0547f29f20bull, 0x22551f2a5b5be78cull, 0x8d1b7de0f9a15138ull},
    {"gain_compensation", 0x2d3791304c3a21d6ull, 0x956d5a4164058cbaull, 0xcf7d38012ba5135aull},
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
