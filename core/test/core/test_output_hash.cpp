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
    {"balanced", 0xa72d6728e4e81b17ull, 0x64b00a1f0294476aull, 0xf6a9e92c7235818full},
    {"fast", 0x1958892d28c14052ull, 0xa138632f38cefd34ull, 0x482854238a38b397ull},
    {"accurate", 0x8bbd739fbe1c0b74ull, 0x4b5f85fda10c9b09ull, 0x139180e69209ee30ull},
    {"balanced_variance", 0x615e6d17dc34174aull, 0x13d84b7d117b8a73ull, 0x410ec7f25ebad6eaull},
    {"accurate_variance", 0x2bdc8ab966fe5373ull, 0x1d4175d36730df2bull, 0x71bd75eb06803f93ull},
    {"finest_0", 0x5c75f1d17c449915ull, 0xd36fd13306559518ull, 0xb65f83609e72eabeull},
    {"finest_2", 0x3a6746914f3f415dull, 0x9f9a0f70ec0e7b0eull, 0xccdc8bae4e61c7acull},
    {"levels_3_3", 0xd43c54c2c362f247ull, 0xb9c4ec52b931719bull, 0xe2cd4f4d579fef25ull},
    {"whole_level_search", 0xb3b02372a1032a96ull, 0xb0f8bee69cea4012ull, 0x37ed319bf399aea8ull},
    {"one_row_bands", 0xe5c75170bb000ad4ull, 0x018ea1346f952b75ull, 0x7ca1e6d3c5d72edcull},
    {"no_check", 0x420976f6a847d122ull, 0x8f8d5fe31d8eab5cull, 0x7167a7c21d3cc3f0ull},
    {"no_propagation_no_mean", 0x24d0a72643579cf3ull, 0xd11aa23b1fae99f4ull, 0x4482e36c56fb92d8ull},
    {"half_pixel_window", 0x3d5d6da9881928f0ull, 0x43c0020552e92b03ull, 0xd0e285a793e15ec5ull},
    {"patch_4", 0x8186818aeff3dbc3ull, 0x95c1c81811a8b88aull, 0x8186818aeff3dbc3ull},
    {"patch_12", 0xdda1bfa49901011aull, 0x6ae410bd7d72bb75ull, 0xdda1bfa49901011aull},
    {"patch_7_variance", 0x2ad438c905b468c9ull, 0x2ad438c905b468c9ull, 0x2ad438c905b468c9ull},
    {"paper_posterior", 0xf76be6db3e78d28bull, 0x0892ac68e7d0fb87ull, 0xab3cc0977001e571ull},
    {"twelve_iterations_variance", 0x629c665a299cd842ull, 0xb1d2424fa7ac050full, 0xae194e64e23d02b2ull},
    {"strict_validity", 0x7d2427bf44e8facdull, 0x09520664c68a1883ull, 0xae55ccec63f39c03ull},
    {"tiny_sigma_s_variance", 0x8f489a5898fda8feull, 0xa74a14c3db58d09eull, 0x9169befe0d3cc124ull},
    {"coarser_look_variance", 0xad8027cb00217103ull, 0x9e66d68a8cd3a0c9ull, 0xcf665560c7c1ba6aull},
    {"gain_compensation", 0x5e08e53bfecaeed8ull, 0x6f5f8d533bc17a62ull, 0xf16e00c6081131cdull},
    {"no_support_weights", 0x12cfb4fef39c6ef5ull, 0x10bb5a14104de6c3ull, 0xcc2b8c0d2e591d9cull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0x6cfb11a768d47e8full, 0xe44eecddeaf53731ull, 0x1be8a7493ddaddd9ull},
    {"fast", 0xfd61879008ded960ull, 0xfe10d86c9bff7de2ull, 0x3150fc440993f641ull},
    {"accurate", 0x2e024d805ac764e1ull, 0x7c8a70699fedeca6ull, 0x18b37c14180ab58bull},
    {"balanced_variance", 0xac725fb650d276e1ull, 0x48305a92eb84f211ull, 0x23ab416c16451c7full},
    {"accurate_variance", 0x02880902d2e827f8ull, 0x3b8759ecac6b3192ull, 0xa86ec8f7b9fd058eull},
    {"finest_0", 0x924291c35e212ebaull, 0xfbb604bda56d23adull, 0x939fd2fe603699c3ull},
    {"finest_2", 0xd7d214b0b13efbf9ull, 0x17a748198475151eull, 0x4a12ae4c7efa57f9ull},
    {"levels_3_3", 0x062481fc2ea6aa02ull, 0x07e11cbd6070fff7ull, 0xf7ca9ee959540deaull},
    {"whole_level_search", 0x0d463feb817c6d7bull, 0x5a273934c7964bd7ull, 0xa1a0b3f178bc82dbull},
    {"one_row_bands", 0x338ed39df24475c1ull, 0x50c3e728be1fdbcfull, 0x1a4af1f93217688full},
    {"no_check", 0xa6b7568a410747d3ull, 0x5b90b0d481b4d6f2ull, 0x00db0b73005bef93ull},
    {"no_propagation_no_mean", 0xc73144443ca2cd8full, 0xb88416ab470adea1ull, 0x17a7c1bd9cb701f3ull},
    {"half_pixel_window", 0xd5094d99d1bb573bull, 0x57b7e192df788ebbull, 0x66a990fde4c7df86ull},
    {"patch_4", 0xae99ecde53cf0dd8ull, 0xa682926ea97dc97cull, 0xae99ecde53cf0dd8ull},
    {"patch_12", 0xe3d0be4f72d5bb3cull, 0x96578414237a83deull, 0xe3d0be4f72d5bb3cull},
    {"patch_7_variance", 0x2dc8e71a064f85fbull, 0x2dc8e71a064f85fbull, 0x2dc8e71a064f85fbull},
    {"paper_posterior", 0xaf5974ee69ad6e6cull, 0xba864008c78c459cull, 0x1dcfa6fd121daa28ull},
    {"twelve_iterations_variance", 0xce1e6ddf41d2e2ebull, 0x8acb653e69db87d3ull, 0xf7d2eafbcde7e8f7ull},
    {"strict_validity", 0xf27c13e432b18a85ull, 0xa2934be5bb505c09ull, 0xa2829f6a3cb5c6e8ull},
    {"tiny_sigma_s_variance", 0xb36a9c20fc41e529ull, 0x25ecc989fcfb5179ull, 0x57f032289dc8a2d2ull},
    {"coarser_look_variance", 0x5c859515848b5b42ull, 0xdfa41e3355bb97baull, 0x10b8c6e85537a30bull},
    {"gain_compensation", 0xf6d1b1469bf7dec5ull, 0x5f9d2d382eb395d8ull, 0x41977825489bcb4cull},
    {"no_support_weights", 0x2e6ed772d8e6cb9dull, 0x1f9327d8157749afull, 0xb87a04974d5bc703ull},
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
