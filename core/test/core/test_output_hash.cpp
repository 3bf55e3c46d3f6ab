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
    {"balanced", 0xd7269a080ad529bfull, 0xe7bc4d4eb2d34a93ull, 0xa5e2caa6bf59fdeaull},
    {"fast", 0x222c86bf9cd55d52ull, 0x681c86c2dc4eeb2aull, 0xfe3f1006b47501eeull},
    {"accurate", 0x6a2ecb9e01219c7aull, 0x4e099ef2ab6c07beull, 0xdb6f07eb085d196aull},
    {"balanced_variance", 0xe9811bc2b5d5b6d9ull, 0xf6c3255c22be45c5ull, 0x57abeea8c32fef99ull},
    {"accurate_variance", 0xbae3fe84537c131cull, 0x3c0c552b21556948ull, 0x1787a5fba4cc7826ull},
    {"finest_0", 0x52abc7dafb0d824full, 0x4ff7505e3cc05799ull, 0x5cc0f4ca880bb9cfull},
    {"finest_2", 0xa11ccf30ba01a6a6ull, 0x063a6900a12a6ff8ull, 0xb29c93f3d76399e2ull},
    {"levels_3_3", 0x089da6fe387c7de6ull, 0x2c8c9a0d592b6fb8ull, 0x16abe5b7b840fcd4ull},
    {"whole_level_search", 0xe7dc049280044c48ull, 0xd834b621dde833dfull, 0x9424f6dabf3402a3ull},
    {"one_row_bands", 0x5cdb3f4652be3eb0ull, 0x74df2d6e5b23ab70ull, 0x2ab314d37c734e19ull},
    {"no_check", 0xd3d9c95846418023ull, 0x2816f945a8c02078ull, 0x702e7d8167cd6b4full},
    {"no_propagation_no_mean", 0xbf59c450c59e6ab9ull, 0x1921c21a070d7720ull, 0x4e132356475a2e66ull},
    {"half_pixel_window", 0xcfa4f61f9a4b5259ull, 0xf48f1a03d6cdad86ull, 0x858433778000ea32ull},
    {"patch_4", 0x458f99f60d55b4dfull, 0xbe62ccc904528d8aull, 0x458f99f60d55b4dfull},
    {"patch_12", 0xef9e230336d72d78ull, 0x336099bdf53b038eull, 0xef9e230336d72d78ull},
    {"patch_7_variance", 0xbca20db210762abeull, 0xbca20db210762abeull, 0xbca20db210762abeull},
    {"paper_posterior", 0xfa6eda2f242fa6c5ull, 0xae4154aeba8d6c35ull, 0xa60d3a691bacd16bull},
    {"twelve_iterations_variance", 0xaadc051ca15c6d32ull, 0xc79e8f67b3fd3152ull, 0x1d156fcfa48695aeull},
    {"strict_validity", 0x1aec1a27986eb15aull, 0x5eafb8043444fb01ull, 0x5941874b86b0c917ull},
    {"tiny_sigma_s_variance", 0x7de848f3d790f13bull, 0x8c2f14e8c6c9e432ull, 0x221d8d59795f8c81ull},
    {"coarser_look_variance", 0xedcf7a8c61d519e2ull, 0xc2962f0216cfa4dcull, 0x016b64893ae0a8b3ull},
    {"gain_compensation", 0x09456c34656e4093ull, 0x3e74fc9403632301ull, 0xf8aae02285be145bull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0xec31ad9adfc0e043ull, 0x693cc03c679aeeafull, 0xcc2cb917bfe97c20ull},
    {"fast", 0x3b16fab553f58447ull, 0xbfffb4fdba4ff3faull, 0x304ad1fb63392b6eull},
    {"accurate", 0x6d79c8b7be8b8559ull, 0x5f193a8498675d09ull, 0x240b881dedcd5c23ull},
    {"balanced_variance", 0x6679ddb6267ea611ull, 0x43bc648d39794ff4ull, 0x05c17d5d73eb9c6aull},
    {"accurate_variance", 0xcc3a9721acc0c5bbull, 0x9f2306e7eec39a95ull, 0x741fc53c411e2f01ull},
    {"finest_0", 0x6787513749a7ea23ull, 0x7e34adf20c35e3d6ull, 0x7981653e6da2b219ull},
    {"finest_2", 0x607fbe8ee6b25258ull, 0x3d2bb707bffb1eccull, 0x734a0030a9fc3b31ull},
    {"levels_3_3", 0x51ea8f33d6d2e9c7ull, 0x28441e9b5c71881bull, 0x42e1640654619aebull},
    {"whole_level_search", 0x04341d0537500d95ull, 0xe096cf39bb8ed613ull, 0x83fd1ecabe11ae7full},
    {"one_row_bands", 0xcdeddeb5a2e6c40full, 0xc583b872d56fbab4ull, 0x488fcef1900a6713ull},
    {"no_check", 0x5d1a1c24446586daull, 0x6fad9208d564439cull, 0xae5ece6041474b3bull},
    {"no_propagation_no_mean", 0x9fbf66d1c0d5fd10ull, 0x4d80b117a39d5271ull, 0xdf56c9df55950bbeull},
    {"half_pixel_window", 0x71cd5432bd4a7171ull, 0xcbb139511cfdc509ull, 0xe9415a85a5cc69feull},
    {"patch_4", 0x4a6b9073c166d682ull, 0x4183d432bc2f1a78ull, 0x4a6b9073c166d682ull},
    {"patch_12", 0x320046566edc1aeeull, 0x8dbc16c4c1ab2fd0ull, 0x320046566edc1aeeull},
    {"patch_7_variance", 0x867bc8d3edcfaccaull, 0x867bc8d3edcfaccaull, 0x867bc8d3edcfaccaull},
    {"paper_posterior", 0x1db0d320283afd43ull, 0xe71214712da2f394ull, 0x4b158b70de62ab25ull},
    {"twelve_iterations_variance", 0x0e6851affc480134ull, 0xe1a817e105ed9edbull, 0x83a8072fa5aafc89ull},
    {"strict_validity", 0xebd630b88875499dull, 0x9beaa23b26c49a54ull, 0x4ac23f53d02ff9c4ull},
    {"tiny_sigma_s_variance", 0x083225e463d73273ull, 0x182745e23a9d9659ull, 0xb20f924290a56da8ull},
    {"coarser_look_variance", 0x6099454d1e214978ull, 0xa522b7bf24abadedull, 0x85a68ff5884055e2ull},
    {"gain_compensation", 0x886a553e5ffb91c1ull, 0xe41b006a439f4c70ull, 0x20265f53950d23f7ull},
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
