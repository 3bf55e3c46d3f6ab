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
    {"balanced", 0x08a0c0fb02f7a49eull, 0xb608b743c0771718ull, 0xe7a5eb9fa5548a41ull},
    {"fast", 0x7d634741cc9f918eull, 0xe96d3f95eac5c900ull, 0x3cd18d46a92b7e5eull},
    {"accurate", 0xcce40e2d8afebb10ull, 0xb7fac651675f0ae2ull, 0xc0830e0acf480affull},
    {"balanced_variance", 0xfc13e57513294f08ull, 0xc75bff1344e9511dull, 0x6af5db62902753efull},
    {"accurate_variance", 0x5d94687db7fbcc38ull, 0xe5b8d2473485c461ull, 0x5326daceaf2500efull},
    {"finest_0", 0x3d840e1ad657c389ull, 0xfb8fb7e433453a9cull, 0x33bf5cb8e1956f37ull},
    {"finest_2", 0xfca306098104530aull, 0xb603f017472baa27ull, 0xe37210bf1af42956ull},
    {"levels_3_3", 0x4fd88a4f4d20f9daull, 0xcf83d6428a48863full, 0x6f4ea21e08abcce4ull},
    {"whole_level_search", 0xbde74693274ef9c8ull, 0xdc7d4436c54d26f3ull, 0x93326e74d2bfb7f3ull},
    {"one_row_bands", 0x6345d777c1a789daull, 0x17b3e0841a5a964bull, 0xf7edc03666ad43cfull},
    {"no_check", 0x8063da8684a50d65ull, 0x39fbfd50dbb68590ull, 0xc6c62fb10aadc0f5ull},
    {"no_propagation_no_mean", 0xeceeab6498729095ull, 0x95809f624b9c14b7ull, 0x3d8de74f8e2aeb0dull},
    {"half_pixel_window", 0x610139e45e681e8cull, 0xc028a300032b1a37ull, 0xdcd6ffbe860cc735ull},
    {"patch_4", 0x6dc3eb382f583a96ull, 0xea99c82133a5ef7eull, 0x6dc3eb382f583a96ull},
    {"patch_12", 0xb10ec5b5f82a8f94ull, 0x9c400eb7eeb54009ull, 0xb10ec5b5f82a8f94ull},
    {"patch_7_variance", 0xc0ffd50642de8475ull, 0xc0ffd50642de8475ull, 0xc0ffd50642de8475ull},
    {"paper_posterior", 0xbdd0b731cc38a26aull, 0x2a39675b586dc881ull, 0x958f9022ee83e02eull},
    {"twelve_iterations_variance", 0xd3fda87e67f9e872ull, 0x880f676fd26b3d38ull, 0x8c875a6a31afabfcull},
    {"strict_validity", 0xff9c23cc413e7f11ull, 0x04e942ead3677079ull, 0xbe67b6e806787325ull},
    {"tiny_sigma_s_variance", 0x613ac9d3770e9330ull, 0x7d124b22f448ae51ull, 0x65ab91f8e96e5ba3ull},
    {"coarser_look_variance", 0x3ff524d28ac1fe87ull, 0x069504e908363aafull, 0xade9843462846f6eull},
    {"gain_compensation", 0x31e2373e2684293cull, 0xdddf520dc5dc11b1ull, 0x417c13f449fa6dfdull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0x02825943b9daff93ull, 0x76815883265e5614ull, 0x1cfcd4ea9a153fa3ull},
    {"fast", 0x0a557a98aa230fc8ull, 0x93c873c90442f496ull, 0xee7043521d9f9716ull},
    {"accurate", 0xa6b96476608b5aa9ull, 0xd59872cfc40de24aull, 0xfd0aab7dd6626a59ull},
    {"balanced_variance", 0xf6b9aa4b2c2ae9aaull, 0x00b8e895e4456eb3ull, 0x88807fa2a7180b45ull},
    {"accurate_variance", 0x0659d79026203251ull, 0x9c31066f5f38783bull, 0x4be1814dae18629cull},
    {"finest_0", 0xdb4a32f65b1ffc8full, 0xecf5b56b501237d3ull, 0xd56c7eea595d2ba6ull},
    {"finest_2", 0xbc2526baea4ea1ebull, 0x2df90e485853f7d5ull, 0x8232f89c2da66447ull},
    {"levels_3_3", 0x6d75bba669bd9125ull, 0xe10b7b428f739f5dull, 0x50d420160f9ecdc1ull},
    {"whole_level_search", 0x605ccf7d86073421ull, 0x9241f5444e4fee93ull, 0xda29c7b36fe5b54eull},
    {"one_row_bands", 0x71f198ebb153eb12ull, 0xb491e58a723c6f68ull, 0x21c7e48c528cc668ull},
    {"no_check", 0x0f46112c42c7c8dfull, 0xc6a6f79cc24e42c0ull, 0xd1763006d78bffd2ull},
    {"no_propagation_no_mean", 0xcf03c20be16f85f5ull, 0xc2868a9ced8cf8a5ull, 0xa2ebdef022faeb56ull},
    {"half_pixel_window", 0x7dd40113b6f62b60ull, 0xb7c59b9544b44471ull, 0x5053fcd447300480ull},
    {"patch_4", 0xb0dfd5dd53b91048ull, 0x87bac464376a310eull, 0xb0dfd5dd53b91048ull},
    {"patch_12", 0x033d25ad1c424c43ull, 0x0f1603f307045ad6ull, 0x033d25ad1c424c43ull},
    {"patch_7_variance", 0x8ceab25c66537f30ull, 0x8ceab25c66537f30ull, 0x8ceab25c66537f30ull},
    {"paper_posterior", 0x113f12d80fa28630ull, 0xee3e01cb2a436446ull, 0xd911deb259ed1defull},
    {"twelve_iterations_variance", 0x03dfd68c7d1f90beull, 0x8d4f3fba94595d98ull, 0xc797768a8456b9f5ull},
    {"strict_validity", 0x26db4f9f783de892ull, 0x272381afa250d809ull, 0x4ad535ea5dfd17d5ull},
    {"tiny_sigma_s_variance", 0xad759b2244725383ull, 0x02ce026c5aba6da4ull, 0x21aae12770b51a67ull},
    {"coarser_look_variance", 0x8a73ef6b071ca72cull, 0x45b60b066b127110ull, 0xb5259b1e67fa5671ull},
    {"gain_compensation", 0x4f6ca583221c3fd8ull, 0xd32e970137f7654bull, 0xdaa81693c1a6762dull},
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
