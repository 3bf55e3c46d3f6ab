// The matcher's steady state allocates nothing: after the first frame of a
// given size, compute() makes no heap allocation. Every allocation function of
// the C library and of C++ is interposed in this test binary (OpenCV's
// cv::Mat memory comes from posix_memalign or malloc, std::vector's from
// operator new, which ends in malloc), and counted while a flag is set.
// Under AddressSanitizer, whose allocator must see every block, the counting
// comes from its malloc hook instead of interposition.
#include <gtest/gtest.h>

#include <atomic>
#include <cctype>
#include <cerrno>
#include <string>
#include <vector>
#include <cstdio>
#include <cstdlib>
#include <new>

#include <opencv2/core.hpp>

#include "bdis_stereo/matcher.hpp"
#include "test_images.hpp"

namespace {
std::atomic<bool> g_counting{false};
std::atomic<long> g_allocations{0};
inline void count() {
  if (g_counting.load(std::memory_order_relaxed)) g_allocations.fetch_add(1, std::memory_order_relaxed);
}
}  // namespace

#if defined(__SANITIZE_ADDRESS__)
#define BDIS_COUNT_WITH_ASAN_HOOK 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define BDIS_COUNT_WITH_ASAN_HOOK 1
#endif
#endif

#ifndef BDIS_COUNT_WITH_ASAN_HOOK
extern "C" {
void* __libc_malloc(size_t);
void* __libc_calloc(size_t, size_t);
void* __libc_realloc(void*, size_t);
void* __libc_memalign(size_t, size_t);
}

extern "C" {
void* malloc(size_t n) {
  count();
  return __libc_malloc(n);
}
void* calloc(size_t n, size_t m) {
  count();
  return __libc_calloc(n, m);
}
void* realloc(void* p, size_t n) {
  count();
  return __libc_realloc(p, n);
}
int posix_memalign(void** out, size_t alignment, size_t n) {
  count();
  void* p = __libc_memalign(alignment, n);
  if (!p) return ENOMEM;
  *out = p;
  return 0;
}
void* aligned_alloc(size_t alignment, size_t n) {
  count();
  return __libc_memalign(alignment, n);
}
void* memalign(size_t alignment, size_t n) {
  count();
  return __libc_memalign(alignment, n);
}
}
#else
// ASan calls these hooks for every block of its allocator (malloc, calloc,
// realloc, the aligned ones and operator new). It installs none unless both
// are given.
extern "C" int __sanitizer_install_malloc_and_free_hooks(
    void (*malloc_hook)(const volatile void*, size_t), void (*free_hook)(const volatile void*));
namespace {
void countAsanAllocation(const volatile void*, size_t) { count(); }
void ignoreAsanFree(const volatile void*) {}
const int g_hooks_installed =
    __sanitizer_install_malloc_and_free_hooks(countAsanAllocation, ignoreAsanFree);
}  // namespace
#endif

namespace {

using bdis::Matcher;
using bdis::MatcherParams;
using bdis::MatchResult;

/// Allocations made by compute() on frames 2..N of one size, after frame 1.
long steadyStateAllocations(const MatcherParams& params, bool colour, const bdis::MatchOutputs& outputs = {},
                            int frames = 4) {
  Matcher matcher(params);
  MatchResult result;
  std::vector<bdis_test::StereoPair> pairs;
  for (int i = 0; i < frames; ++i) {
    pairs.push_back(bdis_test::texturedPair(203, 157, {4.0 + 1.7 * i, 0.01 * i}, 10 + i));
  }
  std::vector<cv::Mat> left(frames), right(frames);
  for (int i = 0; i < frames; ++i) {
    if (colour) {
      cv::Mat channels_l[] = {pairs[i].left, pairs[i].left, pairs[i].left};
      cv::Mat channels_r[] = {pairs[i].right, pairs[i].right, pairs[i].right};
      cv::merge(channels_l, 3, left[i]);
      cv::merge(channels_r, 3, right[i]);
    } else {
      left[i] = pairs[i].left;
      right[i] = pairs[i].right;
    }
  }
  matcher.compute(left[0], right[0], result, outputs);  // first frame of this size: sizes the buffers
  g_allocations = 0;
  g_counting = true;
  for (int i = 1; i < frames; ++i) matcher.compute(left[i], right[i], result, outputs);
  g_counting = false;
  return g_allocations.load();
}

TEST(SteadyState, TheCounterSeesAllocations) {
  // The interposition works: a Mat, a vector and a malloc are all counted.
  g_allocations = 0;
  g_counting = true;
  { cv::Mat1f m(64, 64); }
  { std::vector<int> v(100); }
  std::free(std::malloc(10));
  g_counting = false;
  EXPECT_GE(g_allocations.load(), 3);
}

TEST(SteadyState, FirstFrameAllocatesLaterFramesDoNot) {
  Matcher matcher{MatcherParams{}};
  MatchResult result;
  const auto pair = bdis_test::texturedPair(160, 120, {5.0, 0.0}, 3);
  g_allocations = 0;
  g_counting = true;
  matcher.compute(pair.left, pair.right, result);
  g_counting = false;
  EXPECT_GT(g_allocations.load(), 0) << "the first frame must size the buffers";
}

struct AllocationCase {
  const char* name;
  MatcherParams params;
  bool colour;
  bdis::MatchOutputs outputs{};
};

class SteadyStateAllocations : public ::testing::TestWithParam<AllocationCase> {};

TEST_P(SteadyStateAllocations, ZeroPerFrame) {
  const long n = steadyStateAllocations(GetParam().params, GetParam().colour, GetParam().outputs);
  std::printf("[measured] %s: %ld allocations in 3 steady-state frames\n", GetParam().name, n);
  EXPECT_EQ(n, 0);
}

MatcherParams withVariance() {
  MatcherParams p;
  p.compute_variance = true;
  return p;
}
MatcherParams preset(const char* name) { return MatcherParams::preset(name); }
MatcherParams withGainCompensation() {
  MatcherParams p;
  p.gain_compensation = true;
  return p;
}
MatcherParams withMinConfidence() {
  MatcherParams p;
  p.min_confidence = 0.01f;
  return p;
}
MatcherParams twoScalesWithVarianceAndMinConfidence() {
  MatcherParams p;
  p.two_scales = true;
  p.compute_variance = true;
  p.min_confidence = 0.01f;
  return p;
}
MatcherParams fullResolutionNoChecks() {
  MatcherParams p;
  p.finest_level = 0;
  p.lr_check_tolerance = 0.f;
  p.propagation = false;
  return p;
}

INSTANTIATE_TEST_SUITE_P(
    Matcher, SteadyStateAllocations,
    ::testing::Values(AllocationCase{"balanced mono", MatcherParams{}, false},
                      AllocationCase{"balanced bgr", MatcherParams{}, true},
                      AllocationCase{"variance", withVariance(), false},
                      AllocationCase{"fast", preset("fast"), false},
                      AllocationCase{"accurate", preset("accurate"), true},
                      AllocationCase{"gain compensation", withGainCompensation(), false},
                      AllocationCase{"finest 0, no checks", fullResolutionNoChecks(), false},
                      // The node's case: the confidence decides without being published.
                      AllocationCase{"min_confidence, no confidence asked", withMinConfidence(), false,
                                     bdis::MatchOutputs{false, false}},
                      AllocationCase{"disparity only", MatcherParams{}, false, bdis::MatchOutputs{false, false}},
                      // Two scales: the confidence decides between them without being published.
                      AllocationCase{"two_scales, variance, min_confidence", twoScalesWithVarianceAndMinConfidence(),
                                     false, bdis::MatchOutputs{false, true}}),
    [](const auto& info) {
      std::string n = info.param.name;
      for (char& c : n) if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
      return n;
    });

}  // namespace
