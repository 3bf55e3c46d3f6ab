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
    {"balanced", 0x8b7a8326ced1c0b3ull, 0xa1a9b8e4d04fd787ull, 0xca810a6505c38a48ull},
    {"fast", 0x618eee470850c312ull, 0x25731502661c92b8ull, 0x5c67f020a28d3312ull},
    {"accurate", 0x817adffc69215a60ull, 0xca5e63672cede17eull, 0x4e9b72de2a595cbdull},
    {"balanced_variance", 0xd2ecbfd360771c89ull, 0x8d8246802e8e9c65ull, 0xcbcc7e85e1c44ed7ull},
    {"accurate_variance", 0xcaba97b83d17d05aull, 0x6438e36684684ee0ull, 0xf2b7424df1e79659ull},
    {"finest_0", 0x5e6d763abd749cfbull, 0x138f88bedcbd9cddull, 0x0d9e03f89f8485dbull},
    {"finest_2", 0x0a0be6935b55eadaull, 0x5f10893808ce0dd8ull, 0x944f8617fe89545dull},
    {"levels_3_3", 0xfa45c6090d13ef94ull, 0x5829a46bf7f8360aull, 0xf90d3f78178bd13dull},
    {"whole_level_search", 0xde3b715f934722c4ull, 0x53f284b63c91e671ull, 0x89026959365bedb8ull},
    {"one_row_bands", 0x1feb85fbd8c447c2ull, 0xef3668bf83a04a2eull, 0x8ec4672c32c5dce8ull},
    {"no_check", 0x6595752283e67b8aull, 0xa2f1d48dd5269121ull, 0x52184dc178bc3277ull},
    {"no_propagation_no_mean", 0xa289dc9c58140d5aull, 0xbb8056649b1c7356ull, 0xea70b2ac51cecac1ull},
    {"half_pixel_window", 0xde9037415d8930efull, 0xa24ca16f88cb6274ull, 0x60ca6156915c9a10ull},
    {"patch_4", 0xe877b6534eb1243aull, 0x85adac092de15212ull, 0xe877b6534eb1243aull},
    {"patch_12", 0xd413de14357b1ff6ull, 0x4569661a6b2e385dull, 0xd413de14357b1ff6ull},
    {"patch_7_variance", 0x9cf391854b3a929full, 0x9cf391854b3a929full, 0x9cf391854b3a929full},
    {"paper_posterior", 0xd919567d88ff9538ull, 0x78e99b24d15c2016ull, 0x774690e884730523ull},
    {"twelve_iterations_variance", 0xeb0ce1e46f1d66b4ull, 0x789a678ead9ab17dull, 0x33d23ac8f745a7b4ull},
    {"strict_validity", 0xb6b876ee702095ecull, 0xd3ee5228eb2c7eb5ull, 0xc9924c6e45b87fd7ull},
    {"tiny_sigma_s_variance", 0x8a8160df707a4e1dull, 0xd069d6cf97c01cb9ull, 0x189aeb1198e57d55ull},
    {"coarser_look_variance", 0x1164f0577d0a1a25ull, 0xe4efbf705d0278deull, 0x66c1d66c45ae15dfull},
    {"gain_compensation", 0xb281a67f62429e3aull, 0xa3aabba5b355016dull, 0xc22047b533f8dfa9ull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0x9aac237d91b14a63ull, 0x248c90f5fb410a0full, 0xa184665c48997c94ull},
    {"fast", 0x9126c4b13d3c727full, 0xa4333a02f74c527full, 0x536d6901b28b557full},
    {"accurate", 0x3066863b85acd462ull, 0x19463c6b551be451ull, 0x2f31c3c8549d352aull},
    {"balanced_variance", 0x7df69695e9ff064dull, 0x17ecad23ced1ebc0ull, 0x9778bf1b67a856aaull},
    {"accurate_variance", 0xb6691c6a5c7ab470ull, 0xd15e6a482838afddull, 0x4ec8274c5ffff6a8ull},
    {"finest_0", 0x101e1a17a40e95deull, 0x5d04fb963dc7a77full, 0x3b28872a7bd08705ull},
    {"finest_2", 0xa663c635f5fd3ac5ull, 0xaf77c23fcbce9ab7ull, 0x46c4825ea83a3dfaull},
    {"levels_3_3", 0xcaabb49939281ff9ull, 0x3a03e957e95c84caull, 0xd06207cbccd3dc38ull},
    {"whole_level_search", 0xbb92c632f89cbe76ull, 0xde5970d92cf5f294ull, 0x00c7fc950fc2d476ull},
    {"one_row_bands", 0x70e25c79cf69dc39ull, 0x3ff8330955c34560ull, 0x63459ff76c67dce7ull},
    {"no_check", 0xd40ef3ca40e73ceaull, 0xa8937140dfef0218ull, 0x5ab79c47f1a58262ull},
    {"no_propagation_no_mean", 0x2937ccdf8e0d91edull, 0x8cb875ea641ce3b1ull, 0xe833464eb67975d7ull},
    {"half_pixel_window", 0x5ad71e94adc0f88aull, 0x151ab67822b2606full, 0xf64d306b7496c05bull},
    {"patch_4", 0xacc35c0487924ea1ull, 0x15ca2ade0b571474ull, 0xacc35c0487924ea1ull},
    {"patch_12", 0xfed2da888108620dull, 0x83757c9d0717c5a0ull, 0xfed2da888108620dull},
    {"patch_7_variance", 0x63fc18f84fb3295cull, 0x63fc18f84fb3295cull, 0x63fc18f84fb3295cull},
    {"paper_posterior", 0x6fb54c82293aa5efull, 0xc5f2169187e23bc5ull, 0x223927f8efd79244ull},
    {"twelve_iterations_variance", 0x9779626f3c671828ull, 0x9936b2ebc60f8400ull, 0x1ec67584163e048aull},
    {"strict_validity", 0xb1c82bd5b5337209ull, 0x768d66b19112c482ull, 0x79378dcc1ac6dbeaull},
    {"tiny_sigma_s_variance", 0x88257ea527dd89d3ull, 0x643e8fa3530e59d9ull, 0xc91c34b5b95c05cbull},
    {"coarser_look_variance", 0x033b1707f09c3247ull, 0xdba9c8d18cbb3633ull, 0x959741872414ed67ull},
    {"gain_compensation", 0xa75cd56f4ddca05dull, 0x3aebae0d70713bf2ull, 0x00263c787812b9b8ull},
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
