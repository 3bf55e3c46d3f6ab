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
    {"balanced", 0x9e9be48566233a4cull, 0xce77f5c3c1774c9dull, 0xef8d7f9ea741ccb5ull},
    {"fast", 0xc02350b383ffedafull, 0xe32a1e6fb739cb26ull, 0xd111b740f153d5d7ull},
    {"accurate", 0x5b4819cf3783d8b7ull, 0x04b5f6c3919ab545ull, 0xa8f54be061f7d660ull},
    {"balanced_variance", 0x3ccc5e2df0196f43ull, 0x78616c0e65679bddull, 0xa86a37a0d141b734ull},
    {"accurate_variance", 0x2618094b3be78f03ull, 0x92d3bb16369253c6ull, 0xa259025ac6ac749cull},
    {"finest_0", 0xa9e482dc849a1628ull, 0x047b8ed3f67fb340ull, 0x2e29eba2963d258cull},
    {"finest_2", 0x75ab565e9b0dd72bull, 0x3054ec0154302850ull, 0x46e4557aeae6c3dbull},
    {"levels_3_3", 0x53b8931de1b116c9ull, 0xffecb972b2e43971ull, 0xdd200b1702805670ull},
    {"whole_level_search", 0xeb0a718adc01f6a7ull, 0x5307e20e88dcadc4ull, 0x09bff9c009386094ull},
    {"one_row_bands", 0xb46282e546b90f12ull, 0x27fd0fe084707401ull, 0x7e6f6c09c1792b4aull},
    {"no_check", 0x8c4251e4cef9f6d8ull, 0x2f17d6841e284bd3ull, 0xdc657881f85ae98aull},
    {"no_propagation_no_mean", 0x2a262b1d3f94462dull, 0x26ed2cff3909bad3ull, 0x1774afc3c5f9e634ull},
    {"half_pixel_window", 0x9c68e026d8798cdfull, 0x67bb4c4f9b01f086ull, 0x92733daba4204e0bull},
    {"patch_4", 0x6105af894ffc82e9ull, 0x8998511db6bd6ceeull, 0x6105af894ffc82e9ull},
    {"patch_12", 0xbc212904f35820f5ull, 0x073d347ce328cb88ull, 0xbc212904f35820f5ull},
    {"patch_7_variance", 0xc7eaee5ad7c3344aull, 0xc7eaee5ad7c3344aull, 0xc7eaee5ad7c3344aull},
    {"paper_posterior", 0x944422c48d1399afull, 0x6a519b0681f7d04full, 0x33d0fed2a2a6f80cull},
    {"twelve_iterations_variance", 0x47cc7b751e89e806ull, 0xbaa04af7e9cf16abull, 0xf23dff453a188d7aull},
    {"strict_validity", 0x348694d69dad9084ull, 0x240906296e35608aull, 0x4b8cf9716642d003ull},
    {"tiny_sigma_s_variance", 0xcf23a74eada264ddull, 0xba300cf72d5b88c6ull, 0xe33ee4215dcdd636ull},
    {"coarser_look_variance", 0x190d78f4f4844006ull, 0x1d4fd628307574a9ull, 0xfd6903430797b0b6ull},
    {"gain_compensation", 0x60a5a1a7ae1be7a8ull, 0xad6d6fa4d5db77bcull, 0x5a10b2c7e5eadf0eull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0xa67280c3b498c098ull, 0xf034ba5f861d0608ull, 0x46bfeacc4fe13ca9ull},
    {"fast", 0xee64813e9ecfcd57ull, 0x42f96954794b3b18ull, 0x2094c8b94fbe50c1ull},
    {"accurate", 0xf913ea3943244c74ull, 0xdd9fa83e2ca964cfull, 0xceb4b0192bbe4041ull},
    {"balanced_variance", 0x9dcac41181829d6cull, 0xa15be2fbd30d5d39ull, 0xac7b8aedc3f8f574ull},
    {"accurate_variance", 0x024fcd73ac52c61eull, 0xd096d33a9a93b0c2ull, 0x852d913ce0b4fd3dull},
    {"finest_0", 0x0420f42f618ee49bull, 0x2216d9af87d58756ull, 0x8da150dfd26bceb0ull},
    {"finest_2", 0xff94fbea4224e447ull, 0xe0ce1dcad53cc969ull, 0x6e69c9aab9797597ull},
    {"levels_3_3", 0xcce926697e034e74ull, 0x1dda53ddfc4cc3d0ull, 0x0854c7526eee9766ull},
    {"whole_level_search", 0x9e61e0e458aadf47ull, 0x0be78528de223810ull, 0xfb52945836cfc245ull},
    {"one_row_bands", 0x177409918a6e6889ull, 0xba41d21058e3ebf9ull, 0xc9e36f93a402f8afull},
    {"no_check", 0xc36be06c15a81965ull, 0x6d19da84970ef35cull, 0x84329edbea17e31cull},
    {"no_propagation_no_mean", 0xda1c7044ceed822bull, 0x9790b6c03e01949aull, 0x5a86581c75112b6aull},
    {"half_pixel_window", 0x4463af68a577f86aull, 0xbe1735048f2a9eaaull, 0xe3cdcd822defe4e5ull},
    {"patch_4", 0xd9b93c93fa10748bull, 0x05138c226306fd8eull, 0xd9b93c93fa10748bull},
    {"patch_12", 0xc3e3dad800ad20e8ull, 0xd24e18eaa1f8cbd5ull, 0xc3e3dad800ad20e8ull},
    {"patch_7_variance", 0xcf476b0e8ee39accull, 0xcf476b0e8ee39accull, 0xcf476b0e8ee39accull},
    {"paper_posterior", 0x89be9871946949a5ull, 0x110fe3645e9ddbc1ull, 0x6955deea81979399ull},
    {"twelve_iterations_variance", 0xfd546e108320da1eull, 0x5cb0938250c8cf40ull, 0x8178bd5bd3f2c3e2ull},
    {"strict_validity", 0x05c57171538317acull, 0x19e4d3824143d190ull, 0x66e12f74c19e003eull},
    {"tiny_sigma_s_variance", 0xeed0b9c65688c95cull, 0xf35270808d3a7884ull, 0x10a81f89022b6132ull},
    {"coarser_look_variance", 0x5a65caea6f6f22bcull, 0x8a9a589d392a3c0dull, 0x5ef2d4ed4de060e1ull},
    {"gain_compensation", 0x7b9f8509cb616be4ull, 0x5b8b3b329e9d707dull, 0x26277c841d8cd78aull},
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
