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
    {"balanced", 0xb5cd24070678da6dull, 0x25fe8cd094e4a2feull, 0x84fe9214e9a34c79ull},
    {"fast", 0x398e59cc7ad34201ull, 0xd2366aa58f634618ull, 0x39e4d0263bca0497ull},
    {"accurate", 0xe2325c92b4bb3ddaull, 0x977244e4322a6b98ull, 0xc58d9e076a691321ull},
    {"balanced_variance", 0x4b3c04968abe9843ull, 0x7918755a3210779full, 0x761d77b795989314ull},
    {"accurate_variance", 0x528fa705326f901cull, 0xa82cbef00fab375dull, 0xf1b0ddec9f111f36ull},
    {"finest_0", 0xf2105b63a277b3c3ull, 0x34c2e7f8f266d75eull, 0xf3e3de56ee7191b6ull},
    {"finest_2", 0x13395c94ff37cfaaull, 0x6c465f1fa1de4f69ull, 0x1e7315d0206e3b09ull},
    {"levels_3_3", 0xd3afc3e158a74943ull, 0x16814b0bf45ad739ull, 0xd233ee12caae9f1full},
    {"whole_level_search", 0xe9b586f3ffb0d85bull, 0x10e0bfeb838d3004ull, 0x4291ce499d0520c7ull},
    {"one_row_bands", 0xad54d75a10fbed1dull, 0x82267a90e17f0e98ull, 0x87d36459a526ef94ull},
    {"no_check", 0xe6fbebc553b948bdull, 0x9527b4dc9853988dull, 0x360f814ccdfbb202ull},
    {"no_propagation_no_mean", 0x69396f45db425f31ull, 0x24a197b39b2d5903ull, 0x40690bf9a5221b46ull},
    {"half_pixel_window", 0x84c8a6f34a465125ull, 0x3697148e2ecb939dull, 0xed5062d2d6f00a22ull},
    {"patch_4", 0x0d2caa81be4c80eeull, 0x7818fa1a6819486full, 0x0d2caa81be4c80eeull},
    {"patch_12", 0x458c1c73b36e62b3ull, 0x550b9fc5ddfa7a0aull, 0x458c1c73b36e62b3ull},
    {"patch_7_variance", 0xa6c26365841ab577ull, 0xa6c26365841ab577ull, 0xa6c26365841ab577ull},
    {"paper_posterior", 0x043bcc86007f9908ull, 0xbbde847815ac293dull, 0xe5aa3aa04a55281full},
    {"twelve_iterations_variance", 0xd7d052497b6d0ad6ull, 0x49fbcc18bb0c6b13ull, 0x421968114c14cac8ull},
    {"strict_validity", 0x01ad78f875aab4ddull, 0x0f617a90301fd897ull, 0xd596a70f3361d581ull},
    {"tiny_sigma_s_variance", 0xe3b4d95d0136a74bull, 0x2d41135d2372862dull, 0xc8b194ccc1512d0dull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0x3cf69570ea7a08f8ull, 0x48d4958dfa1b5d03ull, 0x790b56baf79755c9ull},
    {"fast", 0xee317470b5270bafull, 0x7ef1f372920b375cull, 0x153b48c2b06a5dedull},
    {"accurate", 0xa51125a98730e20aull, 0x01101ace92be83cdull, 0xb76b71ff8c7fc595ull},
    {"balanced_variance", 0x5e248ba3f38c47eeull, 0x115d41b2a7257210ull, 0x938c6a0011dcf9edull},
    {"accurate_variance", 0x2bafeea6d1ad6be9ull, 0x8d44bd9721b5a034ull, 0x9f2e247e114b263full},
    {"finest_0", 0xd84f2371877a47bbull, 0xbc1d89aa4ca634c3ull, 0xef857ae7d55c9726ull},
    {"finest_2", 0x3cc34ca488aa8982ull, 0x81bb4779204b674full, 0x705d5419a34ae1e6ull},
    {"levels_3_3", 0xe965ea321b6e894dull, 0x15caf0523ee40084ull, 0xe71f4d1eacfa5b7aull},
    {"whole_level_search", 0xda49b648a31502bbull, 0xe64810b5312e5fa3ull, 0x45a680e0049a4072ull},
    {"one_row_bands", 0x0b57c5192f7bd41aull, 0xa562bd4909fe609bull, 0xbddca99d132633a8ull},
    {"no_check", 0x2b0beaf3a47f8047ull, 0xd31e1f540afbde4dull, 0xd355e7f0230e9f43ull},
    {"no_propagation_no_mean", 0xabd44abf92769cf9ull, 0xfca9968acab4a986ull, 0xa31ab8cc11115765ull},
    {"half_pixel_window", 0xdd3caaa7a0f7ed59ull, 0x50e47e6f2e4a7058ull, 0xabbdafd8613a98d7ull},
    {"patch_4", 0x932b95450bd97199ull, 0x2d502782222d5938ull, 0x932b95450bd97199ull},
    {"patch_12", 0xc5ad6ebb4f31c5e6ull, 0x6035f47c27c6abbbull, 0xc5ad6ebb4f31c5e6ull},
    {"patch_7_variance", 0x02f5d3d9af8cfbb4ull, 0x02f5d3d9af8cfbb4ull, 0x02f5d3d9af8cfbb4ull},
    {"paper_posterior", 0x9d9e31eb2f3f2493ull, 0x7223091e049e3c48ull, 0x3b8ec11cefcd523bull},
    {"twelve_iterations_variance", 0x1f529727b72724f6ull, 0x842f40874dc7fc7dull, 0xeaf5866bb52e5948ull},
    {"strict_validity", 0x79a4bbb68fbbbdd8ull, 0x26ded49771b8b612ull, 0x32d0aca511521598ull},
    {"tiny_sigma_s_variance", 0x8a81a05d6132abc6ull, 0xa8dff57aac78e35eull, 0x5595439587d0edb2ull},
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
