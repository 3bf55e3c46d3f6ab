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
    {"balanced", 0x642a505e24df5aa9ull, 0x5c17f6800f12306cull, 0xf22c30175d67c4f3ull},
    {"fast", 0x1779ef0d3b15b1f7ull, 0x476d57aaa51eb06dull, 0xc052df676d64588full},
    {"accurate", 0xf97e551a502b3501ull, 0xfb905527c41e94cbull, 0xce2bdf7456029221ull},
    {"balanced_variance", 0x969a838e5a125e18ull, 0x01d467ad17e294fdull, 0xc9063c845e153b06ull},
    {"accurate_variance", 0x5c6c047052da8c7dull, 0xf5c998caf7208a1cull, 0x3b8cb7294120d5c4ull},
    {"finest_0", 0x3111dcd784e1632eull, 0x2fc896f573e1cbfcull, 0x04da823cd7240e69ull},
    {"finest_2", 0x380fd55279242b9bull, 0x59dec071d445ea9full, 0x078cdb19180c7d86ull},
    {"levels_3_3", 0x602f4fb26accf902ull, 0x01aaad410e71445cull, 0xf9bc0a87bcb29233ull},
    {"whole_level_search", 0xd09f317e83305c21ull, 0x07a38aa06d7ed191ull, 0xfe568065bca000aeull},
    {"one_row_bands", 0x6944aad2c44d6f35ull, 0x0695e732fc240a44ull, 0xa709e749a0c56686ull},
    {"no_check", 0xbcf1e3e576bc6ae4ull, 0x3c5bb7ad5205eacfull, 0x6625df416404c633ull},
    {"no_propagation_no_mean", 0x2b0a309de7abdb9full, 0xe341a469681dbfefull, 0x839bbe41a490677full},
    {"half_pixel_window", 0xd2105603680b2b07ull, 0x5bc3c052117f62e2ull, 0x1bdd7d81aa3bc1efull},
    {"patch_4", 0xd6980aeec6d6a272ull, 0x9bb59bd878ec53c9ull, 0xd6980aeec6d6a272ull},
    {"patch_12", 0x3c51fe34aa3134ddull, 0x1a3c92e0db5f7eecull, 0x3c51fe34aa3134ddull},
    {"patch_7_variance", 0xed617e42f5534a86ull, 0xed617e42f5534a86ull, 0xed617e42f5534a86ull},
    {"paper_posterior", 0x53acde46c9d4ac2aull, 0x41a0f8abc7f9c88eull, 0x32dbfe67ff80f0e1ull},
    {"twelve_iterations_variance", 0x48f0281502717d1cull, 0x70fa2760b1a34e7cull, 0xad95b279d75e12edull},
    {"strict_validity", 0x7ba0aa1a89834d35ull, 0x99bedf3e0d2e2ec6ull, 0x6d6ed9464863c8ccull},
    {"tiny_sigma_s_variance", 0xdcba25cb040e51b1ull, 0x35425e1e64284314ull, 0xbea35c117c4861f5ull},
    {"coarser_look_variance", 0x6f1dd733258eecdeull, 0x2d3bfcefac329f63ull, 0x48ac47364e8f2afaull},
    {"gain_compensation", 0x7c7cccb7122eaf30ull, 0x81998f4d24ff17b0ull, 0x32cf3b942fea513dull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0xc613bf516bc3ecdbull, 0x6fc355b3187042ddull, 0x35ffd24587942c1full},
    {"fast", 0xf4666ddb2d641744ull, 0x8dc278ca034503d4ull, 0x66d3ffbaa5f54174ull},
    {"accurate", 0x9f254bed6df8f836ull, 0xf36cb773e701fa67ull, 0xdf1914aa53fb1659ull},
    {"balanced_variance", 0x03ceec8391790055ull, 0xeb29ab6ef25b653full, 0xb4f4a3a6463240e9ull},
    {"accurate_variance", 0x7cb75aefcb52c015ull, 0x776b8b7b7b5a4336ull, 0x5d2ad474b979621dull},
    {"finest_0", 0x5144624caf8015e9ull, 0x530bcbbdb1ef6d85ull, 0xf69af0b6cd0e555full},
    {"finest_2", 0x09f78017cb81b9f7ull, 0x87802ff8644fc2e4ull, 0x6839f2e9778c5465ull},
    {"levels_3_3", 0xee76b4716178837full, 0xaf3ba217dc74a831ull, 0x8d6283fbab5aab44ull},
    {"whole_level_search", 0x28b8b5e6c07c0121ull, 0x9becb3a545b0c7d8ull, 0xd52472cbe39d65efull},
    {"one_row_bands", 0x09ac5b0271e35414ull, 0x81304620291649ceull, 0x85e62adfb353dddaull},
    {"no_check", 0x432686e7d92f3626ull, 0x097044ac79173bbdull, 0xc312aed587278e0cull},
    {"no_propagation_no_mean", 0x2164207bdf98decaull, 0xac39f82da076a838ull, 0xcffc9417c3abbb39ull},
    {"half_pixel_window", 0xc15bf0056c8c2177ull, 0x3159faafc8355e9full, 0x0b1a912ce63b4c5bull},
    {"patch_4", 0x1062bd4eb626a3d7ull, 0x4fec109c6c3d6165ull, 0x1062bd4eb626a3d7ull},
    {"patch_12", 0x1a0cf60008643600ull, 0xf547d2ab9fde99c7ull, 0x1a0cf60008643600ull},
    {"patch_7_variance", 0x930de71be0ac00c8ull, 0x930de71be0ac00c8ull, 0x930de71be0ac00c8ull},
    {"paper_posterior", 0x131f1237196751f3ull, 0xfbddce4595053954ull, 0x84011207931ecf4dull},
    {"twelve_iterations_variance", 0x0257673680859e26ull, 0xed18c5b4cc26628full, 0xa24d59cb4c897a28ull},
    {"strict_validity", 0x97c3d9e0521ccb9aull, 0xc9dcfa60bc2519c0ull, 0x71cf63078b2a4757ull},
    {"tiny_sigma_s_variance", 0x81ca493ba3d8f47aull, 0x76354bbb067b3846ull, 0x22129934786dd994ull},
    {"coarser_look_variance", 0x0407ec5bc88e9451ull, 0xe6db6c242d86b0bcull, 0xb9d4a9f85473fc8dull},
    {"gain_compensation", 0xb63b75e55a39852aull, 0x6535654d02a895ecull, 0x49957581c0557e1bull},
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
