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
    {"balanced", 0xc7b8cdf601f85f17ull, 0x66730560d4b4deb0ull, 0x76f43a29e63059f8ull},
    {"fast", 0x9bb281aa619ca768ull, 0x6f121e57be0cf612ull, 0xe6ad5ef9b137b0acull},
    {"accurate", 0x0755f5ac7bf4b713ull, 0x20173b43383ad373ull, 0xf822d178718cb783ull},
    {"balanced_variance", 0x50d6185210fec404ull, 0x8717b20b7b7e1650ull, 0x95a80d21970fe16dull},
    {"accurate_variance", 0x657a5620e2532ef7ull, 0x38e7082d3807e458ull, 0x19b3de6225df0167ull},
    {"finest_0", 0xe4342e6e6bc7cdf5ull, 0xd76809f189f12160ull, 0xbfc1067e06d989beull},
    {"finest_2", 0x7e8f8bfeaec2d1ebull, 0x31acc7315b0a9e33ull, 0xeb1a0330b6b7f820ull},
    {"levels_3_3", 0x53b8931de1b116c9ull, 0xffecb972b2e43971ull, 0xdd200b1702805670ull},
    {"whole_level_search", 0x6e39ea5e6fe29ad8ull, 0x5ba1f58f8dfeddc9ull, 0x75fc1f802d9af937ull},
    {"one_row_bands", 0x1fb45fbd0b1386b2ull, 0x05c703b0b8b31e5dull, 0xa037e2aeadbf05cdull},
    {"no_check", 0x7659455eadb66cb6ull, 0x8f8d154ff9d969e2ull, 0x17503192738c169full},
    {"no_propagation_no_mean", 0x0a3812b1fdaf94b1ull, 0x09466e991d5a5f84ull, 0xb5856782c4427684ull},
    {"half_pixel_window", 0x1025032a2273bedfull, 0x9c4806fa44b0cb0full, 0xc952d1bc1ebb793dull},
    {"patch_4", 0x6bbd8c40646d0606ull, 0x12463ee4f2efe190ull, 0x6bbd8c40646d0606ull},
    {"patch_12", 0x10065e6b43dbab14ull, 0x329fb664c62afbdaull, 0x10065e6b43dbab14ull},
    {"patch_7_variance", 0x90ab179ab3eddffaull, 0x90ab179ab3eddffaull, 0x90ab179ab3eddffaull},
    {"paper_posterior", 0x548a619309803882ull, 0x549fbf82e91841ceull, 0xe49f38686973c7b2ull},
    {"twelve_iterations_variance", 0xb029136f590660f7ull, 0xbddbe195e4edb2f3ull, 0x1f485c8e915c6786ull},
    {"strict_validity", 0xdbfc48a79d5dc350ull, 0xa4444caa7e063110ull, 0x7f560044055281dcull},
    {"tiny_sigma_s_variance", 0x920391d4c87d79d7ull, 0xd5596480292b1924ull, 0x6e519682941179c1ull},
    {"coarser_look_variance", 0xc19ec48659d59880ull, 0x8bcbeb76f138aefeull, 0x74d264aea6337411ull},
    {"gain_compensation", 0x280527f3a144bc64ull, 0xdf8ffb357af1d17aull, 0xe1841b086613650eull},
};

// The same on the first frame of each colon sequence of the shared data.
const std::vector<Expected> kColonFrameHashes = {
    {"balanced", 0xc8b44e3f47519b27ull, 0xc38c6c689f8dd087ull, 0xfb1a323f4e4f7ba9ull},
    {"fast", 0x1dbb1adab0054ee6ull, 0x5c727fe541ddc779ull, 0x02134a251c8bf54aull},
    {"accurate", 0x2315ca025d0e9383ull, 0x270d4f97f6653821ull, 0x04b9904eaae2f9b4ull},
    {"balanced_variance", 0x48e7649aa1c9721full, 0x123998432e47c02aull, 0xa65a72354a1eb914ull},
    {"accurate_variance", 0x7febddf74614ea99ull, 0x236467f298061504ull, 0x4dd0e57761bb6fe8ull},
    {"finest_0", 0xa23bee6e4cb1f8b3ull, 0x684421c0607872b4ull, 0x470b6b7db0b02635ull},
    {"finest_2", 0xd2afc79c370893f5ull, 0x6dbbdfc060d0b6beull, 0x16ff6495e649bae0ull},
    {"levels_3_3", 0xcce926697e034e74ull, 0x1dda53ddfc4cc3d0ull, 0x0854c7526eee9766ull},
    {"whole_level_search", 0x8e5d1271334949f8ull, 0x77557c7bc7af5d2eull, 0x4e8aae5996235f88ull},
    {"one_row_bands", 0xac79d490b9e2f484ull, 0x76898ea3243d3193ull, 0xd4c1c26503f47208ull},
    {"no_check", 0x21e80875a6e78b79ull, 0x45c0623cfc4f7250ull, 0x589335d5ad5933f1ull},
    {"no_propagation_no_mean", 0x1fe8e81465604063ull, 0x1554d096c0078709ull, 0x25bcd2680b4bdf4full},
    {"half_pixel_window", 0xa1a27b7e2fdaabffull, 0x5ce6a34d53ec04a1ull, 0xb7760d6916936f68ull},
    {"patch_4", 0xb5b0ca5424b443a9ull, 0xd4ad1970f67bdeddull, 0xb5b0ca5424b443a9ull},
    {"patch_12", 0x9b47f3b63f95d8dfull, 0xbc81f990651162a3ull, 0x9b47f3b63f95d8dfull},
    {"patch_7_variance", 0x5cb9c1980fbd79d3ull, 0x5cb9c1980fbd79d3ull, 0x5cb9c1980fbd79d3ull},
    {"paper_posterior", 0xdcb7dda980243c23ull, 0xbd59b70584a90ff1ull, 0x82020e3fb639bbe3ull},
    {"twelve_iterations_variance", 0xc7740a2c48319e89ull, 0xe8f93f3389639bacull, 0x9893063da3bb49e2ull},
    {"strict_validity", 0x864bc1a73ba86183ull, 0xedc3470557a2620full, 0xb927947082bca00bull},
    {"tiny_sigma_s_variance", 0x4470fd40c9e0dd13ull, 0x865217ccd535ef74ull, 0x2ed6179b0950751dull},
    {"coarser_look_variance", 0x3cd63a9a4d1fc85full, 0xf87cdda76b8b9388ull, 0x389cb904dd95ceb7ull},
    {"gain_compensation", 0xe7b7363989fd60deull, 0x1ca83dc139adc682ull, 0x5f8346ebad7a5b2full},
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
