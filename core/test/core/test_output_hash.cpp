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
    {"balanced", 0x66925925dd183dd9ull, 0x9698c23cb36ff72bull, 0xbd20c8f3ce183aedull},
    {"fast", 0x71e1f29aaea7690cull, 0x6f82426522e5ae83ull, 0xdffd1f1d0a321f42ull},
    {"accurate", 0x7e41253a6917c2cdull, 0x2371f5cbfce4fd2aull, 0x1df3288bb784304full},
    {"balanced_variance", 0xa01280d0f59550f7ull, 0xdfc2b1335134a469ull, 0xf7fd9f6371de736eull},
    {"accurate_variance", 0x41776ac64d9328dfull, 0x2aed81921523e644ull, 0xd53dd3cf9d18ed33ull},
    {"finest_0", 0xd2c1412c57abdbbfull, 0x02e5178682775466ull, 0xdb62f751c0aa8f7full},
    {"finest_2", 0x93a86eeb395c85c9ull, 0x62b9e29d1308e66cull, 0xa005c4c2a86aac2dull},
    {"levels_3_3", 0x5c0edac235ef40beull, 0x277e11e50014db6bull, 0x1a6c8c6162317c10ull},
    {"whole_level_search", 0x04528b9b68c8a735ull, 0x0236fd793eaff530ull, 0xf175bd5df94c3264ull},
    {"one_row_bands", 0x2903aa9b753a48a8ull, 0x4bd4fd32c99ab6faull, 0x6e64d1d484765f5cull},
    {"no_check", 0x3614653e7af731faull, 0xdcca3d718ecb193eull, 0x6aa122d69b2a5a79ull},
    {"no_propagation_no_mean", 0x9e6dcb10f1f4ef87ull, 0x28556f0886f872ffull, 0xf427b6af0eb396bdull},
    {"half_pixel_window", 0xb975587635a8b76eull, 0x5ec03f6a423d25d2ull, 0x9675438b9cffd43full},
    {"patch_4", 0x63a792060140bf93ull, 0xb483b47f8b13753cull, 0x63a792060140bf93ull},
    {"patch_12", 0x5c0b333f6c7e3987ull, 0xc96e35a1cd6a1be4ull, 0x5c0b333f6c7e3987ull},
    {"patch_7_variance", 0xb9484506f94f6395ull, 0xb9484506f94f6395ull, 0xb9484506f94f6395ull},
    {"paper_posterior", 0x0aa0d01b37c19571ull, 0x769c5e83f12219aeull, 0x0ed571a25f1982ecull},
    {"twelve_iterations_variance", 0x6bac76ff6094308cull, 0xd08fe9d9457e9d3eull, 0x3c191b8c4520b181ull},
    {"strict_validity", 0x06caa563e1d9dbdfull, 0x07cf9b060e33cd28ull, 0xccc9c4bae236e925ull},
    {"tiny_sigma_s_variance", 0x7ee097755372dc31ull, 0x42f9a810e50d3e9cull, 0x9c7cd92172b2b161ull},
    {"coarser_look_variance", 0x9ebdcc84110581b7ull, 0xe8f8322bf0fb8845ull, 0xeeabf35d8d00bd22ull},
    {"gain_compensation", 0x09958b7423822f72ull, 0xdcef27eba31f9ed6ull, 0xcbe83bb2cbbf835full},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0x7db32732a1a1e945ull, 0xc8f125ec3c9d347aull, 0xda826db27e3b4425ull},
    {"fast", 0x2a7e3e849fffefbaull, 0x520f5cc6e7f1db8dull, 0x2e058c4280e151caull},
    {"accurate", 0x4a12570de44866e1ull, 0x829568076e72c4d1ull, 0x4652023068e81a01ull},
    {"balanced_variance", 0xb25c284615e73393ull, 0x68f0b8f375c7af8dull, 0x73a059de3f610dd3ull},
    {"accurate_variance", 0x43d6cbdbdce44163ull, 0x63f04c57ac1deef1ull, 0x6fdd2e7d2f50fe2full},
    {"finest_0", 0x9e91114556966e78ull, 0x648dd3e2d12aa634ull, 0x75318ee002a723deull},
    {"finest_2", 0xe44d84a95b96a86bull, 0x395b4c36a47ae677ull, 0x074d450ad284fafdull},
    {"levels_3_3", 0x440b8010be902429ull, 0x52fe741b08793bd8ull, 0xe91f6a9e560d760aull},
    {"whole_level_search", 0xef27120c8cea8c2cull, 0xd04af4889bae9f14ull, 0x5436bea51697210aull},
    {"one_row_bands", 0x31852c9b9815c416ull, 0x3938c5fa67ef1ddeull, 0x73b4aec3fe608d11ull},
    {"no_check", 0x978873ecb36a6047ull, 0x8470dd34bdcfd47full, 0x684421bb9dcfddfdull},
    {"no_propagation_no_mean", 0xf0f5c1c6a10fbc44ull, 0xb247888323d666bbull, 0x53462ce53661202dull},
    {"half_pixel_window", 0x784844cf79c96cfbull, 0xef9bce8c1b558dd1ull, 0x94cfbb7e6c4e892eull},
    {"patch_4", 0x6bf7654672a6715eull, 0xbcc6cb93c12e55c3ull, 0x6bf7654672a6715eull},
    {"patch_12", 0x0c7dad24eea16283ull, 0xb84e39df61717c3full, 0x0c7dad24eea16283ull},
    {"patch_7_variance", 0x7fbd9f4468f0da23ull, 0x7fbd9f4468f0da23ull, 0x7fbd9f4468f0da23ull},
    {"paper_posterior", 0xda325fc428ef1e98ull, 0x178f2202eb0c5f54ull, 0x2e083bd75ab8f548ull},
    {"twelve_iterations_variance", 0x8a02be89c46e2793ull, 0xae10477af15c6997ull, 0xf41be60ccb614f05ull},
    {"strict_validity", 0x1176125b285115a9ull, 0x841dc40732cc85f8ull, 0x162be3474358643full},
    {"tiny_sigma_s_variance", 0xd0b60a5db7d4187cull, 0x5e91155eb0907f98ull, 0xad1d8047551e8adbull},
    {"coarser_look_variance", 0xec443220c1b34d19ull, 0xecc4d0f714dd55cdull, 0x703aedd9df2b8307ull},
    {"gain_compensation", 0xe0868264564d1f7full, 0x0d45c2059dd0f985ull, 0xfb53d9ac008ac884ull},
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
