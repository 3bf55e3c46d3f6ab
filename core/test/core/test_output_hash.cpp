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
    {"balanced", 0xd5d851faf89a4c9dull, 0x7ecaa990a244e16bull, 0x8923f0c0c20f818aull},
    {"fast", 0x2786421c7f37150aull, 0x2ea867266fbe2cf7ull, 0xa958f0be2396426bull},
    {"accurate", 0x7e846a6f65c991feull, 0x09989a249b554aaaull, 0xb4471f3f4d32852full},
    {"balanced_variance", 0x0612bddd9bf49ffcull, 0xac07e3c9da612cfaull, 0x04b6daa51d40be3aull},
    {"accurate_variance", 0x9a383902e2473c69ull, 0x09d83cd344c36924ull, 0x4563def522a6e3eeull},
    {"finest_0", 0x0148285a33bb6889ull, 0xde53d403fd02cc99ull, 0x27ca793635f314ebull},
    {"finest_2", 0x3e11e9c79641bb4eull, 0x76c4c7e3163ee40dull, 0xc3c8626a4afa3c09ull},
    {"levels_3_3", 0xcef663a948ee2fb9ull, 0x8198030cb413b454ull, 0x4b1785ee44e8945aull},
    {"whole_level_search", 0x086635545d2df70dull, 0xaa6c05fd45f5f65full, 0xd007a642959acdcaull},
    {"one_row_bands", 0xa2c571530d47922full, 0xa1e96e7c0fbab09cull, 0x4c71be289b2d6dd6ull},
    {"no_check", 0x1e94c5dc9129521aull, 0xdd2f7f19d0911959ull, 0x18718391a085238bull},
    {"no_propagation_no_mean", 0x57bb3f9f7b85f6f8ull, 0x1e66e283248aa4e9ull, 0x29d6778064ff910aull},
    {"half_pixel_window", 0x2bd13dab3d643406ull, 0x9e959bfcbca13057ull, 0x27e880e0bc7f3056ull},
    {"patch_4", 0xb7e659c3b606fdf0ull, 0x5b9d9158ea941638ull, 0xb7e659c3b606fdf0ull},
    {"patch_12", 0x2e40c9a1af5a4284ull, 0xc0ab86a5f954d727ull, 0x2e40c9a1af5a4284ull},
    {"patch_7_variance", 0x2b22bf2be3ba6c04ull, 0x2b22bf2be3ba6c04ull, 0x2b22bf2be3ba6c04ull},
    {"paper_posterior", 0xb04de3e5b1f60a60ull, 0x00aadecf83c99a4dull, 0x393c9cfb75bb9a8dull},
    {"twelve_iterations_variance", 0x6e219e1af42535ceull, 0xc80c0083e85004d5ull, 0xc110df8e6af853adull},
    {"strict_validity", 0x587627f52ab1c6fdull, 0xe73bb29be85e309eull, 0x2dbdd6e1d844def6ull},
    {"tiny_sigma_s_variance", 0x1dfae16085de57a1ull, 0xd66849b26cf940adull, 0xf459757afb1d0eb6ull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0x75c387d85ac7f025ull, 0x4a5d389a66b70ec6ull, 0x08b9c17bad9ab839ull},
    {"fast", 0xcb89c2680ce6fe89ull, 0x15fb4c8efe6d53ccull, 0x5c5287a3453e4863ull},
    {"accurate", 0x28e7487b76a54f50ull, 0x5fee73965b15311dull, 0xe5df593dfeddbe1full},
    {"balanced_variance", 0x05fb22340522a60cull, 0x97ea1334523c0971ull, 0x22480215107f9247ull},
    {"accurate_variance", 0xa27e503cb948df12ull, 0x809d290806ffdea3ull, 0x8d59854e71698fa5ull},
    {"finest_0", 0x4964fe992fb2960eull, 0x0b97660772f664b0ull, 0xd13e0539cfb7bb31ull},
    {"finest_2", 0xda203c2c1937d979ull, 0x3cea2ee386897d96ull, 0x6415756a108287d3ull},
    {"levels_3_3", 0x48351a98d6aa805aull, 0x05d06724f3605246ull, 0x2a4cdfb0844fad50ull},
    {"whole_level_search", 0xb00ccfe997ea9704ull, 0xba16aba120bbdb09ull, 0xfe87e50d43f89059ull},
    {"one_row_bands", 0xb67f5e3c0a05b389ull, 0xe10dc358d3a39400ull, 0x4954ac461ec2cfc8ull},
    {"no_check", 0x0b650efb58e8bc68ull, 0xb6c8d4760764ae06ull, 0xc7d86a8644fa19a3ull},
    {"no_propagation_no_mean", 0x00fd4add9a5b7437ull, 0xace6cee6519b8596ull, 0x92c4eea8b33680b7ull},
    {"half_pixel_window", 0xb2e5c9bf36a83cb8ull, 0x8eec5782a58255e0ull, 0x0992101d7607ad36ull},
    {"patch_4", 0xd5d35583be73ba25ull, 0x94e8f95e71076740ull, 0xd5d35583be73ba25ull},
    {"patch_12", 0xcc9368ad818027a7ull, 0x22807e7784a4e9efull, 0xcc9368ad818027a7ull},
    {"patch_7_variance", 0x142ad81047b2be4full, 0x142ad81047b2be4full, 0x142ad81047b2be4full},
    {"paper_posterior", 0x50244a53efba0c9full, 0x4fa29ae2ad945807ull, 0xc7b70cb5db417285ull},
    {"twelve_iterations_variance", 0x91452ac0aad61fb3ull, 0x80df4408f545f965ull, 0xaf6828c8280a9fc0ull},
    {"strict_validity", 0xbb66b8ae0c05673eull, 0x4e80ae6842caeb37ull, 0x61eba2605681f0bdull},
    {"tiny_sigma_s_variance", 0x2ad13b4b9a4b9fb0ull, 0x8572b80ccd3d73b0ull, 0x003a1b94858afca9ull},
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
