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
    {"balanced", 0xc43be3737f21983full, 0x4e784c71dd606eb1ull, 0x7871218d6ef5a0c0ull},
    {"fast", 0x6a8907b34791df90ull, 0x31c1e676bc64ee42ull, 0x9555064e3b94a961ull},
    {"accurate", 0x8016289f1a8af1f0ull, 0x1a5540b899dae974ull, 0xf9c0cbd66656ef9aull},
    {"balanced_variance", 0x79e6b63cd3f7317cull, 0x6a65ccb90f238341ull, 0x47c9ea136311332dull},
    {"accurate_variance", 0x788788b39b3bcec8ull, 0x8923cb45457da6abull, 0x223ac7e0a0b2cfb2ull},
    {"finest_0", 0xbbe63fa0d32519fdull, 0xc6a2c19e5cc83cdeull, 0x8875e208fa4541d8ull},
    {"finest_2", 0xfc7b3a5e27670642ull, 0x661adb6c5682d788ull, 0x94dc91cf9b9a74deull},
    {"levels_3_3", 0x60f666ac3062f5d2ull, 0x46554d40e0f75001ull, 0x45e4546c635b80a6ull},
    {"whole_level_search", 0x4002f8e30f64831aull, 0x46135b8d78dc5a1cull, 0xcdbf69d919ad6ee7ull},
    {"one_row_bands", 0xf028b9a2170737ffull, 0x44b2335b8975bc9dull, 0x26eae80222f2b5aaull},
    {"no_check", 0xc01dde5f67632c41ull, 0x72416b1e318d7ae0ull, 0x8aeeb7d69cf0a830ull},
    {"no_propagation_no_mean", 0x4ec858212a926d8eull, 0xa3c365a72f51206cull, 0xa9ad81bb766a8a99ull},
    {"half_pixel_window", 0xee4832545bf71caeull, 0xddc4eeb3dec9a656ull, 0xd26d030b6a048e70ull},
    {"patch_4", 0x8c084b569dd39381ull, 0x3a1d145ad465e4f7ull, 0x8c084b569dd39381ull},
    {"patch_12", 0xd39b3258110b600full, 0xf412f365ee463af2ull, 0xd39b3258110b600full},
    {"patch_7_variance", 0xf2c4d0b0fd2ad761ull, 0xf2c4d0b0fd2ad761ull, 0xf2c4d0b0fd2ad761ull},
    {"paper_posterior", 0x933933904ebdf6f4ull, 0x125754b9188fcddeull, 0xc6e889a534bbbabaull},
    {"twelve_iterations_variance", 0x249df2dc4aa95bfbull, 0xe64b561471829641ull, 0x2c400c9d3836eba9ull},
    {"strict_validity", 0x718690bd691bb0e0ull, 0xc541178d6432bd16ull, 0x8c3530cc1eb9ca4bull},
    {"tiny_sigma_s_variance", 0x832e18c7af66a9e2ull, 0xb5570e7cb454b58cull, 0x3b86490162162a2full},
    {"coarser_look_variance", 0x3114be284ed031b8ull, 0x5d4b78f9def5d16bull, 0x0cdc4b0acf6b53a1ull},
    {"gain_compensation", 0x9111e5193824313bull, 0x482b765225e54b97ull, 0xa52f6b0dd4cbb413ull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0xd9ed87145dc1aff5ull, 0x0587d88d839273dfull, 0x1d167b6f5d37269eull},
    {"fast", 0x157ad1e5ad4cf5ddull, 0xda8c63fd137761d5ull, 0x4f93725d24eb900aull},
    {"accurate", 0x8aa41c3cc35f3808ull, 0x35e7b6480ddebb76ull, 0x1f529e7833a4b4deull},
    {"balanced_variance", 0x113ee49287cb9c89ull, 0x4def2a4d0ae31a66ull, 0xc52024e20dfd3a5bull},
    {"accurate_variance", 0x129d4385f4fc44d2ull, 0x17a3bb6e3b407c6bull, 0x4c14967f87622582ull},
    {"finest_0", 0xb1bf775fae770ddbull, 0x7c28ae40bd1bc346ull, 0xfb098b2a00dbbf03ull},
    {"finest_2", 0xb0284ff949d9a5d9ull, 0x5d7a38ffe40a5c2full, 0x764a142c83923a7cull},
    {"levels_3_3", 0xb91a035f1aaff655ull, 0xa9c41d9179953c0full, 0xb7f64c90891405c7ull},
    {"whole_level_search", 0x6bd9f9ccc11152dfull, 0xf4913e16e4b7291dull, 0xb2ce0ebe4e324bb1ull},
    {"one_row_bands", 0x2825e6c42797b50full, 0x7e65b067083f8e16ull, 0xd8e3ad39637e27b5ull},
    {"no_check", 0x711eeaf7ab0c73d2ull, 0x19de3826934d4880ull, 0xdf0c11ee902d297eull},
    {"no_propagation_no_mean", 0x0b2c61eb831fadf9ull, 0xfd91b9628ec41e8cull, 0x7a35334c4897e982ull},
    {"half_pixel_window", 0x99da2a8917454003ull, 0xd74b00ecf59dc89bull, 0x7bbea91b3833eaf1ull},
    {"patch_4", 0x73111b0f2cfcbbcfull, 0x447806ea1fa51dc3ull, 0x73111b0f2cfcbbcfull},
    {"patch_12", 0xe9ad06bc5714a0eaull, 0xa70fa12d2f02fc7aull, 0xe9ad06bc5714a0eaull},
    {"patch_7_variance", 0xab6ac2d968cb3aaaull, 0xab6ac2d968cb3aaaull, 0xab6ac2d968cb3aaaull},
    {"paper_posterior", 0x7c80e843a9861c7dull, 0x88933d08601f7faeull, 0xdd9b7ac228af516cull},
    {"twelve_iterations_variance", 0x675c4148ccaef144ull, 0x6239615293ed7658ull, 0xcdcedabf005b9f6eull},
    {"strict_validity", 0x134f2ec54f05d5a8ull, 0x903bff71ecd7228bull, 0x03b0c9dc786aa0f3ull},
    {"tiny_sigma_s_variance", 0xb34fda7acb1e18b8ull, 0xa3e5cde75b0b0bb6ull, 0xa6756383cc442d53ull},
    {"coarser_look_variance", 0x2e07a4aa9f8ce153ull, 0xbe2b7e5c57b4d3bdull, 0x4899470c2d1e3d10ull},
    {"gain_compensation", 0xb9fe23f7aec4906aull, 0x07f8c9e26dc459a7ull, 0xb98c1dc5d9979e66ull},
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
