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
      {"two_scales_variance",
       [](MatcherParams& p) {
         p.two_scales = true;
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
    {"balanced", 0xd7c586f3fa8e784aull, 0xdfcc41d9f2765b94ull, 0xe3a25684660a52d4ull},
    {"fast", 0x62db6784e6e4848full, 0x25eea1b45da387d6ull, 0xed7570056bba48a9ull},
    {"accurate", 0x2a193ebdcf5bc365ull, 0xf764d328270528c4ull, 0x376e8c5206f00006ull},
    {"balanced_variance", 0x64bf92f0c8e4cee9ull, 0x96233fd3b0766ae3ull, 0xa55010454137dc12ull},
    {"accurate_variance", 0x4c901905e5a9480eull, 0x0eb1cd028ed05ecfull, 0x979e6ebc61060714ull},
    {"finest_0", 0x2a10d665f9c636deull, 0x48898711d3b4b024ull, 0xa877f101842ffffaull},
    {"finest_2", 0x6c4149d35fe60f6dull, 0x4d2d602503bcf4ceull, 0xa728f5bcf2edff32ull},
    {"levels_3_3", 0x83c6896fbd2eb2abull, 0x57cf19884861c03eull, 0xe001d4d66bd061a3ull},
    {"whole_level_search", 0xfddba58e925266f2ull, 0xc8e48f11614a2f73ull, 0x5865e7e7959c4b06ull},
    {"one_row_bands", 0x7adda68601424396ull, 0xc877703cba3c76aaull, 0x28cac22e5f695c54ull},
    {"no_check", 0xc0c0740422136a0aull, 0x60b926fda9a719acull, 0xd33b6fdf46962e3aull},
    {"no_propagation_no_mean", 0xe6330332017bb467ull, 0xd0d5e04fe9a655eeull, 0xe0ac66ca6f590a24ull},
    {"half_pixel_window", 0x32833844a3449b79ull, 0x9455afdbfd3d0addull, 0x03850f4462b7edf3ull},
    {"patch_4", 0x4aba02b4e2a40861ull, 0x0cc26f981f4c5b35ull, 0x4aba02b4e2a40861ull},
    {"patch_12", 0x24c2cb2f226f478aull, 0xa2493c6b00c9479cull, 0x24c2cb2f226f478aull},
    {"patch_7_variance", 0xcb37b102fea67603ull, 0xcb37b102fea67603ull, 0xcb37b102fea67603ull},
    {"paper_posterior", 0x601c4854a74002a4ull, 0x42ec8db5cadbb3c4ull, 0xf817f872dbfcea31ull},
    {"twelve_iterations_variance", 0xbda3e2b0833a64f0ull, 0x585762a327db8802ull, 0xd3b4c9d22166e518ull},
    {"strict_validity", 0x82dedb94f61bb5e2ull, 0x3f065179d7047e75ull, 0x9dab182ee1ac5ef4ull},
    {"tiny_sigma_s_variance", 0x88e97b3e78581efaull, 0x99cf9d51644ca027ull, 0xb6cd9c22201d70d6ull},
    {"coarser_look_variance", 0xfb04727c56174bc5ull, 0x66a05ced61e7f2e9ull, 0x6d78e5706146c8a5ull},
    {"gain_compensation", 0x1556f4ac77c0db31ull, 0xc79d5ed867f4e510ull, 0xfecd3442b68bea9full},
    {"no_support_weights", 0xfff4b116886390acull, 0xea345868ba2ead3aull, 0xfc3cf6e39c9f229bull},
    {"two_scales_variance", 0xc43784dd62ede125ull, 0x2c96426abdb66d60ull, 0x9a80d1313a7b7335ull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0x05ab32cc6b3e0c46ull, 0x07f7f450d4d98f0aull, 0x1651e63742b97859ull},
    {"fast", 0x2f078de8e4c9ff4bull, 0x0361126bf8ed572full, 0x899f45deebb3a464ull},
    {"accurate", 0xdc4635bd340d7984ull, 0x8eb31563b83c4bd9ull, 0x18b2bd9cec2f2d14ull},
    {"balanced_variance", 0xe594ea5f7bc547d7ull, 0xa98ae7fca0e78aedull, 0x84933c683f9a4997ull},
    {"accurate_variance", 0xc494941655d13726ull, 0x0b5a3ed827b7652bull, 0x1c454bb6fdc334ddull},
    {"finest_0", 0x3d605d1957ba4eedull, 0x62e0d332ce670e5bull, 0x48c915d1f61d797eull},
    {"finest_2", 0xa58c09eb17bc49e1ull, 0x7481925340ec24f4ull, 0x07542c969640e951ull},
    {"levels_3_3", 0x878feba9ea8d5a81ull, 0x03331683ce544447ull, 0x8b1efab6d8164f0full},
    {"whole_level_search", 0xcc31106c1281e181ull, 0x9e153e9b45b3422cull, 0x76947ee5c06ba47full},
    {"one_row_bands", 0x81793e6f2659ee7bull, 0x8c414a08f669d354ull, 0x3d3c71e56f63c27full},
    {"no_check", 0x2ef3238f856b9f96ull, 0x11df81cdd26d63d4ull, 0xdad40e152cd6b30dull},
    {"no_propagation_no_mean", 0x7220c0c495907569ull, 0x4cfd85fa99941e58ull, 0xc9805783d284ca17ull},
    {"half_pixel_window", 0x880bd12cd805a0ffull, 0x737f4355006d7626ull, 0xccc7702cfd2ee0b4ull},
    {"patch_4", 0x04eb452355b1dd71ull, 0x79b893d4013e4e26ull, 0x04eb452355b1dd71ull},
    {"patch_12", 0x1e3b3f4c14024c9dull, 0x0e09fa4e2d5431fbull, 0x1e3b3f4c14024c9dull},
    {"patch_7_variance", 0xdace1e0acfed8ca5ull, 0xdace1e0acfed8ca5ull, 0xdace1e0acfed8ca5ull},
    {"paper_posterior", 0x365d0677dee3bd6eull, 0xa0c80b6e066d68b2ull, 0xdeef73b2c8f84e9eull},
    {"twelve_iterations_variance", 0xd0e9a16cd837898cull, 0xb7d2bf5577da3b91ull, 0x2c8513f34b727d7bull},
    {"strict_validity", 0x2ef68c5b47508b82ull, 0xdd94062e371b761dull, 0x699b9fc24eb4435cull},
    {"tiny_sigma_s_variance", 0x5a41dab46f16c6d3ull, 0xda6cbcd84107b932ull, 0x2eaf961f3b156f4cull},
    {"coarser_look_variance", 0xde7c1cf6b898d893ull, 0xef5a0475a7837ba7ull, 0x04211e54cfee6031ull},
    {"gain_compensation", 0x8a6b930c7467bb19ull, 0x3213506322be1f18ull, 0xf3c7f7dfc0785b8aull},
    {"no_support_weights", 0x343f29753e8bc75full, 0x1fc2618fce2018bdull, 0x0e60cb8ea65201dfull},
    {"two_scales_variance", 0x971d6ec8738affe1ull, 0x71e4e19e4ab6325dull, 0xc036760d105f95c6ull},
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
