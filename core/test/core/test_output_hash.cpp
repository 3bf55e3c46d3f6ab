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
    {"balanced", 0xf9a724f57700b4a8ull, 0xb04e8d6ec03cab7cull, 0x9be99fd4e776e589ull},
    {"fast", 0x05643da0b9f819e6ull, 0xc3f1601c5bde21f0ull, 0x1e622a5b874bd105ull},
    {"accurate", 0x7924fa39730fa347ull, 0x0b20d7cb068dd133ull, 0xf4b92246f90b3b1aull},
    {"balanced_variance", 0x58a948949a30b651ull, 0xe24394126ba72d05ull, 0xc755ddd33a09fd51ull},
    {"accurate_variance", 0x8ee42581e16707c0ull, 0x206f7b15c1f24261ull, 0xac02b3b36b0c2effull},
    {"finest_0", 0xd9dc24d6c92109bbull, 0xf08d727175fee8e6ull, 0x5e205c9e4ef67478ull},
    {"finest_2", 0x4283fa5f78bcefb8ull, 0x5578872478481bacull, 0x3fdccdcbbc8b7c8cull},
    {"levels_3_3", 0xb31dcbccc7652fd5ull, 0x3ac0f4efcb396b97ull, 0xc24760cc453ea158ull},
    {"whole_level_search", 0xcec5473a46d7ec4aull, 0x3be235fb8e1eabdeull, 0x2ccf6cc8ad0e59f5ull},
    {"one_row_bands", 0x27befda19bf1dc52ull, 0x20b3d6d65ac5d22full, 0x73985ae1019bffddull},
    {"no_check", 0x8df0565d5db68c6bull, 0x8f0ff78efe27aab9ull, 0x0109e5e237625f27ull},
    {"no_propagation_no_mean", 0xa5a61aceab062dceull, 0x8e59748e5b978cf1ull, 0x8d2effa90088c1caull},
    {"half_pixel_window", 0x9f2def6a190e0ea8ull, 0x5c4260eaa9f9d589ull, 0xc5eb8f1a95d417a7ull},
    {"patch_4", 0xa10ab01a6d465c62ull, 0x9a8fc665646542cfull, 0xa10ab01a6d465c62ull},
    {"patch_12", 0x32a4d31eb4a1cc63ull, 0xf36a1ff4aefda609ull, 0x32a4d31eb4a1cc63ull},
    {"patch_7_variance", 0x47ef3bf0b7bc76dfull, 0x47ef3bf0b7bc76dfull, 0x47ef3bf0b7bc76dfull},
    {"paper_posterior", 0x6a05d87a1d5d5663ull, 0x7352a22c5636928dull, 0x544c3cb812fe5a6cull},
    {"twelve_iterations_variance", 0x7810a261d735893aull, 0x0ee92d7585d645c3ull, 0x4ee800174de56765ull},
    {"strict_validity", 0x4c15fc34c5e8ec86ull, 0x9ef219bb63029763ull, 0xe77b6723fbad2a85ull},
    {"tiny_sigma_s_variance", 0x0323bc675e7dbc88ull, 0x1954ea6d484afca0ull, 0xf749d0e0bf986588ull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0xb8bd165751921f0cull, 0x7f946e9b9bcdaf30ull, 0xcceb7bcd15847f68ull},
    {"fast", 0x50e883411ff45bb1ull, 0xb5ced5b087afa630ull, 0xafa71356cbabb93dull},
    {"accurate", 0xfd8de92317108b51ull, 0xa117e586335e8a43ull, 0x6fdf8f605c89b618ull},
    {"balanced_variance", 0xb6ee4b9c9fa88455ull, 0xc141d3ef0fe6bb77ull, 0xadab8e65dfc1100aull},
    {"accurate_variance", 0x086fad721f1d58e7ull, 0x951170721280da85ull, 0x4d4453f874ce6286ull},
    {"finest_0", 0x56f54fa58307af8cull, 0xaa67511b4753a06cull, 0xb0461b2815bcceeeull},
    {"finest_2", 0x135133cf4e7d670cull, 0x5343ab64dacf6dddull, 0x4e9d40af5234bf5aull},
    {"levels_3_3", 0xe65c96ed554aba6full, 0xdb6379becf77d9eeull, 0xb7627982527cb146ull},
    {"whole_level_search", 0x13948cde9b089d50ull, 0x9515f1a9602f06f8ull, 0x95186b942ba282d3ull},
    {"one_row_bands", 0x382cce88aaba9615ull, 0xff7e46c9708f152cull, 0x379ff370dbef1ebcull},
    {"no_check", 0x269031b1c7f8ca93ull, 0x6b341ceb403ead87ull, 0xdb5476f3bb34c8b2ull},
    {"no_propagation_no_mean", 0x30232ebdc39a1e42ull, 0x90bbb96260c11bfaull, 0xc250bc0eda3097dfull},
    {"half_pixel_window", 0x75f13932b02e8fa0ull, 0x2dc592042bb08fe3ull, 0x081375ca651db6f1ull},
    {"patch_4", 0xa1b2a2f0b08b9081ull, 0x8ab498c1283899f5ull, 0xa1b2a2f0b08b9081ull},
    {"patch_12", 0x0a72613d63c20e23ull, 0x541b74b8c1cbe28dull, 0x0a72613d63c20e23ull},
    {"patch_7_variance", 0xef31011c2a21d77aull, 0xef31011c2a21d77aull, 0xef31011c2a21d77aull},
    {"paper_posterior", 0xb3d80561f8a99d11ull, 0xf9905a2168db6966ull, 0x46e68158891d07b1ull},
    {"twelve_iterations_variance", 0x885c287df085a804ull, 0xa26ccb63e27517b9ull, 0x1bf71ed9e6ad5923ull},
    {"strict_validity", 0x3a4c4be8721f8b68ull, 0xa91ed95b8a5a966dull, 0x7d9dd482a70915bcull},
    {"tiny_sigma_s_variance", 0x6e7fe4ca23c21699ull, 0x9310e830eebef747ull, 0x75bd7c9b6dbefc9bull},
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
