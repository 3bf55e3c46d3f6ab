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
    {"balanced", 0x12ae5dc6c3e62433ull, 0x07522d0c582b0f6eull, 0x846ac17293b354adull},
    {"fast", 0xf2e507e1bb436ce0ull, 0xe939b2cf6112fd94ull, 0xa0956cfca5b95f85ull},
    {"accurate", 0x2abcc90ed2986484ull, 0x95e09861cce62204ull, 0x7742719a813ea23bull},
    {"balanced_variance", 0x19a850387cb76210ull, 0xb2849754349c9e4aull, 0x3c43899c7419b754ull},
    {"accurate_variance", 0x61573c8b7a0999b0ull, 0xf246705d71c9def7ull, 0x8eea22b414259d5full},
    {"finest_0", 0xa90f07c94d4a0933ull, 0xc35314cf82a56e97ull, 0x01b4bd3e95008d0aull},
    {"finest_2", 0x7b58ad8cf6b11464ull, 0xe144d60876237a6eull, 0x4b77618660f39fc7ull},
    {"levels_3_3", 0x60f666ac3062f5d2ull, 0x46554d40e0f75001ull, 0x45e4546c635b80a6ull},
    {"whole_level_search", 0x5d8e35b0fd3c92bfull, 0x0cc8a5850523e3daull, 0xd47d86e0393b88cfull},
    {"one_row_bands", 0xf5dcacb967bb2c84ull, 0xb32ed5ec38f87e18ull, 0x47f9e4ffe20e06fdull},
    {"no_check", 0xfff1db7fc647a555ull, 0x2bb63943c2d2ecb5ull, 0xb356d31ccf967dc2ull},
    {"no_propagation_no_mean", 0xe5291cda206bd5a2ull, 0xede31a8ca9514631ull, 0xb173ad98bbf206f1ull},
    {"half_pixel_window", 0x00de5ad71703ee4dull, 0x9e017907138c77e0ull, 0x0d1d5dd53470aa4dull},
    {"patch_4", 0xd91b53e3201f2eacull, 0x07e41603d9b6cdffull, 0xd91b53e3201f2eacull},
    {"patch_12", 0x788b7012c129eac4ull, 0x65a861d1089db122ull, 0x788b7012c129eac4ull},
    {"patch_7_variance", 0x14ba546d1dd349adull, 0x14ba546d1dd349adull, 0x14ba546d1dd349adull},
    {"paper_posterior", 0xd3777967402703e3ull, 0xec9ec7083c256808ull, 0x1ee3c0faf94c97e4ull},
    {"twelve_iterations_variance", 0x9f71a4bd22a6c3b3ull, 0x0a11228bd45446d3ull, 0x664094a8188e735bull},
    {"strict_validity", 0x1af5fadf683ca7b8ull, 0xb442c4386e4adea2ull, 0x989f1945383036a0ull},
    {"tiny_sigma_s_variance", 0x3924e9f3181457ccull, 0x34c9acb0cca3c4b4ull, 0x76aaf2f8b8bb2067ull},
    {"coarser_look_variance", 0x5e374eab792b193eull, 0xd9f6babd0fe7cb0eull, 0x08d3f68aa084dac2ull},
    {"gain_compensation", 0x66aeed0a5d99e0c3ull, 0xfbf87b675fa6d1b3ull, 0xff85d6dd8a8463c4ull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0x46c6aba3dd8a20f5ull, 0x4540c45f1c42710bull, 0x36c1ce10fb3a0260ull},
    {"fast", 0x89373f75e3a19cc5ull, 0x25d965aabf14ef62ull, 0x4e493f17c28e8e4cull},
    {"accurate", 0x376df20f546b0b91ull, 0xdbe4bfacf306cf7full, 0x12c0137df38b8602ull},
    {"balanced_variance", 0x0bdeee05cdd1f44dull, 0x58deaa6026ba26d6ull, 0xf5d77e1722bbc709ull},
    {"accurate_variance", 0x799250a7433eea93ull, 0x9ecd06ea058f93b2ull, 0x70d60e4f640bb66eull},
    {"finest_0", 0xbf6087541b37c59dull, 0x9159f5fa4cd1cc30ull, 0x6286333c7d319490ull},
    {"finest_2", 0x2ef565b19df17339ull, 0xabe615327e4e7ed9ull, 0x4dc230ee356a1e82ull},
    {"levels_3_3", 0x0bc38816d5d66ca1ull, 0x6e8386be991dc272ull, 0x2a55781c7d613f81ull},
    {"whole_level_search", 0x648f226ca398bdf7ull, 0x9e4816e9e017d8c6ull, 0x0e9b8f5c04022f3cull},
    {"one_row_bands", 0xa79b173facdcff05ull, 0x9f9b95f096550987ull, 0x3f9ff7356ad22f6eull},
    {"no_check", 0x39833d1087f97168ull, 0xb9061124a9b31be3ull, 0x4dae4598ef14fb20ull},
    {"no_propagation_no_mean", 0x2c5bc978fac00159ull, 0xbf78e810e4665256ull, 0x4905ea6f7dbbba69ull},
    {"half_pixel_window", 0xfc04805233da7010ull, 0xaa8a736dfec142b4ull, 0x34432ed47aec561bull},
    {"patch_4", 0x6ea0e7c31c7fca72ull, 0xd4dd8f5d058232c9ull, 0x6ea0e7c31c7fca72ull},
    {"patch_12", 0xe3253095e34e4483ull, 0x20d6eaf2af8b0157ull, 0xe3253095e34e4483ull},
    {"patch_7_variance", 0xfc2e9c6084e71ffcull, 0xfc2e9c6084e71ffcull, 0xfc2e9c6084e71ffcull},
    {"paper_posterior", 0xdd72aac301255161ull, 0xae381ce4dbbbb540ull, 0x35ed71bd1c7a89b0ull},
    {"twelve_iterations_variance", 0xd91b7d45479cccd8ull, 0xb7bcd30eda528bf7ull, 0x6f0dd551830fb990ull},
    {"strict_validity", 0xcd78e1e3bd1659d6ull, 0x5309023e6d4bffdcull, 0x3700f7eb8a5367cfull},
    {"tiny_sigma_s_variance", 0xd330799500c9caefull, 0xa9b5513ecf364b12ull, 0x5cc48d316c135fceull},
    {"coarser_look_variance", 0xf901b5b8b6db704eull, 0xa3e59371d579830bull, 0x4e0fdcaaea5be073ull},
    {"gain_compensation", 0xf1f2f5a5e2454286ull, 0xc8a5bc4faa17c593ull, 0x78c169fd6ac86dc3ull},
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
