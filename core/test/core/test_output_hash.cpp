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
    {"balanced", 0x76ae703c870311d0ull, 0x8706bbfd73fe6c2dull, 0xb9bb1bd088c77949ull},
    {"fast", 0x8ff657add6bac7b4ull, 0xe130c7e62e2a3118ull, 0x9a82fc999dc9835dull},
    {"accurate", 0x4c8e02a42d51254aull, 0xbe5e52da52a8761bull, 0xb723a706e47085e6ull},
    {"balanced_variance", 0x0df2d0e5d2ffce55ull, 0x2d55d8a3955ba20full, 0x4af484b9e9a7057full},
    {"accurate_variance", 0x4826ca65caeee4c6ull, 0x6c975cee74cc684bull, 0x90d0ec1e345d9549ull},
    {"finest_0", 0x95f53e3d2442ff1full, 0x655c145300fcba72ull, 0x214f1ea870537130ull},
    {"finest_2", 0x873f968795dc0bacull, 0x3988584118e6227bull, 0xfa4f3893664eed39ull},
    {"levels_3_3", 0x6ae7974f69538c5cull, 0xe80e87df3b415a28ull, 0x157ceaa206171a77ull},
    {"whole_level_search", 0x0d67116ea3634ee3ull, 0x0489e0b5516d32c0ull, 0x9aec0b2c3f04c9b0ull},
    {"one_row_bands", 0x9c3cc54d26f7d6f4ull, 0xe01fb0d687b1df2dull, 0x77d833269463434bull},
    {"no_check", 0x7f45bbc6d9cdb988ull, 0x1afa583cd5971a95ull, 0x0bf1e52a7356fa84ull},
    {"no_propagation_no_mean", 0x990215b5c9c20405ull, 0x16ccfec169801c04ull, 0x0addae769e7ba34bull},
    {"half_pixel_window", 0x0ded3f7ad852fea9ull, 0xde777af7863c5cefull, 0x48093c92f1cc7140ull},
    {"patch_4", 0x778114a5f6feb756ull, 0xc5ef84ef1ad9475dull, 0x778114a5f6feb756ull},
    {"patch_12", 0x10b4711a14a9302cull, 0xea804525a06da0c4ull, 0x10b4711a14a9302cull},
    {"patch_7_variance", 0x57b745e5be537a8dull, 0x57b745e5be537a8dull, 0x57b745e5be537a8dull},
    {"paper_posterior", 0x9f1d73deb72ba1f4ull, 0x9a2bdb6fb94f741cull, 0x9115df048d5d3a86ull},
    {"twelve_iterations_variance", 0x02483ad450319cc6ull, 0x1c50982d13be39b6ull, 0xc85659c69d48768aull},
    {"strict_validity", 0xd571bf299e6b370eull, 0x0d1e00a588fc56a4ull, 0x2f588c6a49872531ull},
    {"tiny_sigma_s_variance", 0xc2b263c32ffc5599ull, 0xaa1595111f5a17cfull, 0x0d565804f3187842ull},
    {"coarser_look_variance", 0xf09191c877927006ull, 0x5c9aef052c2addcbull, 0x2c179cc76ddda663ull},
    {"gain_compensation", 0x51d9f983207bfee3ull, 0x04daf4dedce474c4ull, 0xbdcf64f7f81105daull},
    {"no_support_weights", 0xbd21967b896b8928ull, 0xe527e7f6f3d8850aull, 0xffd313efb4660a7cull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0x74fdd0827a5182a9ull, 0x764d1a8d570e18f7ull, 0x61c3ef4fd29dd147ull},
    {"fast", 0x87dfeb6a646c7da6ull, 0x97fac59cef441ff9ull, 0x2cd45b54010f8ea1ull},
    {"accurate", 0x5509191ad6d911ecull, 0x6c4ec30c94bbb3c8ull, 0x9ac3e6018fcf3ad0ull},
    {"balanced_variance", 0xe0e422ef31d1f602ull, 0x6e2a94ec187b586full, 0xb108a86a432602e6ull},
    {"accurate_variance", 0xdde6dddf94e18020ull, 0x32b42c3cd35c2221ull, 0x8387489527ac2159ull},
    {"finest_0", 0x5d0adcf3168ec8bfull, 0xf749f242459f371eull, 0x4db01d860f0e3bedull},
    {"finest_2", 0x3e59ab8fe415e40dull, 0x637ddad09d016c4aull, 0x0374d3a0c32201dfull},
    {"levels_3_3", 0x24c481cc5741da6dull, 0x1fdf8854f53da025ull, 0x9d472cf6f5ee2ee0ull},
    {"whole_level_search", 0xaad0313c7c6e0102ull, 0xba08e9842a683674ull, 0x983b040600985ed2ull},
    {"one_row_bands", 0x040e9150e99d8cccull, 0x40f16daad93548fcull, 0x5b2110fd9a0c13d9ull},
    {"no_check", 0x7ee99094df4a4510ull, 0x33ac482fd6b62a6eull, 0x85de4d65244fe740ull},
    {"no_propagation_no_mean", 0xa3c3076e2f685916ull, 0x5de1a7b1b7c53361ull, 0x1a4e1fed59adcafdull},
    {"half_pixel_window", 0xc9b03c4a950dcfcdull, 0x29014351dbc115cdull, 0x83e011eb96ec1fdaull},
    {"patch_4", 0x2d4da9717a8052f5ull, 0x32c083c625b59033ull, 0x2d4da9717a8052f5ull},
    {"patch_12", 0x8baf4e4f892c755aull, 0x9692f51132bf72c6ull, 0x8baf4e4f892c755aull},
    {"patch_7_variance", 0x8325bc70cd570f29ull, 0x8325bc70cd570f29ull, 0x8325bc70cd570f29ull},
    {"paper_posterior", 0x516813779f9d0280ull, 0xc68fe9c55bda564eull, 0xd01850b3e01e2441ull},
    {"twelve_iterations_variance", 0xa746001c120c1693ull, 0x2953bff81dcaac72ull, 0xef2afcc41efe0771ull},
    {"strict_validity", 0x69e810ba1ace49d6ull, 0xb344f0396a27aae7ull, 0xebb1cb7b4ff043e5ull},
    {"tiny_sigma_s_variance", 0x6a88b384206c7231ull, 0xf224c8abe74d488full, 0x775a6a84c47aa227ull},
    {"coarser_look_variance", 0x13c3fc1a4d85c520ull, 0xe5a5dea3265c3245ull, 0xf65040e6b414d280ull},
    {"gain_compensation", 0xf6b4940ce044d4f4ull, 0xe676478132076952ull, 0xb6b8428bd65ab7daull},
    {"no_support_weights", 0xae0e698a0a136b23ull, 0x6d4fc7a990e8c82cull, 0x92f3264c444917e4ull},
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
