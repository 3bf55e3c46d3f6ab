// Fixed-size kernels built with AVX2 + FMA (this file only; CMake adds the
// flags where the compiler targets x86-64). Chosen at run time when the CPU
// has both, so the library still runs on older CPUs.
#include "patch_kernels.hpp"

namespace bdis {
namespace detail {
namespace avx2 {
#define BDIS_KERNEL_NAME "avx2"
#define BDIS_KERNEL_AVX2
#include "patch_kernels_fixed.inc"
#undef BDIS_KERNEL_NAME
}  // namespace avx2

const KernelSet* avx2KernelsFor(int patch_size) { return avx2::fixedKernelsFor(patch_size); }

}  // namespace detail
}  // namespace bdis
