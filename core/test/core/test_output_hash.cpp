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
    {"balanced", 0x7d2cb90d1dd7e8bbull, 0x3f8d03b882e8610cull, 0x5db6827832024b4full},
    {"fast", 0x42ffebbc9f1c4a6full, 0x28052b157ab1e5a3ull, 0xf3d21dabf8db57b9ull},
    {"accurate", 0x3bfe348aee505542ull, 0xa9c37bb143b84cbcull, 0xe3a923b4e5718987ull},
    {"balanced_variance", 0xd135d693a1d8214eull, 0x510a0ae34a7abc75ull, 0xa8506fa5e529482eull},
    {"accurate_variance", 0xd77c4cf19293c6f7ull, 0xedcbc19e6c306734ull, 0x0cf4246291f09b1full},
    {"finest_0", 0x3dc7126e5b15eacaull, 0x25b81ea02607f7f2ull, 0xbc16032fcf31fe1full},
    {"finest_2", 0x80a5d1f45134440eull, 0x564df6ab36933808ull, 0x56e4817424466c2dull},
    {"levels_3_3", 0x16f005f1f626e75full, 0xecffcd32ef848ba8ull, 0x527b53fecee8557cull},
    {"whole_level_search", 0x7da158bdc42ccca7ull, 0x2b83012389a5d7beull, 0xec17f4d1f44156b1ull},
    {"one_row_bands", 0x8cf3dfbcb54a84bfull, 0xbc5a391572021ccfull, 0xab30f4f4bb3b54afull},
    {"no_check", 0x308870a5a15c7bc4ull, 0x6d949c71970f4c5aull, 0x34ca92b7f8f2fe50ull},
    {"no_propagation_no_mean", 0x1b2cfb22c5b50edcull, 0x9189958cf6d3950cull, 0xff5659779f563aa1ull},
    {"half_pixel_window", 0xc1c877b022079d27ull, 0x340f4bfba4dab662ull, 0x2b23747ee82b9201ull},
    {"patch_4", 0x029121f2cca5cdc1ull, 0x71f1b940e019eb1cull, 0x029121f2cca5cdc1ull},
    {"patch_12", 0x019fc3d2013215acull, 0x063a6d8822717a6aull, 0x019fc3d2013215acull},
    {"patch_7_variance", 0xe3208f8ea4d0080bull, 0xe3208f8ea4d0080bull, 0xe3208f8ea4d0080bull},
    {"paper_posterior", 0x583c36429e444d07ull, 0x8ae0b2b275002d26ull, 0x3385808ea0ae7da3ull},
    {"twelve_iterations_variance", 0xca6de37c310fd57aull, 0xbaa4d22f099656c4ull, 0x998497d986f5b81full},
    {"strict_validity", 0x3c282b7f155b6906ull, 0x581b10160edda192ull, 0x1edf0ff03c1adbf4ull},
    {"tiny_sigma_s_variance", 0x72b822a136b2e0e8ull, 0x6eb7a2f5821dc3ecull, 0xe0a86391aac60517ull},
    {"coarser_look_variance", 0x73a137d9ac6cbe95ull, 0xb539f8bc54d95935ull, 0x258c38324d88ccadull},
    {"gain_compensation", 0x84252c3d0870d027ull, 0x84551509e56b57a2ull, 0xa2b7003f4e9e8602ull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0x13494e39adde2eecull, 0x5f5e48d684999097ull, 0x36c2e724c75fa689ull},
    {"fast", 0x90faa946b7051271ull, 0x9b7799b94ece0e9full, 0x8c4a3d9b95153d7dull},
    {"accurate", 0x2e2a0b27c2503b84ull, 0x173c093368afe0e6ull, 0x5ffda2cbf5eaabc8ull},
    {"balanced_variance", 0x9ab35a4ad121276eull, 0xbd077a83bc3bc949ull, 0x7a3a5973328e3aebull},
    {"accurate_variance", 0xeb63ba5ce517b012ull, 0xf25406a609cfc5eaull, 0x7ab1bb8059152796ull},
    {"finest_0", 0x11699d83df175bf5ull, 0xbbafbedaa57939cdull, 0xe1ac1f570153dbc9ull},
    {"finest_2", 0x1ed6eaf0447f7d6dull, 0xabe3399f1e5f2591ull, 0x590f028f662673c0ull},
    {"levels_3_3", 0xcd248e5e8276d3e2ull, 0xcfa1044d606c0deaull, 0xc2fcb8a1dc3a54deull},
    {"whole_level_search", 0xde03bae0f38500f4ull, 0x0b47e5442d568379ull, 0x141b51ffd4a023e3ull},
    {"one_row_bands", 0x6388ec0ec5aa91d0ull, 0xfe97a1904525dc3full, 0xb250ebb12c74c923ull},
    {"no_check", 0x90ffabef457fcfe1ull, 0x83fc02da1de31c17ull, 0x2d27ce90a6696c8aull},
    {"no_propagation_no_mean", 0x7c06182db7dea4a2ull, 0x35a99b426c245ae9ull, 0x579c4ff175afbe5cull},
    {"half_pixel_window", 0x1ef45377f5268d99ull, 0xc3e481bdc80bb915ull, 0x2cf4f22a3373b10bull},
    {"patch_4", 0xb5e2942bbc3edf6full, 0x8a29101fecc190a7ull, 0xb5e2942bbc3edf6full},
    {"patch_12", 0x9046e2a1bacfe484ull, 0x83ef016c177f989bull, 0x9046e2a1bacfe484ull},
    {"patch_7_variance", 0x218653b9622b0c74ull, 0x218653b9622b0c74ull, 0x218653b9622b0c74ull},
    {"paper_posterior", 0x7e2218c4ee31366eull, 0xb4b1d37c954cacdaull, 0xeb4e7d228f9ecc7bull},
    {"twelve_iterations_variance", 0x1af09ebc58b0526dull, 0xdccac827466ad4c1ull, 0xe7fdfd1a3551973dull},
    {"strict_validity", 0x44138867f6eeeaa9ull, 0xa4a1684c9f89c492ull, 0x925533744f64c338ull},
    {"tiny_sigma_s_variance", 0x4e81031440639f72ull, 0x6162c0efcab0cc37ull, 0xd2e12681ffbde60eull},
    {"coarser_look_variance", 0x314567fe69ce5d2dull, 0x5f8e9e0d3fa1d06cull, 0x8e6acdb8f7f106d0ull},
    {"gain_compensation", 0xbd877e00d2bf5ddeull, 0x541e5180152c6719ull, 0x888cd2568a803228ull},
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
