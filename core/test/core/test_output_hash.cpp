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
    {"balanced", 0x5fa15811b30d2f3cull, 0x9bbc8ac1430fa805ull, 0x67cccd9faa5ddc9aull},
    {"fast", 0x1779ef0d3b15b1f7ull, 0x476d57aaa51eb06dull, 0xc052df676d64588full},
    {"accurate", 0xf97e551a502b3501ull, 0xfb905527c41e94cbull, 0xce2bdf7456029221ull},
    {"balanced_variance", 0x4642bddcaf737f55ull, 0xaee55f3d4f0045a8ull, 0x53f425f728ee2554ull},
    {"accurate_variance", 0x5c6c047052da8c7dull, 0xf5c998caf7208a1cull, 0x3b8cb7294120d5c4ull},
    {"finest_0", 0x17440673e699cbf0ull, 0x300e7b52f12d86bdull, 0xf0a4ff70f1a187b5ull},
    {"finest_2", 0x28612c296bc5cbf3ull, 0x239ac662a96888e5ull, 0xc9270ee97ac2a9f4ull},
    {"levels_3_3", 0xd48e7d54792ccfb3ull, 0xbc762e17797ec34eull, 0x95e7624e6e898fb6ull},
    {"whole_level_search", 0xa8f9d9a902eb755bull, 0xe6e579e57d2b180aull, 0x9f7dd20de6508395ull},
    {"one_row_bands", 0x1cdaae18393a7d5eull, 0x87ab44099344bf90ull, 0x493b29472da39f11ull},
    {"no_check", 0xbe046749187eba25ull, 0xae506f243692e3e5ull, 0x2a63c83e0586972full},
    {"no_propagation_no_mean", 0xe0ff5f9eb2774b6full, 0xe113a0290af8e8e5ull, 0xa2c86e6c90af1416ull},
    {"half_pixel_window", 0x691c63ca01560e44ull, 0xc7b7457e1b6dafe7ull, 0x5e0bf066d4632757ull},
    {"patch_4", 0x583a912ff1b7a713ull, 0xad77dedae646988eull, 0x583a912ff1b7a713ull},
    {"patch_12", 0x6aa8864578bbe229ull, 0x7f0ed8b2fa1bbdd0ull, 0x6aa8864578bbe229ull},
    {"patch_7_variance", 0xf09d801a3684e2dfull, 0xf09d801a3684e2dfull, 0xf09d801a3684e2dfull},
    {"paper_posterior", 0xf826f658709ff56bull, 0xbdd40ff1b1771a8dull, 0xcf84983ec36662b9ull},
    {"twelve_iterations_variance", 0xdc5c8a94bbaca926ull, 0x819793adc514b60full, 0x279e35827c18b36dull},
    {"strict_validity", 0x855270eb5318e896ull, 0x5d322f97fc1bd09cull, 0x41f771832a3030e9ull},
    {"tiny_sigma_s_variance", 0xd1c50de6e719bbbcull, 0x9af441de115b5bf1ull, 0x706df2dd132fc66cull},
    {"coarser_look_variance", 0x77bbb0a9eeab9d03ull, 0x47988db224cbe18aull, 0xafcf22d210cf29b5ull},
    {"gain_compensation", 0x7c0f1dcee40c331eull, 0x59fe9100c23d04adull, 0x621b33845570bd80ull},
    {"no_support_weights", 0x642a505e24df5aa9ull, 0x5c17f6800f12306cull, 0xf22c30175d67c4f3ull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0x16ebc1bff9dff664ull, 0x44a6ce648b21d575ull, 0x2835a7b5de24f717ull},
    {"fast", 0xf4666ddb2d641744ull, 0x8dc278ca034503d4ull, 0x66d3ffbaa5f54174ull},
    {"accurate", 0x9f254bed6df8f836ull, 0xf36cb773e701fa67ull, 0xdf1914aa53fb1659ull},
    {"balanced_variance", 0x6b0776bbc08f372bull, 0x36b61c390f45918cull, 0xd55433f40434d153ull},
    {"accurate_variance", 0x7cb75aefcb52c015ull, 0x776b8b7b7b5a4336ull, 0x5d2ad474b979621dull},
    {"finest_0", 0xa04129a61a7a16ffull, 0x32179c37251c122bull, 0xd81b0710b3b14a05ull},
    {"finest_2", 0x97ecbba8b1d33fecull, 0x67b645dd7727767aull, 0xe3c48f41f3d2f5d8ull},
    {"levels_3_3", 0x0615e08b2e431b5dull, 0xace6dde7bb5cf058ull, 0x744428d1c5bc8464ull},
    {"whole_level_search", 0xbe0ef86cc20e593full, 0x416ce18659dd9021ull, 0xb7596463bb473443ull},
    {"one_row_bands", 0x2216632fae9cba79ull, 0x2cff38c1d6a7293full, 0x7d1768e217d0db63ull},
    {"no_check", 0x5102cc47b09d5680ull, 0xe6a6de55557df1a9ull, 0x0f680c87c98edf58ull},
    {"no_propagation_no_mean", 0xc63ecbcd220edca5ull, 0x8b54b106b11ee448ull, 0x56646d76c4427a29ull},
    {"half_pixel_window", 0xe2c10a5a2a9e9853ull, 0xb80dddd8589b196full, 0x55f55af1b77682abull},
    {"patch_4", 0x4c967a620c9eece9ull, 0xbb3ca146a5a01e96ull, 0x4c967a620c9eece9ull},
    {"patch_12", 0x7d0ae7f8ad561126ull, 0x635187f4d6cd1e89ull, 0x7d0ae7f8ad561126ull},
    {"patch_7_variance", 0x53a0bc8da413f944ull, 0x53a0bc8da413f944ull, 0x53a0bc8da413f944ull},
    {"paper_posterior", 0x93f8aeb88e2058beull, 0x7352fd6dbb04a6c1ull, 0xfdca195bc606ec49ull},
    {"twelve_iterations_variance", 0x06d218d236c14890ull, 0xd94ac7c4577514c9ull, 0x00646fbbca83760full},
    {"strict_validity", 0x56f24a089c9c4a86ull, 0x3c678341e1543246ull, 0x693ccbf27fd7d5fcull},
    {"tiny_sigma_s_variance", 0x1151b1439328280cull, 0x966ab27f993605adull, 0x8f3d2ee5d3efaab5ull},
    {"coarser_look_variance", 0xbc1ee8dcec558698ull, 0x9c092b0041ca4b75ull, 0xdf85a78fbdd4e5b0ull},
    {"gain_compensation", 0xd134853b63a1da58ull, 0x0774a3630dc5985cull, 0x01bd4e8774022018ull},
    {"no_support_weights", 0xc613bf516bc3ecdbull, 0x6fc355b3187042ddull, 0x35ffd24587942c1full},
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
