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
    {"balanced", 0xc5e84116e2359b79ull, 0x3ef6762c55a29ed5ull, 0x72f520b01d9073fdull},
    {"fast", 0xf1d80caecac8108cull, 0xadf2e812a5ac5898ull, 0xa7ac0459548d1197ull},
    {"accurate", 0x690928a85e463f51ull, 0x46e6ce568d39ea2aull, 0x5143de1b0fa7c631ull},
    {"balanced_variance", 0xc133567b5eb8d4cfull, 0xb1897625889b9754ull, 0x87e39a262e3cffcfull},
    {"accurate_variance", 0xc10c3d337a2fd52dull, 0x783adfc580514749ull, 0xe00377c4e696e96dull},
    {"finest_0", 0x939e12cd6d31f87eull, 0x5bdc023ce10ee281ull, 0xa7dc81c06915331cull},
    {"finest_2", 0x168d2201a6b022bdull, 0x1639a8eed06b2926ull, 0xc2b27a60c391c81bull},
    {"levels_3_3", 0x4fd88a4f4d20f9daull, 0xcf83d6428a48863full, 0x6f4ea21e08abcce4ull},
    {"whole_level_search", 0x773e002efc40db67ull, 0xa53af5e868878737ull, 0x1d8338fd21d14451ull},
    {"one_row_bands", 0x37e6059e482c6159ull, 0x6e4b44a0e6117793ull, 0x36e40cd55952ad0dull},
    {"no_check", 0x865554aa2f793d6bull, 0x9c62367162e7a1b1ull, 0x814491c3849de28cull},
    {"no_propagation_no_mean", 0xcc12a22bbeb01866ull, 0xa7b0099f89b91df3ull, 0x54173d6cb9d9bd7cull},
    {"half_pixel_window", 0x8219b33183b9a0e9ull, 0xb264d7d28ca9a8b6ull, 0x20ae53d3a7b715b0ull},
    {"patch_4", 0xec964672f36e04c4ull, 0xef145a88db2e873dull, 0xec964672f36e04c4ull},
    {"patch_12", 0xb90602791b932222ull, 0x9677afc7108a0194ull, 0xb90602791b932222ull},
    {"patch_7_variance", 0x92661dc5e2ee1494ull, 0x92661dc5e2ee1494ull, 0x92661dc5e2ee1494ull},
    {"paper_posterior", 0x249b2df0b1357fddull, 0x519c131ae157c314ull, 0x480b3554d724cb70ull},
    {"twelve_iterations_variance", 0x216c0ecf4ac7612cull, 0x005b50566db31fb5ull, 0x149b7f5ecbde4b16ull},
    {"strict_validity", 0x000eb6a97c9e706cull, 0xd7e51c9703d7cea9ull, 0x4c156922eaca351aull},
    {"tiny_sigma_s_variance", 0x6eea4f570af6a75bull, 0x0116c9d972bc534bull, 0xce5524cbf471cb99ull},
    {"coarser_look_variance", 0x63c79e0b1502ca06ull, 0xbe088850d147a009ull, 0x92d0fdd5d899a606ull},
    {"gain_compensation", 0x4e92fe552e55c8f5ull, 0x41f1714d0e368948ull, 0xe1383a42209810a6ull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0x4456bb43bbe1d857ull, 0xed26592572eee545ull, 0xcaf2ac1e9320ab8aull},
    {"fast", 0x4d67689aa356f876ull, 0xd361f0c751d6d080ull, 0xa54ef1d7863a3e53ull},
    {"accurate", 0xc869060270cc22b1ull, 0x09411416c3bcb70dull, 0xdb1722aa8b82125aull},
    {"balanced_variance", 0xf3ecde922b2577beull, 0xc3b9dfce9973d3beull, 0x62855087f08678a4ull},
    {"accurate_variance", 0x40cf3174367d2f69ull, 0x266742a7606bb3ccull, 0x3f190274d05b272full},
    {"finest_0", 0x138414953faa9bd5ull, 0x150363151cbbc264ull, 0xe603a49579dd8e8cull},
    {"finest_2", 0x79953534b9e07501ull, 0x3b864d429cfe9c19ull, 0xbb386bdd84ec8a99ull},
    {"levels_3_3", 0x19a621e6ae5af159ull, 0x015233808f022274ull, 0x4cd86ac14930af57ull},
    {"whole_level_search", 0x369cdad3e81ee9f9ull, 0x7a874be509426baeull, 0xc3456b2bd5af153aull},
    {"one_row_bands", 0xf8d7979e97c34f9eull, 0x39585c2596835ffdull, 0xbc02cc7fc7337779ull},
    {"no_check", 0x9030f9bd93995f7full, 0xa1cbef82409cfa79ull, 0x9f1009597fb05c6full},
    {"no_propagation_no_mean", 0x788320401811716dull, 0xc8d924b5eead3678ull, 0xa3c794057985615dull},
    {"half_pixel_window", 0x09173aaa2e98b4f3ull, 0x5bbae217b85448f0ull, 0xa227d45d18ed2598ull},
    {"patch_4", 0xf1ff1164a3c0e530ull, 0x7916f937b80528a7ull, 0xf1ff1164a3c0e530ull},
    {"patch_12", 0x41bf5faee3bd384eull, 0xc89a27b639b8abfbull, 0x41bf5faee3bd384eull},
    {"patch_7_variance", 0xda4f6018c78356efull, 0xda4f6018c78356efull, 0xda4f6018c78356efull},
    {"paper_posterior", 0x5ae75aeda02342dbull, 0xe0804ae1d8e58f8full, 0x79013b99fcd4c207ull},
    {"twelve_iterations_variance", 0x71e6f5ed0b7fc4edull, 0xef6421d1d5db5164ull, 0x5676f09d587ab628ull},
    {"strict_validity", 0x9f223625b7b2642full, 0xc22eeb60ac71e8bcull, 0xe860f8bf50be931aull},
    {"tiny_sigma_s_variance", 0x18ef9f684f4bc7feull, 0x44092bbb1c75f3f4ull, 0x721040c446d4bd98ull},
    {"coarser_look_variance", 0x4ea407abbce7fe9eull, 0x9f7a46203559b143ull, 0x9595990498e83aabull},
    {"gain_compensation", 0x84ede165a1391f55ull, 0x8e046b11bbf91943ull, 0xe123eda5816d0a48ull},
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
