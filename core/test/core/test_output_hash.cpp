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
    {"balanced", 0x7cee4839d3907d02ull, 0x3b7e1d39d91c042dull, 0xf059bd0e86d99da1ull},
    {"fast", 0x0fe5a47dafd4cc3full, 0x66664d0b56f2f448ull, 0x49940c91778167dbull},
    {"accurate", 0xfe55548f9ff39a56ull, 0x4493656ae22655f3ull, 0x831c9aa5b0579cedull},
    {"balanced_variance", 0x0ecbdf3349b05379ull, 0xd541960e32384351ull, 0xad6330b20a82bf88ull},
    {"accurate_variance", 0xe54a7ee12fefac92ull, 0x92dc1b6097b698fcull, 0xdc22d3968d72c741ull},
    {"finest_0", 0x60cdcd48827a0cf2ull, 0x5ee821651d0ee76aull, 0xb257721e1cffdf20ull},
    {"finest_2", 0xf36b48460339da2bull, 0xf53af5da792d512cull, 0x7cbee8f823fe47d2ull},
    {"levels_3_3", 0xdd2adc699689fc37ull, 0x5bd905395247d27bull, 0xe472890d07b1eb78ull},
    {"whole_level_search", 0xb938c316691d12acull, 0x8ce4f54c12914125ull, 0x22878c9d26697a31ull},
    {"one_row_bands", 0x89ef60aae59a8651ull, 0xcfae87cc7196288aull, 0x490369a367d105c4ull},
    {"no_check", 0x6a1d48f5fb4c4321ull, 0xa16dd764aa30cba9ull, 0x6d93870e970a040aull},
    {"no_propagation_no_mean", 0x318893794a38a025ull, 0x6218d0f6cd433d39ull, 0xd0662c10598b55f0ull},
    {"half_pixel_window", 0x1520daa403f10886ull, 0x8cf019490d7a7861ull, 0x7f08830070dc00dbull},
    {"patch_4", 0xb9ed96a5a650130bull, 0x1e5a232c87a816deull, 0xb9ed96a5a650130bull},
    {"patch_12", 0x8ab1b2a4e62b2f20ull, 0xd17744759bfd30d9ull, 0x8ab1b2a4e62b2f20ull},
    {"patch_7_variance", 0xca83d23b61991e1full, 0xca83d23b61991e1full, 0xca83d23b61991e1full},
    {"paper_posterior", 0x465a06de09eb5b75ull, 0xe1acba2c372e9a64ull, 0xc82446307069bdaaull},
    {"twelve_iterations_variance", 0x67ad9bcf919650a2ull, 0xa96210fd0ab6db32ull, 0x56c13d2ae07bd891ull},
    {"strict_validity", 0x17472905e87ad97bull, 0xb8f7eea90ae42027ull, 0x762d9a6046480dbcull},
    {"tiny_sigma_s_variance", 0x3eb00b99e9ae53a9ull, 0x05621d8a0f1342fcull, 0xfd0aa51c46a91be4ull},
    {"coarser_look_variance", 0x53154b2ab26c08cdull, 0x3f3d0b7ebf0514ccull, 0x390c9a2fd33f2c78ull},
    {"gain_compensation", 0xefe3573b754f3b20ull, 0xf6396b0c3c57d28aull, 0xf3de8c2d9e513c6aull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0x8f770d0ea6230867ull, 0x44d46876d8341496ull, 0x58d62ea1b744102dull},
    {"fast", 0x63fc7fed3734a530ull, 0x36d87859b228fbc3ull, 0x222a8d2b35283814ull},
    {"accurate", 0xedd4264749f8a2d0ull, 0x6fa3e6b87fcb7d69ull, 0xd832bc394b7a8e67ull},
    {"balanced_variance", 0xd94f3073d0c74f73ull, 0xcc7bf65291933203ull, 0x00a143ee2ea6d214ull},
    {"accurate_variance", 0xab22f99630970c26ull, 0xc97b591be1d5b06cull, 0x774b164ef2b9376bull},
    {"finest_0", 0xc31ef79589072f85ull, 0xd6ba1a3ab66e8b39ull, 0xc6d4224091d452edull},
    {"finest_2", 0x7b97364a7feaa3faull, 0x1c47f2c48f870320ull, 0x67c9c35b9855c684ull},
    {"levels_3_3", 0xc82555ccda89e817ull, 0x3a702acfc7924699ull, 0xc02a9f02e57a475eull},
    {"whole_level_search", 0x1dea5ccdc2190d50ull, 0xaa4e1af0b249ecfbull, 0x52dd5c3a7b9925a1ull},
    {"one_row_bands", 0xf31ff8e3e442f7dcull, 0x2fcfc38cb70cb2e5ull, 0xd24d1e671791cfa4ull},
    {"no_check", 0x282a1bb5e1b653cfull, 0x305b8101a59a1179ull, 0xa2284caed77ecb5aull},
    {"no_propagation_no_mean", 0xd22c219e2c47ae3eull, 0x0f84d0bc39ca2462ull, 0x016f47ca80e6ceceull},
    {"half_pixel_window", 0xa78ea485b495a07cull, 0x88d7baeedbd1351aull, 0xacbc7eb4ff7a4729ull},
    {"patch_4", 0x3fc01a722095641cull, 0xfad2925cb6eb7782ull, 0x3fc01a722095641cull},
    {"patch_12", 0xad9f4c1d52bb7129ull, 0x2bfb5b808b14936cull, 0xad9f4c1d52bb7129ull},
    {"patch_7_variance", 0x2623880e1e4c0e47ull, 0x2623880e1e4c0e47ull, 0x2623880e1e4c0e47ull},
    {"paper_posterior", 0x1c1e67e8ba14d95eull, 0x50d654682e6dd76dull, 0xec982b363cf12483ull},
    {"twelve_iterations_variance", 0x433633f75c7fc7ecull, 0x1030c5e52b75ab12ull, 0x7f6acb6ea13ccb6aull},
    {"strict_validity", 0x2dbf21cdcb48db69ull, 0x56927a31647e7322ull, 0xf63b371a01fdb3e5ull},
    {"tiny_sigma_s_variance", 0x1443a3c139d19ddbull, 0xdb1d9e82350554e3ull, 0xb6e0b33163eed89dull},
    {"coarser_look_variance", 0x5f3aca13c1260d36ull, 0xf9945f34bede34afull, 0xe2a56714d2ece270ull},
    {"gain_compensation", 0x261ce29d04d3b90bull, 0x680294655e6ccdf0ull, 0x2af0d43ebdfeb6beull},
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
