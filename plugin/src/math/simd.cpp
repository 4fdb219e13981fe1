#include "airmass/simd.hpp"

#include <cstdlib>
#include <cstring>

namespace airmass {

namespace {
SimdTarget detect() {
#if AIRMASS_SIMD_DISPATCH
    const char* force = std::getenv("AIRMASS_SIMD");
    if (force && std::strcmp(force, "baseline") == 0) return SimdTarget::baseline;
    __builtin_cpu_init();
    if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) return SimdTarget::avx2_fma;
    return SimdTarget::baseline;
#elif defined(__AVX2__) && defined(__FMA__)
    return SimdTarget::avx2_fma;  // a -march build: everything is AVX2/FMA code already
#else
    return SimdTarget::baseline;
#endif
}
}  // namespace

SimdTarget simd_target() {
    static const SimdTarget target = detect();  // immutable once set (thread-safe init)
    return target;
}

std::string_view simd_target_name(SimdTarget target) {
    switch (target) {
        case SimdTarget::baseline:
#if defined(__x86_64__) || defined(_M_X64)
            return "baseline x86-64";
#else
            return "baseline";  // e.g. arm64: no dispatched kernels
#endif
        case SimdTarget::avx2_fma: return "avx2+fma";
    }
    return "unknown";
}

}  // namespace airmass
