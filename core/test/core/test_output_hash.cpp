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
      {"no_support_weights", [](MatcherParams& p) { p.support_grey = 0.f; }},
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
    {"balanced", 0x8fd065875ffe8087ull, 0x710d7c8b5070aeabull, 0x516d3ab89f5fe5ccull},
    {"fast", 0x1779ef0d3b15b1f7ull, 0x46efdbfabc575f6dull, 0xc052df676d64588full},
    {"accurate", 0x6803a4aa0b49bb8dull, 0x655a59047d92e97bull, 0x84b4c5e972ba0f51ull},
    {"balanced_variance", 0x6004c53ec663200full, 0xfa7095b1b3e25a66ull, 0x67438f8e173f8f38ull},
    {"accurate_variance", 0x8161792ab1b731bbull, 0x63cbf12f5828810full, 0x0a9af261f42e3d27ull},
    {"finest_0", 0x4b3ee925e740464dull, 0xe0a5b010fda55c20ull, 0x564e8fbc9cfcc189ull},
    {"finest_2", 0x76f029a2aeea22a4ull, 0x8af0c818790d9efdull, 0x6afb701d0cb8eff1ull},
    {"levels_3_3", 0xa95c10149c8cd755ull, 0x4c08ca48b3c1b3c4ull, 0x3c27ca53ac1da27full},
    {"whole_level_search", 0x6a0e133e211f333aull, 0x0c57cc4e50bf5db7ull, 0x902948b69e162c41ull},
    {"one_row_bands", 0x47425227937e3ea2ull, 0x02b4371c1750fdb9ull, 0x72a1fa5c56d8070eull},
    {"no_check", 0xe2b9ffeac3cc29bcull, 0xe9f9c82f710e3f22ull, 0x23ab4892a587ea65ull},
    {"no_propagation_no_mean", 0xb3ea505e6619b00full, 0x70a3aa61ad4c9f75ull, 0x3796387d1bb3a712ull},
    {"half_pixel_window", 0x4df9318c277323bbull, 0xd8b7c18a9afc8d5eull, 0x3728289879feea3cull},
    {"patch_4", 0x960337a2822ba46cull, 0x11964d1240b1cd63ull, 0x960337a2822ba46cull},
    {"patch_12", 0x10a4ace06701d900ull, 0x5fa7ee39ecf135cfull, 0x10a4ace06701d900ull},
    {"patch_7_variance", 0xb13c679bf926ac74ull, 0xb13c679bf926ac74ull, 0xb13c679bf926ac74ull},
    {"paper_posterior", 0xa4a374485111d478ull, 0x507720ebe1feadb3ull, 0x41a32778d6c1e6d3ull},
    {"twelve_iterations_variance", 0x31dcf8584b2bf248ull, 0x075be7d25b479ecbull, 0xc3b11d87afa02b40ull},
    {"strict_validity", 0x486048277b2c20ffull, 0x708d53dc3cdec652ull, 0xa67b844804de9a49ull},
    {"tiny_sigma_s_variance", 0x92513b084347e51full, 0x6c47d0e3b9422d92ull, 0xa3a0a4a2b4b1a766ull},
    {"coarser_look_variance", 0x44116a81f1a497ddull, 0x9c501d5287afe087ull, 0xff90fbf436e4160dull},
    {"gain_compensation", 0xc4f63b84d072550bull, 0xe2af12034fa3a063ull, 0x99c6565fce9b9b78ull},
    {"no_support_weights", 0xeb27a4efeb2d913eull, 0xee7eb80740665cf8ull, 0xa3f00f949f138668ull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0x277ecf77856ba654ull, 0x675cd7011bcb9544ull, 0x8961fb3ce632e79eull},
    {"fast", 0xf4666ddb2d641744ull, 0xc5edf326ff310596ull, 0x66d3ffbaa5f54174ull},
    {"accurate", 0x45a3f9f22af2d160ull, 0x6beeb45890a21d53ull, 0x1acd2317d3ecc563ull},
    {"balanced_variance", 0xba9e933e3348ba3bull, 0x4186696716533960ull, 0x4c6f296e4213312full},
    {"accurate_variance", 0x993a7b1d68e02c29ull, 0x27729a99be14acc3ull, 0xa6396aa760e08182ull},
    {"finest_0", 0xc10e259884ad8be0ull, 0x98cc3423fa156939ull, 0x399b8b98dbf8f04full},
    {"finest_2", 0x28b0d6e255004909ull, 0x07094e6498dd733cull, 0xccac31b09abcd49eull},
    {"levels_3_3", 0x6048e749862e0f29ull, 0x96b25972d4291f13ull, 0x577340441285c038ull},
    {"whole_level_search", 0xb878d8e3aba64570ull, 0x925792e035541defull, 0x2787f1b80f162889ull},
    {"one_row_bands", 0x38ed892fb45bd891ull, 0xfbcdc2959d8a4ba1ull, 0x3258d82fa4fdb43full},
    {"no_check", 0x19b0c4e54eebce68ull, 0xfdeddf150a9dcc1aull, 0x44857754d582db7aull},
    {"no_propagation_no_mean", 0x33467a2217873fe9ull, 0xf134344a773685abull, 0x35c08622ec773d70ull},
    {"half_pixel_window", 0x2c16467101d479dfull, 0x0bb4f3055709e9e0ull, 0x1251dcf198acbc98ull},
    {"patch_4", 0x8fa0db9cebee68a7ull, 0x8a07d3fa587928e3ull, 0x8fa0db9cebee68a7ull},
    {"patch_12", 0xf6b24ef8baa1e268ull, 0x7b7ae0bf19319f5dull, 0xf6b24ef8baa1e268ull},
    {"patch_7_variance", 0x5da661d027a5b815ull, 0x5da661d027a5b815ull, 0x5da661d027a5b815ull},
    {"paper_posterior", 0x987a7567a76999c6ull, 0x7bf666d466166713ull, 0x29d02e601f1b4b11ull},
    {"twelve_iterations_variance", 0x45c4160b74596c91ull, 0x4346c97043007400ull, 0x18cb9745451c07e6ull},
    {"strict_validity", 0xf3a1a31328a189ccull, 0x07c96f7c3bf7f9cdull, 0xf4322ddd4894d85aull},
    {"tiny_sigma_s_variance", 0xbbbe4cc78a21e6dfull, 0xbd4f36ad54016f76ull, 0xad5cf8d911479cd8ull},
    {"coarser_look_variance", 0xfe6b27c4e11f39fbull, 0x6a8dcbe7b1762c14ull, 0xe5c62486a5ace1bcull},
    {"gain_compensation", 0xf11d7b96bde929b7ull, 0x50eca2ca1a446e02ull, 0xc7e58d9ef949dfabull},
    {"no_support_weights", 0x1960abe262b60b35ull, 0xdf0ae8adbf0d7569ull, 0xa2ff1104ce45fd64ull},
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
