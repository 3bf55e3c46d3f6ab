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
    {"balanced", 0xa7aeaf1be493f608ull, 0xb5ec38c66af90d1aull, 0x2b15b51cd1cd0da0ull},
    {"fast", 0xbab9919991a1aedbull, 0x227cb958fd353d46ull, 0x9a8019c0560b9189ull},
    {"accurate", 0xa49010e77b6cb456ull, 0x21f869a568ceb097ull, 0x45e627703d3b7524ull},
    {"balanced_variance", 0xca1882c0e167dd3full, 0x8d5dcfdba80a3fd2ull, 0xd89cbd24ec5d1ca9ull},
    {"accurate_variance", 0xb71d3a8bf88cfd82ull, 0x0f8b62f63a02c840ull, 0x825c6877eb739f2cull},
    {"finest_0", 0x08904316cf4f0bcbull, 0x1a3881fc0fe35236ull, 0x7cbd5ce9c8160603ull},
    {"finest_2", 0x6f3f59fef0e166cbull, 0x5f8f0663c1506392ull, 0x10713428af9b5afeull},
    {"levels_3_3", 0x53b8931de1b116c9ull, 0xffecb972b2e43971ull, 0xdd200b1702805670ull},
    {"whole_level_search", 0x39f16e2c906e03e5ull, 0xf5ec48d6f57a9e1aull, 0x85df301bb0d2e0c5ull},
    {"one_row_bands", 0x89e58e8546c7462dull, 0x888b54c42342bbe6ull, 0x976229c4b07ebe58ull},
    {"no_check", 0x1b070ac639de56c3ull, 0x5a40c5c720425908ull, 0xfb3485f91d26148full},
    {"no_propagation_no_mean", 0xc360ba0866a70136ull, 0x069a30ab8ef01735ull, 0x99121edd99cbaaffull},
    {"half_pixel_window", 0x491b7d41b538ecf7ull, 0x628f1b69b6db59dbull, 0xebb09553e26c12c3ull},
    {"patch_4", 0xcdd0fee5f80f45eeull, 0xee6679e8d1c5da44ull, 0xcdd0fee5f80f45eeull},
    {"patch_12", 0xe633cb83f9a77248ull, 0x293eb4840f23e559ull, 0xe633cb83f9a77248ull},
    {"patch_7_variance", 0x4a8ed2487b831d04ull, 0x4a8ed2487b831d04ull, 0x4a8ed2487b831d04ull},
    {"paper_posterior", 0xf18d26d0c29dca44ull, 0x860c164635ef9f7eull, 0x35322f847f641919ull},
    {"twelve_iterations_variance", 0x046955d65fc7d290ull, 0xc14f7a9c5abed935ull, 0x56a129fd95d95334ull},
    {"strict_validity", 0x67b29f5956f034baull, 0x806f2887ddffb63eull, 0x8d1410cf1bc3fdf1ull},
    {"tiny_sigma_s_variance", 0xcea9d91d208071c7ull, 0x36a64f1bc02728f7ull, 0xf1e48920e81fbbc3ull},
    {"coarser_look_variance", 0x4a9740ef952aa7b7ull, 0xf9025b1b5b18ff6eull, 0x9db39e21c3863acdull},
    {"gain_compensation", 0xf30adc66d708cba7ull, 0x9b5755f431115c2cull, 0xb89de79ba9d0b772ull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0x2415d688d9a4b3e8ull, 0xe1d1b5dc1167aceaull, 0xfbad6d1951bc5ab0ull},
    {"fast", 0xa1cacbb171e86da8ull, 0x3eef59789ec37688ull, 0x6575e5528b81b5baull},
    {"accurate", 0xdba8e577b97fee6dull, 0x65a8772c25576858ull, 0x75c6e3514c2823a3ull},
    {"balanced_variance", 0x46dd76381bd36e58ull, 0x6c908ec72c87468bull, 0xbf9b4eaa1abb3715ull},
    {"accurate_variance", 0x496995d83cc63eabull, 0xbc02019bb6f5cf31ull, 0xf3b29b5623c0e42full},
    {"finest_0", 0xed7950e01e54ff0bull, 0x53b5788e8c9eb884ull, 0x732913b9d5bb9daeull},
    {"finest_2", 0x3c550cfff64b47bfull, 0xbae7e648dbfe4144ull, 0xeab6300939ed325cull},
    {"levels_3_3", 0xcce926697e034e74ull, 0x1dda53ddfc4cc3d0ull, 0x0854c7526eee9766ull},
    {"whole_level_search", 0x686dd96d53052e1eull, 0x9b947624ea6bd419ull, 0x247ce928b22bd3b4ull},
    {"one_row_bands", 0x11e5501211809c82ull, 0x9f798064f2466f62ull, 0x4db416418cf83a1cull},
    {"no_check", 0xd8f29d7826ed1e0eull, 0x9b5aa1deed216977ull, 0x9821bf6f6c2ef755ull},
    {"no_propagation_no_mean", 0x76db3ed345421988ull, 0xa739a7766da03ab8ull, 0xf34a94522057b912ull},
    {"half_pixel_window", 0x593381ec152379afull, 0x8dfede4634908337ull, 0x0cabd7c1d5bc3e70ull},
    {"patch_4", 0x05faa0c4c15bdddcull, 0x8d388f84001903d1ull, 0x05faa0c4c15bdddcull},
    {"patch_12", 0x800e92c9b2e423d0ull, 0xcd61371875775c0bull, 0x800e92c9b2e423d0ull},
    {"patch_7_variance", 0x940b40968edfd7c7ull, 0x940b40968edfd7c7ull, 0x940b40968edfd7c7ull},
    {"paper_posterior", 0xf18476393f869fcfull, 0x0cd95d6f05290d2full, 0x1f97ca8f3f298617ull},
    {"twelve_iterations_variance", 0xe249738909fde04dull, 0x3dccde61ffb98374ull, 0x06a1907b17aa4f59ull},
    {"strict_validity", 0xcb5ce9bb40b79d33ull, 0xb5bd29abd79a7c67ull, 0x39ea2fed11144d5aull},
    {"tiny_sigma_s_variance", 0xe0fbe58d788cb3d7ull, 0xfaf23e3b5e1e2087ull, 0x909be1b8cd633181ull},
    {"coarser_look_variance", 0x355a9aab2f951abcull, 0xc97339d505414ea0ull, 0x1304b122d26b4539ull},
    {"gain_compensation", 0x7d9727cfdc1ce29full, 0x3e9dd3e2da8feda0ull, 0x423d138aab5a11d9ull},
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
