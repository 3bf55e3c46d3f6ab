// Chooses the kernel set: fixed-size SIMD kernels where built and supported,
// the scalar reference otherwise.
#include "patch_kernels.hpp"

#include <cstdlib>
#include <cstring>

namespace bdis {
namespace detail {

const KernelSet* baselineKernelsFor(int patch_size);
#ifdef BDIS_HAVE_AVX2_KERNELS
const KernelSet* avx2KernelsFor(int patch_size);
#endif

namespace {
extern const KernelSet kScalar;
constexpr KernelSet kScalar{"scalar",
                            &sumsAllValid,
                            &sumsAllValidNoGradient,
                            &sumsAllValidNoGradientBatch,
                            &sumsClipped,
                            &windowCostsAllValid,
                            &sumsMasked,
                            &sumsMaskedNoGradientBatch,
                            &windowSumsMasked,
                            &accumulatePatch,
                            &templateSums,
                            &supportWeights,
                            &templateSumsAndDeviation,
                            &kScalar};

bool cpuHasAvx2() {
#if defined(BDIS_HAVE_AVX2_KERNELS) && (defined(__GNUC__) || defined(__clang__))
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
#else
  return false;
#endif
}
}  // namespace

bool kernelIsaAvailable(KernelIsa isa) {
  switch (isa) {
    case KernelIsa::Scalar:
    case KernelIsa::Baseline: return true;
    case KernelIsa::Avx2: return cpuHasAvx2();
  }
  return false;
}

KernelIsa bestKernelIsa() {
  const char* env = std::getenv("BDIS_SIMD");
  if (env && std::strcmp(env, "off") == 0) return KernelIsa::Scalar;
  if (env && std::strcmp(env, "baseline") == 0) return KernelIsa::Baseline;
  return cpuHasAvx2() ? KernelIsa::Avx2 : KernelIsa::Baseline;
}

const KernelSet& kernelsFor(int patch_size, KernelIsa isa) {
  const KernelSet* k = nullptr;
  if (isa == KernelIsa::Baseline) k = baselineKernelsFor(patch_size);
#ifdef BDIS_HAVE_AVX2_KERNELS
  if (isa == KernelIsa::Avx2 && cpuHasAvx2()) k = avx2KernelsFor(patch_size);
#endif
  return k ? *k : kScalar;
}

}  // namespace detail
}  // namespace bdis
