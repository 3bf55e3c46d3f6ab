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
    {"balanced", 0xfaefb94025c253faull, 0xd6d63d147fc46f86ull, 0xd203d139668c5303ull},
    {"fast", 0x73e270853c34985dull, 0x1e09b4c6c30c28f5ull, 0xe95275e673b7e5ebull},
    {"accurate", 0x3d7f0ede7679d726ull, 0x50db9cd8b85a9ad3ull, 0xeba64491c9158dddull},
    {"balanced_variance", 0xbacb2fb06e8dc803ull, 0xf6d1adce9e8025a3ull, 0x5ed73d1e2325b6feull},
    {"accurate_variance", 0xfc2e90d76f0cdfe7ull, 0xdbac9738f79f3027ull, 0xb5eaa853da792261ull},
    {"finest_0", 0x3545b37ab9dfd632ull, 0xc2c0df40d73a3ad6ull, 0x7360789c144f9162ull},
    {"finest_2", 0xf6afe5962c2acf67ull, 0x88d165a5ca70240full, 0x72b4eaddb44cef0aull},
    {"levels_3_3", 0xcf6435b00e275cf9ull, 0x133271a6825459d1ull, 0x1dc94a90017f1e51ull},
    {"whole_level_search", 0xc6d5671f9b6f146full, 0x9e79207d3eccc14full, 0xfc6425eb5cabc6fbull},
    {"one_row_bands", 0x38756ed8cde47f86ull, 0x4fffddd54bb29f0bull, 0xed0a548d051843caull},
    {"no_check", 0xe6da9528abab3589ull, 0x37989120dc851f9bull, 0xae1cfcfd0abbb6d5ull},
    {"no_propagation_no_mean", 0x78267f7f8f055a7dull, 0xfc546668c20ee9b7ull, 0xf1d14b2d5f2ead14ull},
    {"half_pixel_window", 0xb87b09bfdfcbfba7ull, 0xa6d5f30759b98385ull, 0xf8d352187e92ba1full},
    {"patch_4", 0xaf05fb51bee9f739ull, 0x993b8f2e14ee5f02ull, 0xaf05fb51bee9f739ull},
    {"patch_12", 0x4b171e0a13cc2420ull, 0x09eb713b55d1d9bbull, 0x4b171e0a13cc2420ull},
    {"patch_7_variance", 0x3e9e39b5e4b93f6eull, 0x3e9e39b5e4b93f6eull, 0x3e9e39b5e4b93f6eull},
    {"paper_posterior", 0x87e8a6dbcff3ce1aull, 0x56a179471fab7529ull, 0x4424838f16434ff8ull},
    {"twelve_iterations_variance", 0xd90a492aa319df47ull, 0x7b451688012fbc58ull, 0x5562b1a5be6b831bull},
    {"strict_validity", 0x54b7601030db8765ull, 0x1019a48882497911ull, 0x1bfeacd6342b8819ull},
    {"tiny_sigma_s_variance", 0x1ad9d385ea57d26full, 0x20cd3ae22350a281ull, 0x3298ea0a3372c1fcull},
    {"coarser_look_variance", 0xfe1cb438a32eb780ull, 0xc16c7e91db06ca92ull, 0x8324e97ff1ad9ae7ull},
    {"gain_compensation", 0x7c6ef3c1ec55ca35ull, 0x3d0a063dad2718b1ull, 0x86b5d01281199b0cull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0x3a7ba05956f3217aull, 0xf47941b560c62ecdull, 0x0424709f0b4cd01aull},
    {"fast", 0x26022e1f8f74af87ull, 0xe0c593cd8425bf18ull, 0x45e9b0955dfb37c8ull},
    {"accurate", 0xe22087c2520bd8c6ull, 0x941826c4754c88daull, 0x08945204ad716887ull},
    {"balanced_variance", 0xe7fc7cf07e24d52cull, 0xeac0a6ac0dd9dcefull, 0x56f47cebe5ff9670ull},
    {"accurate_variance", 0x2b7dfcea60fcf304ull, 0x449f7da7a3a2300aull, 0xebc5dc56898ce449ull},
    {"finest_0", 0x5e032002151ce0ceull, 0x6f504fc56fc93afdull, 0x4ac6968956c8c375ull},
    {"finest_2", 0x06400644dfb9f5e4ull, 0xeb4287fed3d06576ull, 0xe47dac48cf597a6cull},
    {"levels_3_3", 0xca2a63e935676254ull, 0xa227eabb58ea3694ull, 0x7298aaab48cf80c3ull},
    {"whole_level_search", 0x63f007e67bf340e9ull, 0x98e1012c35f0c934ull, 0xd830f6d6be361a86ull},
    {"one_row_bands", 0xf9df9aa92b956faeull, 0x4761d04172d28583ull, 0x3ecb4367606a5a7bull},
    {"no_check", 0xd49be7e4b28c5ef9ull, 0x0ad6e982ec3cca21ull, 0x9a6072867dcdd8d9ull},
    {"no_propagation_no_mean", 0x70a26de8dc99db4full, 0x3d9b6fcccbf5b737ull, 0x55303f5b271a8ef6ull},
    {"half_pixel_window", 0x42bb70a160a94c7full, 0x81a483e86be3759dull, 0x6b430a888224ea56ull},
    {"patch_4", 0xdb55fe691b8bdf73ull, 0xc04d9cd01115f57aull, 0xdb55fe691b8bdf73ull},
    {"patch_12", 0x1a500ce755381a2dull, 0xb067e809e5204e1dull, 0x1a500ce755381a2dull},
    {"patch_7_variance", 0xd552180a5cf58a00ull, 0xd552180a5cf58a00ull, 0xd552180a5cf58a00ull},
    {"paper_posterior", 0x54f3705688b1eb4aull, 0x1a4093f77a763bd9ull, 0xc6c5a0e820d41c6full},
    {"twelve_iterations_variance", 0x95fc47a8e04985faull, 0x3877048712963e03ull, 0x813349a54e369dc1ull},
    {"strict_validity", 0xcbcad0e4412e446aull, 0xf734dced65b2e767ull, 0xe67306ae1381127cull},
    {"tiny_sigma_s_variance", 0xd0fb9c23476ad67dull, 0x17490ef9c2e927e7ull, 0xd52cf51f375fd437ull},
    {"coarser_look_variance", 0xa887517683905decull, 0x91f0ea7a279ad552ull, 0x8a54e01f5bc1a0a7ull},
    {"gain_compensation", 0x55f973d554a1a072ull, 0x438a5050c3e4abe2ull, 0x6abbbb7fa9973e02ull},
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
