// Dispatch over the Chapman methods, the derived forms (plain, log, rescaled) and
// the batch loops. One template serves float and double.
#include "airmass/chapman.hpp"
#include "airmass/simd.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <vector>

#include "chapman_airmass.hpp"
#include "chapman_airmass_hwy.hpp"
#include "chapman_internal.hpp"
#include "chapman_published.hpp"

namespace airmass {

// The `airmass` batch kernel: for AVX2/FMA written with Google Highway (chapman_airmass_hwy.cpp),
// called from chapman_scaled_batch / chapman_rescaled_batch when simd_target() is avx2_fma; for
// baseline x86-64 the scalar path in a loop (on the 2-core Xeon of December 2026 11.0 / 17.7 ns
// above / below the horizon against 14.8 / 31.5 ns for the four-lane vector-extension kernel,
// whose 4-double vectors are SSE2 register pairs without FMA; macOS on Intel too); on other
// platforms (macOS on Apple silicon) the four-lane kernel on GCC/Clang vectors
// (chapman_airmass_batch.inc).
#if AIRMASS_CHAPMAN_VECTORS && !defined(__x86_64__)
#define AIRMASS_CHAPMAN_V4_BATCH 1
namespace airmass_v4 {
namespace baseline {
#include "chapman_airmass_batch.inc"
}  // namespace baseline
}  // namespace airmass_v4
#else
#define AIRMASS_CHAPMAN_V4_BATCH 0
#endif

namespace {

constexpr std::array<ChapmanMethodInfo, 8> kMethods{{
    {ChapmanMethod::exact, "exact", "tanh-sinh quadrature of the defining integral + exact reflection identity"},
    {ChapmanMethod::airmass, "airmass", "ours: rational base x bicubic correction table (w, v), identity below horizon"},
    {ChapmanMethod::schuler2012, "schuler2012", "Schuler 2012 GPU Pro 3: c/((c-1)cos+1), c = 1.2533 sqrt(x)"},
    {ChapmanMethod::schuler2012_full, "schuler2012-full", "Schuler 2012 rational form with full Ch_par = (1/2x+1) sqrt(pi x/2)"},
    {ChapmanMethod::schuler2012_rigged, "schuler2012-rigged", "Schuler 2012 Listing 2.1 chapman_h: c = sqrt(x), 50%-heights, exp2"},
    {ChapmanMethod::schuler2012_rigged_exp2pp, "schuler2012-rigged-exp2pp", "Listing 2.1 chapman_h with the Listing 2.3 exp2pp"},
    {ChapmanMethod::kocifaj1996, "kocifaj1996", "Kocifaj 1996 closed form with erfcx"},
    {ChapmanMethod::golubev2019, "golubev2019", "Golubev 2019 Eq. 45: erfcx by a rational approximation"},
}};

#if AIRMASS_SIMD_DISPATCH
// The `airmass` method's scalar path compiled for AVX2/FMA (flatten: everything it calls inlined
// into this copy). The same formulas; the three-operand VEX forms save the register copies of the
// two-operand SSE2 code, ~20 % of the scalar time (issue 14 goal 5).
template <class T>
AIRMASS_TARGET_AVX2_FMA ScaledChapman<T> airmass_scaled_avx2_fma(T x, T mu, T s) {
    return detail::airmass_scaled_fast<T>(detail::airmass_table(), detail::airmass_parallel_table(), x, mu, s);
}
#endif

// Cosine and sine travel as separate scalars: a two-double struct argument was packed
// through the stack and cost a store-forwarding stall on every call.
template <class T>
ScaledChapman<T> scaled_one(ChapmanMethod method, T x, T mu, T s) {
    using namespace detail;
    switch (method) {
        case ChapmanMethod::exact: {
            const auto r = chapman_exact_scaled(double(x), double(mu), double(s));
            return {static_cast<T>(r.mantissa), static_cast<T>(r.log_scale)};
        }
        case ChapmanMethod::airmass:
#if AIRMASS_SIMD_DISPATCH
            if (simd_target() == SimdTarget::avx2_fma) return airmass_scaled_avx2_fma<T>(x, mu, s);
#endif
            return airmass_scaled_fast<T>(airmass_table(), airmass_parallel_table(), x, mu, s);
        case ChapmanMethod::schuler2012: return chapman_schuler2012(x, mu, s);
        case ChapmanMethod::schuler2012_full: return chapman_schuler2012_full(x, mu, s);
        case ChapmanMethod::schuler2012_rigged: return chapman_schuler2012_rigged<T, false>(x, mu, s);
        case ChapmanMethod::schuler2012_rigged_exp2pp: return chapman_schuler2012_rigged<T, true>(x, mu, s);
        case ChapmanMethod::kocifaj1996: return chapman_kocifaj1996(x, mu, s);
        case ChapmanMethod::golubev2019: return chapman_golubev2019(x, mu, s);
    }
    throw std::invalid_argument("chapman: unknown method");
}

// The batch loop is written once; `method` is a compile-time constant inside so each
// method's loop body is inlined and free of the dispatch switch.
// `x_of(i)` yields the i-th x, so the rescaled batch can form X + h without a copy.
// The loop is compiled twice: for baseline x86-64 and, with everything it calls inlined
// (flatten), for AVX2/FMA; simd_target() picks one at run time (airmass/simd.hpp).
// The `airmass` method has its own kernels: the scalar path in a loop for baseline x86-64, four
// lanes on vectors (chapman_airmass_batch.inc) elsewhere, Highway's AVX2 (chapman_airmass_hwy.cpp)
// called directly by the batch functions.

template <class T, ChapmanMethod M, class X, class Out>
[[gnu::always_inline]] inline void batch_body(X& x_of, std::span<const T> c, std::span<const T> s, Out& out) {
    if constexpr (M == ChapmanMethod::airmass) {
        const auto& table = detail::airmass_table();
#if AIRMASS_CHAPMAN_V4_BATCH
        airmass_v4::baseline::airmass_batch<T>(table, detail::airmass_parallel_table(), x_of, c, s, out);
#else
        const double* parallel = detail::airmass_parallel_table();
        for (size_t i = 0; i < c.size(); ++i) out(i, detail::airmass_scaled_fast<T>(table, parallel, x_of(i), c[i], s[i]));
#endif
    } else {
        const size_t n = c.size();
        for (size_t i = 0; i < n; ++i) out(i, scaled_one<T>(M, x_of(i), c[i], s[i]));
    }
}

#if AIRMASS_SIMD_DISPATCH
template <class T, ChapmanMethod M, class X, class Out>
AIRMASS_TARGET_AVX2_FMA void batch_loop_avx2_fma(X x_of, std::span<const T> c, std::span<const T> s, Out out) {
    batch_body<T, M>(x_of, c, s, out);
}
#endif

template <class T, ChapmanMethod M, class X, class Out>
void batch_loop(X x_of, std::span<const T> c, std::span<const T> s, Out out) {
#if AIRMASS_SIMD_DISPATCH
    // The exact quadrature is a reference, not a kernel: one copy is enough. The `airmass` method's
    // AVX2 kernel is called before this (airmass_avx2).
    if constexpr (M != ChapmanMethod::exact && M != ChapmanMethod::airmass)
        if (simd_target() == SimdTarget::avx2_fma) return batch_loop_avx2_fma<T, M>(x_of, c, s, out);
#endif
    batch_body<T, M>(x_of, c, s, out);
}

void check_lengths(size_t n, size_t n_cos, size_t n_sin) {
    if (n_cos != n || n_sin != n)
        throw std::invalid_argument("chapman batch: x, cos_chi and sin_chi must have the same length");
}

#if AIRMASS_SIMD_DISPATCH
// True when the `airmass` method's batch runs on the AVX2 kernel (chapman_airmass_hwy.cpp).
bool airmass_avx2(ChapmanMethod method) {
    return method == ChapmanMethod::airmass && simd_target() == SimdTarget::avx2_fma;
}
#endif

template <class T, class X, class Out>
void batch_dispatch(ChapmanMethod method, size_t n, X x, std::span<const T> c, std::span<const T> s, Out out) {
    check_lengths(n, c.size(), s.size());
    switch (method) {
        case ChapmanMethod::exact: return batch_loop<T, ChapmanMethod::exact>(x, c, s, out);
        case ChapmanMethod::airmass: return batch_loop<T, ChapmanMethod::airmass>(x, c, s, out);
        case ChapmanMethod::schuler2012: return batch_loop<T, ChapmanMethod::schuler2012>(x, c, s, out);
        case ChapmanMethod::schuler2012_full: return batch_loop<T, ChapmanMethod::schuler2012_full>(x, c, s, out);
        case ChapmanMethod::schuler2012_rigged: return batch_loop<T, ChapmanMethod::schuler2012_rigged>(x, c, s, out);
        case ChapmanMethod::schuler2012_rigged_exp2pp:
            return batch_loop<T, ChapmanMethod::schuler2012_rigged_exp2pp>(x, c, s, out);
        case ChapmanMethod::kocifaj1996: return batch_loop<T, ChapmanMethod::kocifaj1996>(x, c, s, out);
        case ChapmanMethod::golubev2019: return batch_loop<T, ChapmanMethod::golubev2019>(x, c, s, out);
    }
    throw std::invalid_argument("chapman: unknown method");
}

}  // namespace

std::span<const ChapmanMethodInfo> chapman_methods() { return kMethods; }

std::optional<ChapmanMethod> chapman_method_from_name(std::string_view name) {
    for (const auto& m : kMethods)
        if (m.name == name) return m.method;
    return std::nullopt;
}

std::string_view chapman_method_name(ChapmanMethod method) {
    for (const auto& m : kMethods)
        if (m.method == method) return m.name;
    return "unknown";
}

template <class T>
ScaledChapman<T> chapman_scaled(ChapmanMethod method, T x, ZenithAngle<T> chi) {
    return scaled_one<T>(method, x, chi.cos_chi, chi.sin_chi);
}

template <class T>
T chapman(ChapmanMethod method, T x, ZenithAngle<T> chi) {
    const auto r = scaled_one<T>(method, x, chi.cos_chi, chi.sin_chi);
    return r.log_scale == T(0) ? r.mantissa : r.mantissa * std::exp(r.log_scale);
}

template <class T>
T log_chapman(ChapmanMethod method, T x, ZenithAngle<T> chi) {
    const auto r = scaled_one<T>(method, x, chi.cos_chi, chi.sin_chi);
    return std::log(r.mantissa) + r.log_scale;
}

namespace {
// X + h beyond the largest T (so h is, to rounding, ≥ that): Ch(X + h, χ) e^(−h) without forming
// X + h. Above the horizon (and at it) the ray climbs from the point, where the density is
// e^(−h) = 0 relative to the reference. Below it, the line's mass both ways from its periapsis
// h_p = (X + h) sin χ − X scale heights above the reference, 2 Ch(X + h_p, 90°) e^(−h_p), less the
// part behind the point, which is of e^(−h) = 0.
template <class T>
T rescaled_beyond_range(ChapmanMethod method, T X, T h, ZenithAngle<T> chi) {
    if (!(chi.cos_chi < T(0))) return T(0);
    const T hp = h * chi.sin_chi - X * (T(1) - chi.sin_chi);
    if (!(hp < h)) return T(0);  // sin χ rounded to 1: the horizon
    return T(2) * chapman_rescaled(method, X, hp, ZenithAngle<T>{T(0), T(1)});
}
template <class T>
bool beyond_range(T x) {
    return x > std::numeric_limits<T>::max();  // +inf from X + h; NaN stays NaN
}
}  // namespace


template <class T>
T chapman_rescaled(ChapmanMethod method, T X, T h, ZenithAngle<T> chi) {
    if (beyond_range(X + h)) return rescaled_beyond_range(method, X, h, chi);
    const auto r = scaled_one<T>(method, X + h, chi.cos_chi, chi.sin_chi);
    return r.mantissa * std::exp(detail::rescaled_exponent(r.log_scale, X, h, chi.cos_chi, chi.sin_chi));
}

template <class T>
void chapman_scaled_batch(ChapmanMethod method, std::span<const T> x, std::span<const T> cos_chi,
                          std::span<const T> sin_chi, std::span<T> mantissa, std::span<T> log_scale) {
    if (mantissa.size() != x.size() || log_scale.size() != x.size())
        throw std::invalid_argument("chapman batch: output spans must have the length of x");
#if AIRMASS_SIMD_DISPATCH
    if (airmass_avx2(method)) {
        check_lengths(x.size(), cos_chi.size(), sin_chi.size());
        return detail::airmass_scaled_batch_avx2<T>(detail::airmass_table(), x.data(), cos_chi.data(), sin_chi.data(),
                                                    x.size(), mantissa.data(), log_scale.data());
    }
#endif
    batch_dispatch<T>(method, x.size(), [x](size_t i) { return x[i]; }, cos_chi, sin_chi, [&](size_t i, ScaledChapman<T> r) {
        mantissa[i] = r.mantissa;
        log_scale[i] = r.log_scale;
    });
}

template <class T>
void chapman_rescaled_batch(ChapmanMethod method, T X, std::span<const T> h, std::span<const T> cos_chi,
                            std::span<const T> sin_chi, std::span<T> out) {
    if (out.size() != h.size()) throw std::invalid_argument("chapman batch: output span must have the length of h");
#if AIRMASS_SIMD_DISPATCH
    if (airmass_avx2(method)) {
        check_lengths(h.size(), cos_chi.size(), sin_chi.size());
        detail::airmass_rescaled_batch_avx2<T>(detail::airmass_table(), X, h.data(), cos_chi.data(), sin_chi.data(),
                                               h.size(), out.data());
    } else
#endif
    {
        batch_dispatch<T>(method, h.size(), [X, h](size_t i) { return X + h[i]; }, cos_chi, sin_chi,
                          [&](size_t i, ScaledChapman<T> r) {
                              out[i] = r.mantissa * std::exp(detail::rescaled_exponent(r.log_scale, X, h[i], cos_chi[i], sin_chi[i]));
                          });
    }
    // Points whose X + h is beyond the largest T, as the scalar form.
    for (size_t i = 0; i < h.size(); ++i)
        if (beyond_range(X + h[i])) [[unlikely]]
            out[i] = rescaled_beyond_range(method, X, h[i], ZenithAngle<T>{cos_chi[i], sin_chi[i]});
}

template <class T>
T exp2pp(T x) {
    return exp2pp_impl(x);
}

#define AIRMASS_INSTANTIATE(T)                                                                                   \
    template ScaledChapman<T> chapman_scaled<T>(ChapmanMethod, T, ZenithAngle<T>);                               \
    template T chapman<T>(ChapmanMethod, T, ZenithAngle<T>);                                                     \
    template T log_chapman<T>(ChapmanMethod, T, ZenithAngle<T>);                                                 \
    template T chapman_rescaled<T>(ChapmanMethod, T, T, ZenithAngle<T>);                                         \
    template void chapman_scaled_batch<T>(ChapmanMethod, std::span<const T>, std::span<const T>,                 \
                                          std::span<const T>, std::span<T>, std::span<T>);                       \
    template void chapman_rescaled_batch<T>(ChapmanMethod, T, std::span<const T>, std::span<const T>,            \
                                            std::span<const T>, std::span<T>);                                   \
    template T exp2pp<T>(T);
AIRMASS_INSTANTIATE(float)
AIRMASS_INSTANTIATE(double)
#undef AIRMASS_INSTANTIATE

}  // namespace airmass
