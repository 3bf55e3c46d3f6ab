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
    {"balanced", 0x0ef3ae33e598c748ull, 0x20d8de5efdf38addull, 0x0e3655429fb1f1e9ull},
    {"fast", 0x144c36cf81a37ca0ull, 0xc7065e7907434670ull, 0xfc0deb3c837a9b49ull},
    {"accurate", 0x8559f8179c0966ecull, 0x1aeebde4a7c4a35bull, 0xbbe90fa33a9301f3ull},
    {"balanced_variance", 0x9fb4d87ff35004e2ull, 0xfc4f352bdd292d8full, 0xb0cd99aec5a8e256ull},
    {"accurate_variance", 0x2e1b6c1e3930e2c2ull, 0x298baf080d76d571ull, 0xdcd9f1e99b34a22full},
    {"finest_0", 0x7cb28c076fa6cfe7ull, 0xeb01b1d92d39b57cull, 0xf3191a9cf719af3full},
    {"finest_2", 0xa1fa8c13b25158d9ull, 0x3ac0c909ee31bc0bull, 0x423aee36f7195c1cull},
    {"levels_3_3", 0xfa45c6090d13ef94ull, 0x5829a46bf7f8360aull, 0xf90d3f78178bd13dull},
    {"whole_level_search", 0x252665e8f724e508ull, 0xf8e03177c2aef2c3ull, 0x20cd7b84a1e33c75ull},
    {"one_row_bands", 0x484dce5ada2fa7acull, 0x5c19b2bfa3d9cfb9ull, 0x79f78b60aff80180ull},
    {"no_check", 0x13da1c6a2f4f96f9ull, 0x8f188a136b94e076ull, 0x0c1aa69d8f9a63dbull},
    {"no_propagation_no_mean", 0x4576fa3bebb27989ull, 0x7f857273d80aaf0cull, 0x11db03f0c80fd1dfull},
    {"half_pixel_window", 0xbaa0c9680bb30a37ull, 0xc957fd16f954ca1eull, 0x46f9ab996e0ee1b2ull},
    {"patch_4", 0x847ef7a4aa420d4full, 0x769d77564babdf4aull, 0x847ef7a4aa420d4full},
    {"patch_12", 0x8fb911d99a650f83ull, 0x15b4c44cc43fdb5cull, 0x8fb911d99a650f83ull},
    {"patch_7_variance", 0x9e57579e2fc3181dull, 0x9e57579e2fc3181dull, 0x9e57579e2fc3181dull},
    {"paper_posterior", 0xcb5af6c378c21984ull, 0xf63d756064cc4dbcull, 0x5298c0afc44be308ull},
    {"twelve_iterations_variance", 0x831782320f98d602ull, 0xb8b4dc0166953db0ull, 0x3a79d4f437e04a9aull},
    {"strict_validity", 0x4a6cfdecac86401bull, 0x1f55a3f65ee42fe8ull, 0x930405f6f21f94d9ull},
    {"tiny_sigma_s_variance", 0x078e38fdcce1699dull, 0x8f27005afeab4179ull, 0x55a33bb03b9d5f41ull},
    {"coarser_look_variance", 0x8bf87d157a19bec0ull, 0xe4979e00d2c8b1e4ull, 0x4d3e681989ea98b7ull},
    {"gain_compensation", 0x46ad3f54a8057d0dull, 0xef1c99801933e51aull, 0x8b10e1d41237a1fcull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0x06555a39048ea798ull, 0x1180414d5128bd80ull, 0x26342a92e9d0b0b5ull},
    {"fast", 0x1ed193c22c74f269ull, 0x327be24edda666cfull, 0x1f27239306e5108eull},
    {"accurate", 0xc8364517ffb2d02bull, 0xcf07e3e274d11148ull, 0x89ed58a32a7ee6adull},
    {"balanced_variance", 0xe2e59dbb02201ebaull, 0x8cde4e8dfb051f37ull, 0x172e96c86c8016ffull},
    {"accurate_variance", 0x8adad1b1486d1f59ull, 0xc19ba319f36dfc00ull, 0xd2a8f85adb34c57full},
    {"finest_0", 0x17cb541962b2e4bcull, 0xfb277dc11e047675ull, 0x32ca5b43b99384faull},
    {"finest_2", 0xe1978dce16282ca3ull, 0x934cfdb524a9e93bull, 0xfeefa7e9f1b802cfull},
    {"levels_3_3", 0x7e99089afd546a8cull, 0x243ca77067860072ull, 0x8daa17c7af1fc854ull},
    {"whole_level_search", 0x453eca01baf80232ull, 0xf24b8dbf9c0aef7dull, 0xff3b4dfcd1c8e058ull},
    {"one_row_bands", 0x8903ddaaea274189ull, 0x9b0eef1110662890ull, 0x0ab32754a0538cb2ull},
    {"no_check", 0xc5d85d7e7e8bb096ull, 0xc3f04318d1cdd05bull, 0x3541aa7690e84008ull},
    {"no_propagation_no_mean", 0x6b74710f1c5d306bull, 0x9a565272739ae288ull, 0x6b7aa8d154036683ull},
    {"half_pixel_window", 0x7143a1d62595d695ull, 0x0dcf9667939e2a13ull, 0xe542fbb29efdd93eull},
    {"patch_4", 0xfcb6730b496cc1cdull, 0x9e566ff88aad9293ull, 0xfcb6730b496cc1cdull},
    {"patch_12", 0x7eb1aa01479d8d8dull, 0x71840c4ada5491d0ull, 0x7eb1aa01479d8d8dull},
    {"patch_7_variance", 0xca22a8ee78e2d5c1ull, 0xca22a8ee78e2d5c1ull, 0xca22a8ee78e2d5c1ull},
    {"paper_posterior", 0x143352876ee95cdcull, 0x9d8220ba2ba7f9b1ull, 0x69673d278ba259a2ull},
    {"twelve_iterations_variance", 0x3275e7b6da3d413dull, 0x20f2f2af21ad583aull, 0xde7fa2bc3479a2dfull},
    {"strict_validity", 0x582bfe1dabb6b1a5ull, 0xb92fde7a04022dceull, 0xc659127ad0e46f06ull},
    {"tiny_sigma_s_variance", 0xa4763e26e82dd363ull, 0x61d3cc087c021578ull, 0x276afa40c809f51dull},
    {"coarser_look_variance", 0x6b71258d9342ec62ull, 0x0c8b2b9514b5fb83ull, 0xc3f853451126a6f8ull},
    {"gain_compensation", 0xd91fea6d80b7fb36ull, 0xabb98b35f9c973b3ull, 0xd97fa0309a315696ull},
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
