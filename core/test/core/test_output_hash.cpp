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
    {"balanced", 0xb7fa4b000aa5ebeaull, 0x77049048ba999743ull, 0x3e16984ba52525b8ull},
    {"fast", 0xc46fa819bec58a11ull, 0x3d61495d4211b15full, 0xdd1e94577a8ec66full},
    {"accurate", 0xe77cb34f516edcaeull, 0x9547b6ea5dec555aull, 0xce90f852948715edull},
    {"balanced_variance", 0xeff881f993cfe12bull, 0x7eef672f000bfc7eull, 0xf74960120b4f8b44ull},
    {"accurate_variance", 0x298bdb99d4062339ull, 0x07ff6e7c5a8be9e8ull, 0x597a10f2bce99124ull},
    {"finest_0", 0x69f72a033fb46e49ull, 0x78f73380ac919ee6ull, 0x52fde49f5df11aa0ull},
    {"finest_2", 0x9776d25c5cf4197aull, 0x2c4b72da11b6629bull, 0x098d9f8486681cfaull},
    {"levels_3_3", 0x9bf9c494f0a0abe6ull, 0x4f825851087ad26bull, 0xcb6863505f2a3090ull},
    {"whole_level_search", 0x88a61ba3646f6c47ull, 0x23d11ac40d5aececull, 0x2ea53d08f97b33b8ull},
    {"one_row_bands", 0xa955128bb456de21ull, 0x1b1446b2660d0a3bull, 0xacd8af2080c89bceull},
    {"no_check", 0x56b79bc77360d6e0ull, 0xe34fe6e457d90507ull, 0x34564c762d1543f8ull},
    {"no_propagation_no_mean", 0x456961578f8a01fbull, 0x0b7a113783b7fdc4ull, 0x45d6aae64917c611ull},
    {"half_pixel_window", 0x47acb51963cde385ull, 0x1b2b862278190e18ull, 0x84a5f2ac16a960b7ull},
    {"patch_4", 0x9b01d6e393266b73ull, 0xb5e049d9d2047f5dull, 0x9b01d6e393266b73ull},
    {"patch_12", 0x256ca3655ee68a50ull, 0xb9fb38e9672a7968ull, 0x256ca3655ee68a50ull},
    {"patch_7_variance", 0x2f5d43483a5e5076ull, 0x2f5d43483a5e5076ull, 0x2f5d43483a5e5076ull},
    {"paper_posterior", 0x9d17680040e22761ull, 0x2d2a7e3fcc01357cull, 0x67134de88ea8384bull},
    {"twelve_iterations_variance", 0x71d1c483135a98e1ull, 0x60e440e70a65179bull, 0x057711e92f531da6ull},
    {"strict_validity", 0xd616ae11309eaf1full, 0x9e91fd0570eeae46ull, 0xaeedd605eb98da34ull},
    {"tiny_sigma_s_variance", 0x1c7b662334cb4532ull, 0x05d3ddf5c5814dc4ull, 0x154dc25674bd7b89ull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0xe5e6423acf3692c3ull, 0xcc2aedbe78cb0589ull, 0x05e8f5d6910ab7ebull},
    {"fast", 0x25a172d0bf755dcbull, 0x119c2fc26d0029f0ull, 0x5db7e960b5eac656ull},
    {"accurate", 0x04bd762999148ec3ull, 0xb6cbf0d17fcb5ba8ull, 0x921295a526d59784ull},
    {"balanced_variance", 0x76e75eb2e44bd88aull, 0x0f4cd603a271605aull, 0x7e7d3557bda53539ull},
    {"accurate_variance", 0x33c5b766df9130d1ull, 0x0dafa32c9afcad2aull, 0xa171397f9835181aull},
    {"finest_0", 0x656d68ae3bf3b758ull, 0x9a61577f7e278462ull, 0xd4f165b5d937eb10ull},
    {"finest_2", 0xa0ae2e161f2c814cull, 0x12c8a16408c91698ull, 0x6c0c0cefb3caf50dull},
    {"levels_3_3", 0x5535a5676264e6b0ull, 0x46f38ec9c6cc29a7ull, 0x86e0d6140289a93eull},
    {"whole_level_search", 0x70e3e64ebc446bc9ull, 0x351fcb7012a672aaull, 0x3b666dc4e50eb471ull},
    {"one_row_bands", 0xeaca99e23723394aull, 0x026486dfb30fb327ull, 0x8e05ed56713eb373ull},
    {"no_check", 0xfc9526ae728d98aaull, 0x9827a6fdca87cc6aull, 0xcc1a656fe8dcf17full},
    {"no_propagation_no_mean", 0x5a815ef018cdf6e6ull, 0x42bf99e24e09392eull, 0xf2d96fa6309a916aull},
    {"half_pixel_window", 0x11f6db8ee92372eaull, 0x98b2712c4e379c5full, 0xd242e88f382b3b08ull},
    {"patch_4", 0xdff54607afacf047ull, 0x47097e327b3c4716ull, 0xdff54607afacf047ull},
    {"patch_12", 0xaab30cc15c7c940cull, 0x928b9b4d89723b05ull, 0xaab30cc15c7c940cull},
    {"patch_7_variance", 0x77a79dd03c11fdaaull, 0x77a79dd03c11fdaaull, 0x77a79dd03c11fdaaull},
    {"paper_posterior", 0x560d6e405ff03433ull, 0x93ec6e7d9ac6e633ull, 0x39902a781c3ea90full},
    {"twelve_iterations_variance", 0x4ad6ee1487f14956ull, 0x1350a53d18bad5aaull, 0x8cfd6aba4acb81bdull},
    {"strict_validity", 0x0b78ebcb38c2a128ull, 0x7c1e1484305a9459ull, 0x772b9e5d897042daull},
    {"tiny_sigma_s_variance", 0xfd66c393d3fdd001ull, 0x61d43d63ee14860full, 0xf1af1b47c59d74f3ull},
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
