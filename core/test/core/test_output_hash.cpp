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
    {"balanced", 0x91e81ae0e411abc4ull, 0x43749c59c394f313ull, 0x91ffcea40a602e18ull},
    {"fast", 0xaef6221001a94552ull, 0x445faea180d875f5ull, 0x517148eebe1763d2ull},
    {"accurate", 0xe1fdb769658efbacull, 0xd4468fea6d2b6e14ull, 0x4a490d49ef2aad08ull},
    {"balanced_variance", 0x3ce49a968e2a573full, 0x974c2ec32d636e08ull, 0x53302298be861818ull},
    {"accurate_variance", 0xba75da545f184033ull, 0xcff133daf81fae3eull, 0xe965a3d414eb7255ull},
    {"finest_0", 0x308b38a5a7f54689ull, 0x8fd2df51a095a10bull, 0xc53d98cf424f2a30ull},
    {"finest_2", 0x52afcad0bdae03f3ull, 0x2b32ac7ff8535cbeull, 0xaaca1f636bcc3837ull},
    {"levels_3_3", 0xc56b7f0c45545288ull, 0x0ff5e4943d3fbcc6ull, 0xa75d633cea22cd59ull},
    {"whole_level_search", 0x39786f47e4cea77cull, 0x4b2944ecc0c9add6ull, 0x74b4040ca75bbe6eull},
    {"one_row_bands", 0x328305e2bded3c02ull, 0xff931597440648ceull, 0x5fbe9fb34cad1f44ull},
    {"no_check", 0x9bfbb5c9107ac3a0ull, 0x6b659dd80c85de0full, 0xb4363695869261d9ull},
    {"no_propagation_no_mean", 0x866d6ec1c29e931cull, 0xfb0b38f52f18d300ull, 0xfedcb36aa06a1850ull},
    {"half_pixel_window", 0xd0b4f013e2872aa3ull, 0x5c388481e6f6847aull, 0xea9fe2277a9ca532ull},
    {"patch_4", 0x1a338ba6f1ee317dull, 0xb48d0f0841377941ull, 0x1a338ba6f1ee317dull},
    {"patch_12", 0x801fac5d861e191dull, 0x19a3b950b29bdf12ull, 0x801fac5d861e191dull},
    {"patch_7_variance", 0x46363ddd9cf58f0dull, 0x46363ddd9cf58f0dull, 0x46363ddd9cf58f0dull},
    {"paper_posterior", 0xa2a64eea8c335d69ull, 0x686dfc03b53ea47full, 0xe0f5600b6cd8e6c1ull},
    {"twelve_iterations_variance", 0xf07e75da3ff65becull, 0xa95ec53c4d5052d4ull, 0x2611fa6e61481507ull},
    {"strict_validity", 0xc892be1c4cc71fdfull, 0xc7be589eb78f0fa4ull, 0x91f1575710c3e0dbull},
    {"tiny_sigma_s_variance", 0x7176c1edeb7f86d3ull, 0x9b9152eb8129603bull, 0xbfbbcb33273776f7ull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0xe93f80857d31ac5dull, 0xa2023fdf6fed0405ull, 0x233aafe38590a3e7ull},
    {"fast", 0x10f5e53887aec922ull, 0x859fdbfd4f5ef5fdull, 0x0013e4b692be1314ull},
    {"accurate", 0x1f7c88504b9f8a29ull, 0xe8af4e7cb8d3dfcdull, 0xe9d65c9e6c0bf901ull},
    {"balanced_variance", 0xcef651270d4cd3f1ull, 0x4e94de8d4d87963bull, 0xbd32f046ce2323e1ull},
    {"accurate_variance", 0x0fcc3b7a47cb4c47ull, 0x757a3b9e0c2c66dbull, 0x45fcc834b86e1b83ull},
    {"finest_0", 0xfe1ba96cdddcce3bull, 0xee52b095618b0c75ull, 0x8a05c82b34ca3a11ull},
    {"finest_2", 0x28ab9a3f93a4f4e7ull, 0x65ea218ac7cef6c4ull, 0x5306636e7543ee9aull},
    {"levels_3_3", 0x0fb0c438ec9f2c1bull, 0x5f911dfc24d0dfe2ull, 0x25b0d62d240ec524ull},
    {"whole_level_search", 0x3d3aa7d679d43770ull, 0xfcc65313b94c0fe2ull, 0x28a2c605a706cbc3ull},
    {"one_row_bands", 0x91aa3731e3bb8748ull, 0xd442367647f4d800ull, 0x45baf3728a0d4d43ull},
    {"no_check", 0x25e5e7fc63ef32a8ull, 0x3351b4078680338full, 0xc9e9baf89ed8870full},
    {"no_propagation_no_mean", 0x2cd618472d8e9f15ull, 0x439c26d1d488845cull, 0x6b815269e12c0e60ull},
    {"half_pixel_window", 0xf8c7d0cceeb161bbull, 0x552a36c3ca93d509ull, 0x26e53ef4830d5bfdull},
    {"patch_4", 0x2ba831a8f94046c8ull, 0xfd5332d49be04882ull, 0x2ba831a8f94046c8ull},
    {"patch_12", 0xd3ae6b8b8ffaace4ull, 0xe57cc70893c945f8ull, 0xd3ae6b8b8ffaace4ull},
    {"patch_7_variance", 0xcc9d7913d135f94aull, 0xcc9d7913d135f94aull, 0xcc9d7913d135f94aull},
    {"paper_posterior", 0x1237cf73f49df3c1ull, 0x126ea5b68943944full, 0xc83454f3bc9b9856ull},
    {"twelve_iterations_variance", 0x45bfe134b2d3217cull, 0x25addc1ebff71e3cull, 0x278f0e6a3866a621ull},
    {"strict_validity", 0x68530c011c50e6f3ull, 0x774f00a1de6f6495ull, 0x339688cadb37cdadull},
    {"tiny_sigma_s_variance", 0xf013d7878d8afdd0ull, 0x369d1a8eee5ed074ull, 0x815969f05a6be99dull},
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
