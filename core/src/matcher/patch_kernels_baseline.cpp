// Fixed-size kernels with the compiler's baseline instruction set (SSE2 on
// x86-64, NEON on AArch64): they run on every CPU the library runs on.
#include "patch_kernels.hpp"

namespace bdis {
namespace detail {
namespace baseline {
#define BDIS_KERNEL_NAME "baseline"
#include "patch_kernels_fixed.inc"
#undef BDIS_KERNEL_NAME
}  // namespace baseline

const KernelSet* baselineKernelsFor(int patch_size) { return baseline::fixedKernelsFor(patch_size); }

}  // namespace detail
}  // namespace bdis
