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
    {"balanced", 0x8a0c72b67541355dull, 0xcb0029d8d76d8a71ull, 0x64c4714f00c2c7f6ull},
    {"fast", 0xda7bcf5d316d847dull, 0xa30560f77b50b4c2ull, 0x85ae4f8dccee9458ull},
    {"accurate", 0xe2b53b40cdad30f3ull, 0xd38458e6fecd40c3ull, 0x0ad90843bae36915ull},
    {"balanced_variance", 0x7a01818843c2d8c4ull, 0xbbb087038f622320ull, 0x187b7ed3c086f9ceull},
    {"accurate_variance", 0xae5825cf39fead98ull, 0x70a0547de91d3505ull, 0xb45ecc206e824064ull},
    {"finest_0", 0x3ead1ee65e7984e1ull, 0x3e4e9da59bc6198bull, 0xe50780a0b7c1f3efull},
    {"finest_2", 0x98877b0521b6c248ull, 0xeca8ef3c706ffc9aull, 0x7050961fe6f63fa6ull},
    {"levels_3_3", 0x7283e33b7da49025ull, 0x5b3b21db56552510ull, 0x8df8e0359a667337ull},
    {"whole_level_search", 0xf08064f16f2fde0eull, 0xe942a9104528372dull, 0x78bd3dda197d99d4ull},
    {"one_row_bands", 0x17c34db38ab80355ull, 0xe47aea8235013009ull, 0x45ef917921bec57eull},
    {"no_check", 0xec7e801086a1932eull, 0x1933dbdf0266f9a4ull, 0x4cfcc6981fbbe716ull},
    {"no_propagation_no_mean", 0xf0de93637cb4e646ull, 0x112808d3f92822f7ull, 0xb32a83e1a908ccd5ull},
    {"half_pixel_window", 0x52fc5ee76d53637dull, 0x8b8ab41dca09d4f2ull, 0x96d029eb1e39286full},
    {"patch_4", 0xb5275b5281f685eeull, 0xfbd8ec3661906cc0ull, 0xb5275b5281f685eeull},
    {"patch_12", 0x4400bab028941348ull, 0x99840e22adf53825ull, 0x4400bab028941348ull},
    {"patch_7_variance", 0x66a37907a62e3dcdull, 0x66a37907a62e3dcdull, 0x66a37907a62e3dcdull},
    {"paper_posterior", 0x9e7068d74de3252aull, 0xad52f8658903b75dull, 0xcc2db0c57a660ae0ull},
    {"twelve_iterations_variance", 0x06aea6d65d59b8a7ull, 0x46a433ebb3e293c3ull, 0x0cf5e22ab9ea9680ull},
    {"strict_validity", 0x8aebabfbf4118f3full, 0x89c9d7e9135f8cd9ull, 0x34144e8cc3611f55ull},
    {"tiny_sigma_s_variance", 0x6bc86d917626577eull, 0x9c6bb44d7b45dc6aull, 0xf6bb8b2b9a1bc0acull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0xb9d7290c07b5bcbeull, 0xfbc8c03528f4181eull, 0x3c8491648b3823abull},
    {"fast", 0x91bdc9b8042f5452ull, 0x00a60de31c575d53ull, 0xca2202f2b4d62cfaull},
    {"accurate", 0x618e910508e0b6eeull, 0x85b40f3226fc8147ull, 0x2df6eda7863ef565ull},
    {"balanced_variance", 0x4f1d3eead3ea2f5full, 0x2eb687ccc7f8c131ull, 0x442d88941c4af3d1ull},
    {"accurate_variance", 0x4779adf9ca318450ull, 0x5fdef22189a8d70dull, 0xfb815305ab43fd97ull},
    {"finest_0", 0xd80811fb16af1454ull, 0x435f157ff916bf3aull, 0x32d86023307db589ull},
    {"finest_2", 0xd82cc8afb3aac275ull, 0x9684d71533331060ull, 0x2dae7997fea78a2aull},
    {"levels_3_3", 0xad596109487ebe53ull, 0x55879b2b42c5e1c2ull, 0xfc9dd9f3113002a1ull},
    {"whole_level_search", 0x453452f3fec23cf7ull, 0x25fb5ee6d97a0726ull, 0x94ac9f58bc33b113ull},
    {"one_row_bands", 0xad9d4f3e1cfaec26ull, 0xe9f988dba7235fa0ull, 0x93732619115f9b06ull},
    {"no_check", 0xdbad88e5e29aa02aull, 0x93af7754dadfdf12ull, 0x674d4dfab5b76a70ull},
    {"no_propagation_no_mean", 0x9be854baac1b01f8ull, 0x7aab5aed84fe0d5dull, 0x49738506a3973f80ull},
    {"half_pixel_window", 0x2f032814bbab2345ull, 0xcd1b606b96a25f19ull, 0x288bc9e839e3f450ull},
    {"patch_4", 0xa6e73d1f2a4a19cdull, 0x36c969258cf03b17ull, 0xa6e73d1f2a4a19cdull},
    {"patch_12", 0xbcfd1ad2715befa4ull, 0x3599ec9fbc974d28ull, 0xbcfd1ad2715befa4ull},
    {"patch_7_variance", 0x51c2fe3f7a71cd01ull, 0x51c2fe3f7a71cd01ull, 0x51c2fe3f7a71cd01ull},
    {"paper_posterior", 0xe12d538727612b5dull, 0x5e3535acf27f9d25ull, 0x301f6fd62c796501ull},
    {"twelve_iterations_variance", 0xf06af26daf7be603ull, 0x84f7ee5e53a5ab01ull, 0x5d4ee6c815a44ccfull},
    {"strict_validity", 0x7e19716cf7512394ull, 0x14de38a3a267b55full, 0xf1fffd99f3e2cf76ull},
    {"tiny_sigma_s_variance", 0x1836d38516461a57ull, 0x5bf733e215d0346bull, 0x8279e9d454d4a5afull},
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
