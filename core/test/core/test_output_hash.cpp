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
    {"balanced", 0x76898134e0595b76ull, 0xdda62430da029042ull, 0x2f38e541af54f819ull},
    {"fast", 0xaac1695721629529ull, 0xdb83cbdb4586a41full, 0xeda5c884fafee61aull},
    {"accurate", 0x2bd5f778d0b5ae0bull, 0x0db1745f12df106full, 0xf3c1366bab09a1b6ull},
    {"balanced_variance", 0xfea6dfffd2df3687ull, 0x7e48877e91bed776ull, 0xdecb71c2bb5def70ull},
    {"accurate_variance", 0xdd3c9b19c1f40ffcull, 0x2525ec276c7c2e86ull, 0x03e2a7bfa2034fc7ull},
    {"finest_0", 0x922fc8b32ca65737ull, 0xc0b4ef68a913bcc0ull, 0x906a806c6e2d7cacull},
    {"finest_2", 0xc143aabd91e64c95ull, 0xc00b2ea4ecefe2f3ull, 0x808c9caa1b506145ull},
    {"levels_3_3", 0x46ef9339c69fb706ull, 0x6e1c37f131c5d958ull, 0xaceef0a08444db16ull},
    {"whole_level_search", 0x57d56c1fa9c17be0ull, 0xa82443527e198588ull, 0xba11dcd7300dfb9bull},
    {"one_row_bands", 0xf644ac84df9a27b1ull, 0x7daf4a03b4f48fb6ull, 0xbec53d26b1a6bd2eull},
    {"no_check", 0x7c223b8645207d1cull, 0xd4ec35d3ffba57bfull, 0x2017afc0069b28a0ull},
    {"no_propagation_no_mean", 0x43ac0c477d8660e9ull, 0xebded1e5958ce2d7ull, 0x9f8311e82c2c9d4aull},
    {"half_pixel_window", 0x8b3c7c9a72c1eec8ull, 0x5164ce884c8a1f3bull, 0x0b049a334cf681deull},
    {"patch_4", 0x56946904ade818d8ull, 0x1b2d6f58a441ae3dull, 0x56946904ade818d8ull},
    {"patch_12", 0xa4333e36efde5c74ull, 0xa2e43efb76568165ull, 0xa4333e36efde5c74ull},
    {"patch_7_variance", 0x4146be4c51b94c5aull, 0x4146be4c51b94c5aull, 0x4146be4c51b94c5aull},
    {"paper_posterior", 0x300c01e338ec97a4ull, 0x08a5533c53cb5007ull, 0x1c5a7d521551d34dull},
    {"twelve_iterations_variance", 0x58b0bd569a439907ull, 0x4e2867fa8eb3479aull, 0xe949b5d7ac7e2171ull},
    {"strict_validity", 0x71aa4b11d52c97a9ull, 0x871be9991187ed11ull, 0xee74571da2855960ull},
    {"tiny_sigma_s_variance", 0xe59ec0370c20e6a6ull, 0xc2fc43a8ea8f1349ull, 0x9052600870eb069full},
    {"coarser_look_variance", 0xa764480303e56048ull, 0xf4f96916887e8ebbull, 0xead6bc6e9a1f5f25ull},
    {"gain_compensation", 0x89d2d3ee541daea2ull, 0x0a3f7f080ca8cd65ull, 0x84b071050bea74cfull},
    {"no_support_weights", 0xcac01904706aa28full, 0x32804fdbffafc9fbull, 0x9f3d75e5936b5708ull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0x7cd090c72b7f600eull, 0xb3a3e2e258ec5d6full, 0x0d3a8b3e47044debull},
    {"fast", 0x7247568c21437efbull, 0xe6f5295c583b8129ull, 0xd1ed33b4d885b45aull},
    {"accurate", 0xf417b60d519e0a8eull, 0xb31415ca43003aceull, 0x146b5ae43b74c393ull},
    {"balanced_variance", 0x950283afdef8e5f6ull, 0x7336df5802c73717ull, 0x2a91623849b4a537ull},
    {"accurate_variance", 0xf36789af377df28bull, 0x651134aea7bd8c93ull, 0xc6642034f1101cd4ull},
    {"finest_0", 0x8e325ae55475db35ull, 0x34753c094bdbe218ull, 0xe9f2d6dd421f7dc2ull},
    {"finest_2", 0x9dabf33e4b21bf99ull, 0xd3cb52ca5d564c0dull, 0x6d7d8b1e71e53b13ull},
    {"levels_3_3", 0xdb0af839ba18e7a0ull, 0xbe31e85f4c56d589ull, 0xb879315c24b46492ull},
    {"whole_level_search", 0xbd4e86039eeaab0aull, 0xc10a099caceca7cfull, 0x372dd28123b87bf7ull},
    {"one_row_bands", 0x19ea928b52a95603ull, 0x3e4c0fd9f1b914a4ull, 0xc1480854947b8112ull},
    {"no_check", 0x68e3e847756f074eull, 0xe3e90ee53877534dull, 0x4493c0adf1fe793full},
    {"no_propagation_no_mean", 0x2f2a274949f4baddull, 0x50b48004c81091b9ull, 0x89b4df2d60c3e12eull},
    {"half_pixel_window", 0x5ec9d7707dcb9751ull, 0x53709ab04860411full, 0x0d54139c8e5c4783ull},
    {"patch_4", 0xb54e855286ef017cull, 0x135a282e2b9cd467ull, 0xb54e855286ef017cull},
    {"patch_12", 0xebfade1ac0f98e2bull, 0xe6966ec55cd98afcull, 0xebfade1ac0f98e2bull},
    {"patch_7_variance", 0xa36f5f9d1c4a572aull, 0xa36f5f9d1c4a572aull, 0xa36f5f9d1c4a572aull},
    {"paper_posterior", 0x5f54cc4d6571abb9ull, 0xc5fdf050fb3d0d30ull, 0xc61360fc4c5d38deull},
    {"twelve_iterations_variance", 0xe62190cbbc2ce342ull, 0xc985b598fad38894ull, 0xa9deb6bcfc848242ull},
    {"strict_validity", 0x89e1c0256f4bc4ceull, 0x7f8db9715dc68209ull, 0x31077c087f4585dcull},
    {"tiny_sigma_s_variance", 0x31588206db4dc6cfull, 0x7192df4805f537d2ull, 0x50e0ec7d49ec3cb5ull},
    {"coarser_look_variance", 0x57a7d0500f974ab4ull, 0x66a67880f2fa2f88ull, 0x8b214fd4b0385fedull},
    {"gain_compensation", 0x4264c149fa30f693ull, 0x9660e1e8a51ea1f2ull, 0x37452d22d23d31f8ull},
    {"no_support_weights", 0xa4b4fa249c5ffeb0ull, 0x0633b4d6c2a2de3dull, 0x0f7fc948b3311899ull},
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
