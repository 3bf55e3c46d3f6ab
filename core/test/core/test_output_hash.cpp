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
    {"balanced", 0x8c29ce4ac5e040a7ull, 0xf60bb1d85cef821bull, 0xe7a5eb9fa5548a41ull},
    {"fast", 0x6357bcfbe8bd81eeull, 0xd11f2299ee977525ull, 0x3cd18d46a92b7e5eull},
    {"accurate", 0x84659f078e789293ull, 0x09835320f012c6f1ull, 0xfe0b3f376e112fd0ull},
    {"balanced_variance", 0x9719e7969720f684ull, 0x78c171ba8efee393ull, 0xa7ade1e20fca3b40ull},
    {"accurate_variance", 0x0987cb834f6eaed0ull, 0x467c24e98fcc5bbfull, 0xa9f536c39f893e97ull},
    {"finest_0", 0x1e7da0c24db14162ull, 0xe2d14dec5614f73dull, 0x0d9d43c26a25dfb5ull},
    {"finest_2", 0x5a52924a68564186ull, 0xb603f017472baa27ull, 0x5eb276ce5d984caeull},
    {"levels_3_3", 0x4fd88a4f4d20f9daull, 0x4a023c55034452faull, 0x45d762b1893b66f1ull},
    {"whole_level_search", 0xb79edc7c33be72c1ull, 0xf9abbf7b94647ed8ull, 0x93326e74d2bfb7f3ull},
    {"one_row_bands", 0x79990c01b263122dull, 0x984ff163a69d8facull, 0xf7edc03666ad43cfull},
    {"no_check", 0xc60ca40639a7106dull, 0xb6d21253376958a3ull, 0xc6c62fb10aadc0f5ull},
    {"no_propagation_no_mean", 0xd016893d621b68ceull, 0x6b6fd0cfab3cd3a1ull, 0x4f5fbf1e2910ca3cull},
    {"half_pixel_window", 0x95499c66a1c06b13ull, 0x42c4e0f1cb891898ull, 0x1c30f8f44e2e6c46ull},
    {"patch_4", 0xbfc9cd48c742f9bbull, 0x4753333c8ac930beull, 0xbfc9cd48c742f9bbull},
    {"patch_12", 0x66f3801be9332467ull, 0x7f9044be554887b4ull, 0x66f3801be9332467ull},
    {"patch_7_variance", 0x31037ccb836882b5ull, 0x31037ccb836882b5ull, 0x31037ccb836882b5ull},
    {"paper_posterior", 0xe992208456fcd3f6ull, 0x1e08da1d3f80c897ull, 0xc6f1a9a5df904542ull},
    {"twelve_iterations_variance", 0xeba31b1a0cf20555ull, 0xfec10824b3519621ull, 0x997876459cb908daull},
    {"strict_validity", 0x28f7c1a817f2bbc7ull, 0x29a984110e38ec88ull, 0xbe67b6e806787325ull},
    {"tiny_sigma_s_variance", 0x8dafccef82058e26ull, 0x01af51dd1eb9f750ull, 0x2b86ed6f69a0e899ull},
    {"coarser_look_variance", 0x781bef7cbfd89683ull, 0x54fbf01ae25405f5ull, 0x327bd7fb4d8f7be1ull},
    {"gain_compensation", 0x356ace2b8b3ec0c5ull, 0x47dcc1e4a396e78aull, 0x9750896e06a7b30dull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0x5db20881f8273adbull, 0xe5e368467f86d282ull, 0x9a3bbc22f2a98613ull},
    {"fast", 0x14178041ae7dc5adull, 0x2b0bf1118b09ffcfull, 0xf3b4ca42368e9eebull},
    {"accurate", 0x57a296ae482ba27bull, 0x64cfb7435d358df4ull, 0x11bff0fcfecf7a88ull},
    {"balanced_variance", 0x63b51d001ec6f43eull, 0x7dca0d3684923f25ull, 0x0f251f76b4d3f64bull},
    {"accurate_variance", 0xb292aa4928b7dba2ull, 0xe053ae5ff723e433ull, 0x9197e54254e9d57eull},
    {"finest_0", 0xaf565d68b59aafc9ull, 0x1197d38799939f6cull, 0xf7be19d3efa2e589ull},
    {"finest_2", 0xb1fa10963c2b4f26ull, 0x666cbd0e475ee387ull, 0x60f3bd00a9d9b756ull},
    {"levels_3_3", 0x912a2b03be9cb905ull, 0x66a0eb8a028681c0ull, 0x08c38adf516f4776ull},
    {"whole_level_search", 0x01fdc5e1bf147c40ull, 0xb49faf9f3ad8bca9ull, 0x878ea2d9f6ef958dull},
    {"one_row_bands", 0xa255da663f8eee44ull, 0x9e1a16bfd9179bc2ull, 0x0d363f77fd058a3cull},
    {"no_check", 0x05b3ebd89392ea7eull, 0x404c8862d00f8062ull, 0xa49051b2266ade91ull},
    {"no_propagation_no_mean", 0x26443b88408c3386ull, 0x8149fc62d64f1621ull, 0x84ab6858c514ca3bull},
    {"half_pixel_window", 0x37f5ab11c1cc8d06ull, 0xc30b4ba704a973ffull, 0xa0dec277c86fe7d4ull},
    {"patch_4", 0x299934c7099a6296ull, 0xca12c04a3152126dull, 0x299934c7099a6296ull},
    {"patch_12", 0x3b85cc8f20b3a219ull, 0x64acc29757db8323ull, 0x3b85cc8f20b3a219ull},
    {"patch_7_variance", 0x6417b544bb3a6221ull, 0x6417b544bb3a6221ull, 0x6417b544bb3a6221ull},
    {"paper_posterior", 0xf3672d6c5dc2ccedull, 0x50cb0ef77b8bae95ull, 0xf3ef8aefbe030f16ull},
    {"twelve_iterations_variance", 0x2639f32e9db28342ull, 0xe6388fb13f5dbf3full, 0x6cf01c39716aa747ull},
    {"strict_validity", 0x373c088c542f8a9dull, 0x795d686e76a7766eull, 0xea074e0438d730f7ull},
    {"tiny_sigma_s_variance", 0x84a50634d5509c64ull, 0x8016212c2b3dc55full, 0xccb576d7cc11160bull},
    {"coarser_look_variance", 0x02427a4e082dff4bull, 0x6ceb2c1ed05c545bull, 0x7d6dd7ae556cb37dull},
    {"gain_compensation", 0x8590a92abe4f3260ull, 0x6e0d80b4f4d8d924ull, 0x5601ef8ee098f1a8ull},
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
