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
    {"balanced", 0x78e14a978319646full, 0x8f8990fc2f361b43ull, 0xdb13a95cc9dc9993ull},
    {"fast", 0x909e49ac0f142315ull, 0x5fb9cb94e6b65438ull, 0x941598aca75c0d1cull},
    {"accurate", 0x0cf81c8ce5e22a5dull, 0xd3149a92a6a3f07eull, 0xc2a334f49a07ec8aull},
    {"balanced_variance", 0x92b749a9ea5a41fcull, 0x59d1a32503ef26b7ull, 0x574771d608abb7baull},
    {"accurate_variance", 0x739631c40dd57ce5ull, 0x089754f31a61e2a9ull, 0xec30c4431cb52f3eull},
    {"finest_0", 0x3709d21187119dedull, 0xfbdadcd6d1de07e8ull, 0x43384699ba940dacull},
    {"finest_2", 0x1eed7df21dbf6b9bull, 0x96715acdbf05ecd1ull, 0xe405fe6565eb1c95ull},
    {"levels_3_3", 0x8b873bc7d7225eeaull, 0xa4f9fac0c9a2b415ull, 0x805be8b731d3c16dull},
    {"whole_level_search", 0xb22c1a8dcd602a2cull, 0x3bba77c71d196ebcull, 0xa80c34d38df4f983ull},
    {"one_row_bands", 0x94c5e33493265d74ull, 0xac8591b40d0535d5ull, 0xc9dc97135c75531cull},
    {"no_check", 0xc50eaedb0fa4eb63ull, 0xd9bc765f91d8dd76ull, 0x8c3627d5bd3abfb6ull},
    {"no_propagation_no_mean", 0xff7336a1dc1f2394ull, 0xc63f05d1b335356bull, 0xd7ab4dafe41b33b7ull},
    {"half_pixel_window", 0xf949a9c0e18b889aull, 0x50162398a7c8a14full, 0x0171eab8e5736b67ull},
    {"patch_4", 0xa4cc0802754a367dull, 0x839cd94a5a0b6be5ull, 0xa4cc0802754a367dull},
    {"patch_12", 0xe1ed1903efba1ca9ull, 0x2beac9ca4405e886ull, 0xe1ed1903efba1ca9ull},
    {"patch_7_variance", 0x399c9c95bada22caull, 0x399c9c95bada22caull, 0x399c9c95bada22caull},
    {"paper_posterior", 0x4de5f57931fff9e2ull, 0xd0743c86229288fcull, 0x6988c1953d102cbaull},
    {"twelve_iterations_variance", 0x13a4a01e44972888ull, 0xc8b5396408a2b1d4ull, 0x49c019c79112f558ull},
    {"strict_validity", 0xbc5a76be92a61f0aull, 0x94ae8b1c663c652full, 0x14a43578d10dc39eull},
    {"tiny_sigma_s_variance", 0xbd1268a764554aebull, 0x7ab51ee936623bdaull, 0x0e521fb7cbed1eafull},
    {"coarser_look_variance", 0xcf4c00db9fc8bf39ull, 0x2072847cc8cf650aull, 0xa24114422c2df897ull},
    {"gain_compensation", 0xa2b74fff393ef28bull, 0x8bc5350d9627eba7ull, 0xbda74533684d8755ull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0x603610a7a0abcec3ull, 0x166fcdfd9f9b4210ull, 0x4d1fd64cee70cbbeull},
    {"fast", 0x03563efac2822a2aull, 0x4ad2afa4b39ea5d1ull, 0x5a58859f81826db2ull},
    {"accurate", 0x447db01518ef5a1eull, 0x90e715350a818cc3ull, 0x5a1f696601e42a8full},
    {"balanced_variance", 0xdf2f19aeab82fc1bull, 0x93ceb59ce993f70dull, 0x7a9d94d68a892b57ull},
    {"accurate_variance", 0xd5982a4b8c080304ull, 0x8428b5f7503708d2ull, 0x208f07b1fef736c3ull},
    {"finest_0", 0x7462073e07846bbdull, 0x7c03383f0dad0cb1ull, 0x775e87dd72c1268aull},
    {"finest_2", 0xc696667125c3e494ull, 0x56062d698d0bd570ull, 0x8e0880d6b532296dull},
    {"levels_3_3", 0xf980b64426a7ff93ull, 0x197a2412b3790c9bull, 0x2c768c382081807full},
    {"whole_level_search", 0xdb447b8593563017ull, 0x17948be0a5e27417ull, 0xd07aea840d384c04ull},
    {"one_row_bands", 0xf9023ddf5db2fb8cull, 0x86c51a01d41b9d16ull, 0xeee2d3e17cd91890ull},
    {"no_check", 0x4d5ed18691d413c1ull, 0x8be56b92fe199359ull, 0x688bed870e514018ull},
    {"no_propagation_no_mean", 0xb65a58c30e0dd25bull, 0x57b1f87609f38b29ull, 0xa2d55d04b258bd9eull},
    {"half_pixel_window", 0xc791eae3ed4259abull, 0x8c84d8801fcb6035ull, 0x2fba44792a7af602ull},
    {"patch_4", 0x0fb968c2543c5b33ull, 0xfa19e60a91a746a3ull, 0x0fb968c2543c5b33ull},
    {"patch_12", 0xe58687d2b8ab11f7ull, 0x8fe4c21d9f76d67full, 0xe58687d2b8ab11f7ull},
    {"patch_7_variance", 0xf0a71d5cf7c7818aull, 0xf0a71d5cf7c7818aull, 0xf0a71d5cf7c7818aull},
    {"paper_posterior", 0x41043e7675935928ull, 0x45db639857a0fd35ull, 0x64917ea80a081617ull},
    {"twelve_iterations_variance", 0xd1a71b355ef07ebeull, 0xc2388cdd57359a5dull, 0x69f57af6f360733eull},
    {"strict_validity", 0xee90597dbc94c244ull, 0xbb3cc3fa82dd08d1ull, 0x94cead07075e13f2ull},
    {"tiny_sigma_s_variance", 0x14c82396c8bc4e00ull, 0x89ad54450bf0ba6bull, 0x04e34a919fd0abeeull},
    {"coarser_look_variance", 0x2a50199ff2ee76caull, 0x3125de2354956b38ull, 0xc0958f44c9237ee0ull},
    {"gain_compensation", 0xe1e8af6c8bf0b536ull, 0x7102740138265c72ull, 0x6405ca34454597ebull},
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
