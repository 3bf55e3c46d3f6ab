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
    {"balanced", 0xa5667fff807aa0b7ull, 0x0a1aed5ae7a0a524ull, 0x5d3f52b575944fccull},
    {"fast", 0x830aabb1004709d7ull, 0x1d9d6be9ecc21a46ull, 0x319f29be73fb0adaull},
    {"accurate", 0xcc3dc91f970baec7ull, 0xca720fff274eb291ull, 0x70936a04f4bc9097ull},
    {"balanced_variance", 0xb7a3c1b101ad93e8ull, 0x46e48961327b64f0ull, 0xd962c849d4718d19ull},
    {"accurate_variance", 0x270f57c0c7851a27ull, 0xb43e36571160daaaull, 0xdb87df39bb1fcb5bull},
    {"finest_0", 0x9ab2769ecbe2cf44ull, 0xd5021c8f7233a34aull, 0xd7e1db95db0a8cf4ull},
    {"finest_2", 0x9c2cb0d8404ffc5dull, 0x6ac659de8d23bb17ull, 0x6b5d748ae51b897aull},
    {"levels_3_3", 0x53b8931de1b116c9ull, 0xffecb972b2e43971ull, 0xdd200b1702805670ull},
    {"whole_level_search", 0x3f302d2cf632e0b8ull, 0xf49997791251583dull, 0x38072522a2c9903full},
    {"one_row_bands", 0x335b9245a1c1b1d5ull, 0x394cc8b7dac5cb75ull, 0x74c5d6fe16575e9bull},
    {"no_check", 0x849f96346f237269ull, 0x33cd47bb05880833ull, 0x114b6b3c5f8a65ebull},
    {"no_propagation_no_mean", 0xc903a56983b9f168ull, 0x7368429441f6238bull, 0x8c264162193c033bull},
    {"half_pixel_window", 0x73cd0ced2457610dull, 0xdcbb363cf91013d8ull, 0xc18689646005e529ull},
    {"patch_4", 0x1fc1197e80cfcde9ull, 0x00cfef31ac52cc25ull, 0x1fc1197e80cfcde9ull},
    {"patch_12", 0xeec8a939b26237cdull, 0xb27cd59399e17f88ull, 0xeec8a939b26237cdull},
    {"patch_7_variance", 0xca1777474058c128ull, 0xca1777474058c128ull, 0xca1777474058c128ull},
    {"paper_posterior", 0xbdc738364bf369a2ull, 0x6766d5b3e82b7e35ull, 0x5b1647d4d69ccaa3ull},
    {"twelve_iterations_variance", 0xd4bfcd24b40675f2ull, 0x95abcf6a6f4d4f6eull, 0xd893bdcd9af97177ull},
    {"strict_validity", 0x62c74864e73ddb46ull, 0x835fe3a9a875ebbdull, 0xb6d7ca72d8fab4dcull},
    {"tiny_sigma_s_variance", 0x7876c0526120d2e8ull, 0x551a21bab202a229ull, 0x04e83a540c4c59d2ull},
    {"coarser_look_variance", 0x664bf9108c83eadbull, 0xebfe16c89b6beb05ull, 0x2c61fb5367c4f7d5ull},
    {"gain_compensation", 0xca0f466da573f9d8ull, 0xa074c98188aed6d0ull, 0x8950a459731ab973ull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0xba8f1664a5f5f435ull, 0x73ae857686ed5f65ull, 0x465cb675484f5a9eull},
    {"fast", 0x4735a3f46ff5b25bull, 0xbcd5bb7a692251c7ull, 0x4a8e7b7bee3e206bull},
    {"accurate", 0x35da935f44ea9dd7ull, 0x9d997928c375d9e5ull, 0x5d60bf52c92b3ed7ull},
    {"balanced_variance", 0xdefcf802b02a9ee1ull, 0xa17022a105bdf958ull, 0xac5bf70e098684c3ull},
    {"accurate_variance", 0x77ac9c1c567133f1ull, 0x695517d5522a0528ull, 0x1c90d992117a655full},
    {"finest_0", 0x8458167467269385ull, 0x62558ff5ca43bb19ull, 0xa3e744773353aae7ull},
    {"finest_2", 0x32c85f1b52c408b3ull, 0x2bf6b36297bb0a8cull, 0xb6153661cda1665bull},
    {"levels_3_3", 0xcce926697e034e74ull, 0x1dda53ddfc4cc3d0ull, 0x0854c7526eee9766ull},
    {"whole_level_search", 0x2681cfcc75d1cf27ull, 0xb616d69d8df14292ull, 0x09b99666c69e98c9ull},
    {"one_row_bands", 0x8f25402ce6f4721cull, 0x304c54d4f00ea4cfull, 0xa9ac6996fab822e3ull},
    {"no_check", 0x1e4300c41324bf66ull, 0xcc9627af5848a437ull, 0xf738acfcf94c7e09ull},
    {"no_propagation_no_mean", 0xdb029caf0b1486d4ull, 0xc01995158c89f49dull, 0xdff5d59d54fd1c20ull},
    {"half_pixel_window", 0xcd615c39d8525221ull, 0x8fa0505d253e882dull, 0x2dbe65f01e7265e8ull},
    {"patch_4", 0xeb2efdeb923b4cfbull, 0x70834823e6f56f6bull, 0xeb2efdeb923b4cfbull},
    {"patch_12", 0xe4baf5e5b44285b7ull, 0x9fb945a278f8e023ull, 0xe4baf5e5b44285b7ull},
    {"patch_7_variance", 0xc92d8fabdc72b19eull, 0xc92d8fabdc72b19eull, 0xc92d8fabdc72b19eull},
    {"paper_posterior", 0xd0fcda0ac8088d31ull, 0xc7ffc3bb666c47bdull, 0xfcac7aad7974f98bull},
    {"twelve_iterations_variance", 0xcb8f5fa91187d5f6ull, 0x2673d034037c42eaull, 0x92e952cc6fe6b425ull},
    {"strict_validity", 0xb932606c1455acfeull, 0xfe5c82f7f1a56ac3ull, 0x9a980e2ed330ee6dull},
    {"tiny_sigma_s_variance", 0xf0dc52f9113a8085ull, 0xe839396171adb8f5ull, 0x4e71aa480f5649b0ull},
    {"coarser_look_variance", 0xcc0a5b0d69911509ull, 0xc52bad3c3dd8970cull, 0xb0ff3bb1847754c0ull},
    {"gain_compensation", 0x2338724d7ec055d8ull, 0xa0ac7a34b999ee5dull, 0x71f2fd71b6695fc2ull},
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
