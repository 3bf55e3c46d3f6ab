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
    {"balanced", 0xba5cb6419a939ca9ull, 0x38176fe1365703f5ull, 0x3fc9e64a418eeb48ull},
    {"fast", 0xf1d80caecac8108cull, 0xadf2e812a5ac5898ull, 0x182afbe3faa1b828ull},
    {"accurate", 0x7666bc0ab604ea4dull, 0xd86ddca25937b82eull, 0x80ca082df95faf9dull},
    {"balanced_variance", 0x269c44801359013full, 0x4a3a2b062d13f589ull, 0xaa5975e598237d6aull},
    {"accurate_variance", 0x73859b51a5483087ull, 0xdf3968db04735186ull, 0xb259ee67eb7c18fcull},
    {"finest_0", 0xa8a7fbc64b5059a4ull, 0xcd07d9fbb04c0565ull, 0x7980315fb1ec9ca8ull},
    {"finest_2", 0x14d780ddc3dbd28full, 0x7a3823a2c0bbee6bull, 0x2264e2ba0dd342baull},
    {"levels_3_3", 0x1e25687f592d23adull, 0xcf83d6428a48863full, 0xd9b0b1701fb10cd4ull},
    {"whole_level_search", 0x186c8a075c5c733aull, 0xe45e5dd54bed6d97ull, 0x27d780707a674bbeull},
    {"one_row_bands", 0x17d0a5006cd6fa4aull, 0x21ef383607d5b0a1ull, 0x14b7318922cdce8eull},
    {"no_check", 0x792d7590beb61305ull, 0x73f82b2015a61458ull, 0x19c679662a9d20d4ull},
    {"no_propagation_no_mean", 0x7236b3c177a5477aull, 0x4ac027d59938a540ull, 0xa485c2ab2b06a4b5ull},
    {"half_pixel_window", 0xbec4ff5ae84cf996ull, 0x362fe15d6a80b74bull, 0x5949c36cf599d7f9ull},
    {"patch_4", 0xc6766a30d5da45a0ull, 0x395dc3103409cf35ull, 0xc6766a30d5da45a0ull},
    {"patch_12", 0x50cc86904759afbdull, 0x449fdc7ea46f7805ull, 0x50cc86904759afbdull},
    {"patch_7_variance", 0x3809753742362fd6ull, 0x3809753742362fd6ull, 0x3809753742362fd6ull},
    {"paper_posterior", 0xd31c06c53983fe87ull, 0x19b0eb644e568b69ull, 0xb3e383c9e7cc799aull},
    {"twelve_iterations_variance", 0x35c471dae9ff0534ull, 0x5577f10e31f9e2bbull, 0x481844df512f249bull},
    {"strict_validity", 0x290329ff368dfec6ull, 0x2bae329996f60092ull, 0x89cb24ea9cc2c8b8ull},
    {"tiny_sigma_s_variance", 0x7bae6843df297b78ull, 0xf080ef5e6e9edad1ull, 0x5e255ea9cc2c472cull},
    {"coarser_look_variance", 0xfcc31c81921e54e3ull, 0xa4d6f7052f863587ull, 0x47e3a03fae61e5a5ull},
    {"gain_compensation", 0x066c04598885e8a5ull, 0x569d0c36aa1c0f02ull, 0x8dcc2218532abd0dull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0x00d00b32229dd5feull, 0x5f7e3027ce32af98ull, 0xbf8a0bd54f4683d9ull},
    {"fast", 0x6ba9e11dc121527dull, 0x2da6be9a6f9d1bacull, 0x05d966f048be54a5ull},
    {"accurate", 0x02726d644ec5df23ull, 0x4294e3e03734436eull, 0x36069259959c1235ull},
    {"balanced_variance", 0x5401b2ee6c8b14a8ull, 0xe6c0639e74d4e9bfull, 0x64751fd09e8c5bd6ull},
    {"accurate_variance", 0x7800d99305c0b910ull, 0xa4919d38739c1db4ull, 0xa1372983691a81c7ull},
    {"finest_0", 0x165ce482f18761d3ull, 0xf6fbe0ba10b7f19aull, 0xe97eb90247fef40aull},
    {"finest_2", 0x6c000ff06495cc59ull, 0xe9e28ea58d5c14c8ull, 0x7e2e270e5e07aa8aull},
    {"levels_3_3", 0x0397de96538f2af9ull, 0xe0b66bcaa4c015beull, 0x7fdd0653884ac6c0ull},
    {"whole_level_search", 0x7352c21e74823819ull, 0x7520b537318b08b6ull, 0x45234533eba1fc05ull},
    {"one_row_bands", 0xabb556da89d514a1ull, 0xd4918ee9c0ab0687ull, 0x922dd219bfafcc22ull},
    {"no_check", 0xe0ab449189b6fdeeull, 0x87bc7e2756d21b19ull, 0x3dbfc34e3df2d2cbull},
    {"no_propagation_no_mean", 0xd59395f143ecbfa5ull, 0x4c3c66d5f2d5cb5aull, 0x679d49a2c3fdf052ull},
    {"half_pixel_window", 0x58f0b3a3a091d52aull, 0xd0b01a8337217d6full, 0xb0205c74e266cdd7ull},
    {"patch_4", 0xcd64eadd49cb7a36ull, 0x1f7402154821b45eull, 0xcd64eadd49cb7a36ull},
    {"patch_12", 0x5d5069f0da0d38c6ull, 0xbb59c11b546ecd7eull, 0x5d5069f0da0d38c6ull},
    {"patch_7_variance", 0x2fcc76ef6fa224a9ull, 0x2fcc76ef6fa224a9ull, 0x2fcc76ef6fa224a9ull},
    {"paper_posterior", 0xe54c03c9159e7d4full, 0x5542b96aa1d76ffbull, 0x986390ecc3c70444ull},
    {"twelve_iterations_variance", 0x9cf3696fc3e04d0full, 0xe2d452fdf9f8219cull, 0x099ef86922f4e1bcull},
    {"strict_validity", 0xa9c5c89aa92f35e6ull, 0x36e70ef7b441d2d6ull, 0x8d9e642f85ee4be1ull},
    {"tiny_sigma_s_variance", 0xb4963d4cdc5f244eull, 0x59c68f51ee404810ull, 0x000701c3441a5fb8ull},
    {"coarser_look_variance", 0x2cd0b2e26275864bull, 0x5355f10df378808eull, 0x8bfed899da6494e6ull},
    {"gain_compensation", 0x9be2cbda4dac69cdull, 0x7061c14882daf87cull, 0xee574e23aad9174full},
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
