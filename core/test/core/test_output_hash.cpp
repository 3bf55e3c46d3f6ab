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
      {"no_support_weights", [](MatcherParams& p) { p.support_grey = 0.f; }},
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
    {"balanced", 0xb850c7c7c29f4bd4ull, 0xb33ff7870a3d1f02ull, 0x4c7b5ac5234f40c2ull},
    {"fast", 0x1779ef0d3b15b1f7ull, 0x46efdbfabc575f6dull, 0xc052df676d64588full},
    {"accurate", 0xc91a18ef5d6c2a2bull, 0x535afb3eb106cac0ull, 0x11930cd929f162f2ull},
    {"balanced_variance", 0xe3c103048d7e68c4ull, 0x080c785a377a5d21ull, 0x7714435ca928f417ull},
    {"accurate_variance", 0xcfa026f17de76fe3ull, 0x620640d2c8e1b44full, 0x90e3f60c739c9a05ull},
    {"finest_0", 0xd2abf50b7fa4b124ull, 0x8c6516ff6112ec4bull, 0x13babd940aabde9aull},
    {"finest_2", 0x5b7a3c58dad4a943ull, 0xe879a1a88a33c34full, 0x8b8d1baeecb0cf0dull},
    {"levels_3_3", 0xa95c10149c8cd755ull, 0x4c08ca48b3c1b3c4ull, 0x3c27ca53ac1da27full},
    {"whole_level_search", 0x196d0cfdbca31b29ull, 0x2ff0471a1dd2397bull, 0xb733f7297b63b79full},
    {"one_row_bands", 0x4751e3fa95e643ddull, 0x26375c44abcb1bc9ull, 0xeb268236d1f75165ull},
    {"no_check", 0xf95b4a9b48cfa437ull, 0xc142c972288c1ce1ull, 0x24cc6fd11751694full},
    {"no_propagation_no_mean", 0x08d3e422b09dd0e2ull, 0x8dc905e0c010d6edull, 0xc26ad5967cdb723cull},
    {"half_pixel_window", 0xc7d7a512b218aabcull, 0xebe57ead37fd3143ull, 0x239dc4c2c996f025ull},
    {"patch_4", 0x759aa1dc7a247c0bull, 0x17a2b37d459caf39ull, 0x759aa1dc7a247c0bull},
    {"patch_12", 0x2cfd080183ee78ebull, 0x5c63400ac00637c9ull, 0x2cfd080183ee78ebull},
    {"patch_7_variance", 0xdccb94f6344b7890ull, 0xdccb94f6344b7890ull, 0xdccb94f6344b7890ull},
    {"paper_posterior", 0xbf11b1d3164d1fbbull, 0xb422e1cbe5aa63a6ull, 0xbba48b264dd4b8ddull},
    {"twelve_iterations_variance", 0xe1d6ebdd026762d2ull, 0xbeec6ee7e66ebe7aull, 0xb6715ef94b43ad9aull},
    {"strict_validity", 0x6e0b3ec5bf62f8aaull, 0x82531b7f791bd129ull, 0x3535dadc0936b187ull},
    {"tiny_sigma_s_variance", 0x08d659e00626d65cull, 0x47c11e88f149b87dull, 0x721272daeff6c790ull},
    {"coarser_look_variance", 0xc1b9e41c679f8687ull, 0xfbec424c75188745ull, 0x8b91c08cd58dbb08ull},
    {"gain_compensation", 0xb519d1aa32962221ull, 0x8ce93edf0fdd2c5dull, 0xcc92853b5599ad2bull},
    {"no_support_weights", 0xeb27a4efeb2d913eull, 0xee7eb80740665cf8ull, 0xa3f00f949f138668ull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0xc0faf317b79d796aull, 0x568ed9798aadfe6full, 0x9bfa36a19824ed38ull},
    {"fast", 0xf4666ddb2d641744ull, 0xc5edf326ff310596ull, 0x66d3ffbaa5f54174ull},
    {"accurate", 0xa86978002663dc46ull, 0xd8b2c6911018ffd3ull, 0x482f0d9370c931c5ull},
    {"balanced_variance", 0x9d2a698ffe76c364ull, 0xcf11b6902597f7e5ull, 0xbcacaf5f109489fcull},
    {"accurate_variance", 0x0455727a8f2880a6ull, 0x3635d3702d196eaaull, 0x58bf3af441e7fd9full},
    {"finest_0", 0xe0be906f592a23c5ull, 0x5f852a7499b07fc0ull, 0xb19bdc54de74f0dfull},
    {"finest_2", 0xc2ffccd38c83bdc3ull, 0x5552d361d433072dull, 0x70c9fe47c9584c41ull},
    {"levels_3_3", 0x3349b49e6e5a5a56ull, 0x10f05939c35cc7b0ull, 0x453be6ac7c2a5102ull},
    {"whole_level_search", 0x03b76baac5d78500ull, 0x4d85447c016c61b8ull, 0x3976597fb42668d8ull},
    {"one_row_bands", 0x255f8eee38f0f5b0ull, 0x09c7ccbfc94379e2ull, 0xc0eba84937f6b2d4ull},
    {"no_check", 0x3f37561cfbed0fb3ull, 0x487c0a85c52e6065ull, 0xcb33cb026cd91ef1ull},
    {"no_propagation_no_mean", 0x96910bb48114f348ull, 0x290a8c901042faf4ull, 0xbbef65900f8db72aull},
    {"half_pixel_window", 0xe4c34ed2ac907fccull, 0x632d170e300a2b26ull, 0xdf625e12b86c66bcull},
    {"patch_4", 0x315193d92866bc14ull, 0x6c6fd5a75fdd7193ull, 0x315193d92866bc14ull},
    {"patch_12", 0x49aeefebee5da622ull, 0x6f313f96194dd64dull, 0x49aeefebee5da622ull},
    {"patch_7_variance", 0x50737e2f6d90ef87ull, 0x50737e2f6d90ef87ull, 0x50737e2f6d90ef87ull},
    {"paper_posterior", 0x7bf131884233bd0dull, 0x7e9530dc8a3cb51full, 0xbc58e2b3f6d4dd75ull},
    {"twelve_iterations_variance", 0xfc3d6b554891b538ull, 0x3210385dcbc56d61ull, 0x33ab49b2fa4f4a47ull},
    {"strict_validity", 0xe460dbc4cd782b4aull, 0x2de94d871b536ae4ull, 0x9affcf21acef9f99ull},
    {"tiny_sigma_s_variance", 0xdad514b2be890418ull, 0x119a68a3dad4175full, 0x55c20502164c6fffull},
    {"coarser_look_variance", 0xde308766b586e5b8ull, 0x33416fb6219cdbdcull, 0xa55d0c42043e2c9aull},
    {"gain_compensation", 0x15e02f3806e90e02ull, 0xdfaca61ae15e3954ull, 0x625f609ff3acbd73ull},
    {"no_support_weights", 0x1960abe262b60b35ull, 0xdf0ae8adbf0d7569ull, 0xa2ff1104ce45fd64ull},
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
