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
    {"balanced", 0x153b25c19773ca77ull, 0xedb2f418e0ca535dull, 0x896b7364fb539449ull},
    {"fast", 0xaa36a9961b3ffc4dull, 0xd171f8df43bcaae2ull, 0xad88a543d35a3338ull},
    {"accurate", 0x723c80639036c5f7ull, 0x37f745bcb0d8dd39ull, 0x3dba5dd59d578ad6ull},
    {"balanced_variance", 0x235ddaa9e9020ef4ull, 0x4068d2d9d2ea7dd5ull, 0x15c38825aa40df94ull},
    {"accurate_variance", 0x8aa2a7016886dc97ull, 0x78f4a6a9f1bbb1f2ull, 0x4e353ddcf37e8e1aull},
    {"finest_0", 0xbb4c08db0b74dcf5ull, 0xbad647ae8a84cc02ull, 0xb2068727cd9fe055ull},
    {"finest_2", 0x2e4bfd7e4be99804ull, 0xced6f61d7645fcacull, 0x58c57a1066ed43ccull},
    {"levels_3_3", 0x34cea107d8e5efffull, 0x8a4e5e3dc9eb9e81ull, 0xb3ee42e017229f0full},
    {"whole_level_search", 0x785d61f9f02f5656ull, 0x63c50b141362b0c8ull, 0x06a7d038822ad6a8ull},
    {"one_row_bands", 0xe77be496048ae960ull, 0x8761320c73a696feull, 0xc25e7f8c4aa7b84eull},
    {"no_check", 0xd069029afe699440ull, 0x78e5574bd3fd9618ull, 0x39da6a531469952cull},
    {"no_propagation_no_mean", 0x1c3714ac90a6c7b0ull, 0xc78aa6e09f6b2562ull, 0xa7566da1907c85dfull},
    {"half_pixel_window", 0xd1e86783ab4081bdull, 0x73dcf2ad0238156bull, 0xe6bd41ed8039932eull},
    {"patch_4", 0x4574a33d5f9713d7ull, 0xf3326cef27889685ull, 0x4574a33d5f9713d7ull},
    {"patch_12", 0x8de723efd15b82cfull, 0xbe5fc3096862dfb9ull, 0x8de723efd15b82cfull},
    {"patch_7_variance", 0x68d8c02df8827fefull, 0x68d8c02df8827fefull, 0x68d8c02df8827fefull},
    {"paper_posterior", 0xf06a638f84e2db80ull, 0xbebd8f3b1f87fa2aull, 0xb7946acafdb65ffeull},
    {"twelve_iterations_variance", 0x41398116f6f300d7ull, 0x2acc86ccb67b6108ull, 0x8b46aca0f9abdfb3ull},
    {"strict_validity", 0xed65c8baf7bd21adull, 0x973da8788171896eull, 0x3135ee8404ad96a4ull},
    {"tiny_sigma_s_variance", 0xffae73a34d1e2a63ull, 0xf9887898ec8fa466ull, 0xbc2c3298ba057f6eull},
    {"coarser_look_variance", 0x798f5e8269497dd9ull, 0x40611d550365c506ull, 0xb31188b9dba9675aull},
    {"gain_compensation", 0xc68b78c585181674ull, 0x6387ac32815eb7aaull, 0xa6d47782e31bdc18ull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0xa15eb81004ada430ull, 0xe9ef515f922125adull, 0xc94f0f5f05a5ded3ull},
    {"fast", 0x2a3aafba43e605d4ull, 0xe3f1d59cff20e825ull, 0xe48a3bb8fe00c849ull},
    {"accurate", 0xbdaf0790f39cb1f0ull, 0x55004d7e56a3efc0ull, 0xd58f072e6e4ad3b0ull},
    {"balanced_variance", 0xd58acd4505839830ull, 0xdf9e35b0a1af36a0ull, 0x4c64e4bf7c136402ull},
    {"accurate_variance", 0x4a1bda618a036622ull, 0xc4f0e6c564d5fa21ull, 0x1b3cb8d8a1de3ddcull},
    {"finest_0", 0xf5859240044e6639ull, 0x24bd977c343fee19ull, 0x7c7e6411f5077aebull},
    {"finest_2", 0x6d8a88a5688455a3ull, 0xb97dda55f8fe361eull, 0xc24502ca96891d9full},
    {"levels_3_3", 0xdeaa7efef93364aaull, 0xc872aba20fe311d5ull, 0x325811213cbe2c57ull},
    {"whole_level_search", 0xf83c76ed9d81db8cull, 0xa2b6c26b12fb1c7eull, 0x213e6bed0b53b995ull},
    {"one_row_bands", 0x95c2ea037585edccull, 0x320ed83283208e60ull, 0xcc45591859eb2d61ull},
    {"no_check", 0xe4377f9980024a43ull, 0x4c1e547ec8ca3891ull, 0xb1a78fca64f78f1bull},
    {"no_propagation_no_mean", 0x8e9d8a937d9c5d30ull, 0xe8bb8fba9f69eb5aull, 0x984bb412515b17f5ull},
    {"half_pixel_window", 0x4c398a510b75ec83ull, 0xd4884517e9c3083eull, 0x820d67d9af5a6656ull},
    {"patch_4", 0x38180f0c0aef2882ull, 0xae070d3fdd8a7e33ull, 0x38180f0c0aef2882ull},
    {"patch_12", 0xb5d6d4850da426ccull, 0xfbffcbca6e34d20eull, 0xb5d6d4850da426ccull},
    {"patch_7_variance", 0x6d4e78abee37dbecull, 0x6d4e78abee37dbecull, 0x6d4e78abee37dbecull},
    {"paper_posterior", 0x585c2b035eb1487cull, 0x290a108c1b060d10ull, 0x6f962ae355143f30ull},
    {"twelve_iterations_variance", 0xc4e0d6ee6e987d3bull, 0xc5e22f9b877f04eeull, 0x8fbf3df3be1845d5ull},
    {"strict_validity", 0xf77b5ed801a97b3dull, 0x3e835a70649c2ee2ull, 0x0bb0f3e4a3e3d32aull},
    {"tiny_sigma_s_variance", 0x8db4000962d895c5ull, 0x2cf49f1de35245d6ull, 0x825583aa026d7fddull},
    {"coarser_look_variance", 0xfe87725a925f5580ull, 0x51b020ddcbf5399full, 0xd1f560ba73c16e33ull},
    {"gain_compensation", 0x6e42fabb214dca15ull, 0xaab4abde8ccf6abfull, 0x87a9662e7931c688ull},
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
