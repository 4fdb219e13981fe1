// Which instruction set the library's dispatched kernels run (docs/portable.md).
//
// Everything is compiled for baseline x86-64, so one binary runs on every x86-64 CPU. The few
// kernels that gain from AVX2/FMA (the Chapman batch loops) are compiled a second time with
// GCC's target("avx2,fma") attribute and chosen at run time when the CPU has them. The
// environment variable AIRMASS_SIMD=baseline forces the baseline kernels (for tests and
// benchmarks on a new CPU); it is read once.
#pragma once

#include <string_view>

namespace airmass {

enum class SimdTarget { baseline, avx2_fma };

// The target this process runs (the CPU's features, or AIRMASS_SIMD=baseline).
SimdTarget simd_target();
std::string_view simd_target_name(SimdTarget target);

}  // namespace airmass

// Kernels get a second, AVX2/FMA copy only where GCC/Clang can dispatch on x86-64. Not on macOS:
// __builtin_cpu_supports needs compiler-rt's __cpu_model, which Zig's macOS cross build does not
// link (undefined ___cpu_model), and Clang ignores `#pragma GCC target` (docs/portable.md).
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__)) && !defined(__AVX2__) && !defined(__APPLE__)
#define AIRMASS_SIMD_DISPATCH 1
#define AIRMASS_TARGET_AVX2_FMA __attribute__((target("avx2,fma"), flatten))
#else
#define AIRMASS_SIMD_DISPATCH 0
#define AIRMASS_TARGET_AVX2_FMA
#endif

// In a file whose kernels are included twice, as namespaces baseline and avx2_fma (the second
// inside #pragma GCC target("avx2,fma"); multiple_scattering.cpp, single_scattering.cpp):
// `return` the call of the copy this CPU runs.
#if AIRMASS_SIMD_DISPATCH
#define AIRMASS_SIMD_RETURN(call)                                                          \
    if (::airmass::simd_target() == ::airmass::SimdTarget::avx2_fma) return avx2_fma::call; \
    return baseline::call
#else
#define AIRMASS_SIMD_RETURN(call) return baseline::call
#endif
