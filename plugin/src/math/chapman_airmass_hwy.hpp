// The `airmass` method's AVX2/FMA batch kernel, written with Google Highway
// (chapman_airmass_hwy.cpp). Only where the library dispatches (AIRMASS_SIMD_DISPATCH); call it
// only when simd_target() is avx2_fma. Same results as the baseline kernel to rounding.
#pragma once

#include <cstddef>

#include "airmass/simd.hpp"
#include "chapman_airmass.hpp"

#if AIRMASS_SIMD_DISPATCH
namespace airmass::detail {

// mantissa[i], log_scale[i] = Ch(x[i], chi_i) in scaled form (chapman_scaled_batch).
template <class T>
void airmass_scaled_batch_avx2(const AirmassTable& table, const T* x, const T* cos_chi, const T* sin_chi, size_t n,
                               T* mantissa, T* log_scale);

// out[i] = Ch(X + h[i], chi_i) e^(−h[i]) (chapman_rescaled_batch).
template <class T>
void airmass_rescaled_batch_avx2(const AirmassTable& table, T X, const T* h, const T* cos_chi, const T* sin_chi,
                                 size_t n, T* out);

}  // namespace airmass::detail
#endif
