// The published approximations of the Chapman function, each exactly as its author
// wrote it, extended below the horizon (chi > 90°) the way that author did: with the
// reflection identity and the method's own horizontal value (chapman_internal.hpp).
// Where a published form breaks (a pole, a negative value, 0·inf) it is left broken;
// tests/test_chapman_extremes.cpp pins down exactly where, and docs/chapman.md says so.
#pragma once

#include <cmath>
#include <limits>
#include <numbers>

#include <boost/math/special_functions/erf.hpp>

#include "chapman_internal.hpp"

namespace airmass {

// GPU Pro 3 Listing 2.3: rational exp2 on [−1/2, 1/2] with range reduction, ~12 bits.
template <class T>
inline T exp2pp_impl(T x) {
    const T c0 = T(5.79525), c1 = T(12.52461), c2 = T(-2.88611);
    const T e = std::round(x);
    const T t = x - e;
    const T m = (t * t + c0 * t + c1) / (c2 * t + c1);
    // ldexp saturates long before |e| = 2000; clamping first keeps the int conversion defined for
    // any x (found by fuzz_csv: 'airmass chapman --method schuler2012-rigged-exp2pp', x = 1e300).
    return std::ldexp(m, static_cast<int>(e > T(2000) ? T(2000) : (e >= T(-2000) ? e : T(-2000))));
}

namespace detail {

// Schüler 2012 §2.4: Ch'(c, chi) = c / ((c − 1) cos chi + 1) for chi ≤ 90°.
template <class T>
inline T schuler_rational(T c, T mu) {
    return c / ((c - T(1)) * mu + T(1));
}

// Schüler 2012 §2.4.1: Ch∥(x) ≈ 1.2533 sqrt(x) ("with less than 5% error for x > 10").
template <class T>
inline T schuler_horizontal(T x) {
    return T(1.2533) * std::sqrt(x);
}

// Schüler 2012 §2.4.1 before simplification (= Kocifaj at 90°): Ch∥(x) = (1/2x + 1) sqrt(pi x / 2).
template <class T>
inline T kocifaj_horizontal(T x) {
    return (T(1) / (T(2) * x) + T(1)) * std::sqrt(std::numbers::pi_v<T> * x / T(2));
}

template <class T>
inline ScaledChapman<T> chapman_schuler2012(T x, T mu, T sin_chi) {
    // Blog "as originally published": chi > 90°: c/((c−1)cos chi − 1) + 2 c e^(x − x sin chi) sqrt(sin chi),
    // which is the reflection identity with Ch∥(x0) = 1.2533 sqrt(x0) = c sqrt(sin chi).
    return reflect_below_horizon<T>(
        x, mu, sin_chi, [](T x_, T m) { return schuler_rational(schuler_horizontal(x_), m); },
        [](T x0) { return schuler_horizontal(x0); });
}

template <class T>
inline ScaledChapman<T> chapman_schuler2012_full(T x, T mu, T sin_chi) {
    return reflect_below_horizon<T>(
        x, mu, sin_chi, [](T x_, T m) { return schuler_rational(kocifaj_horizontal(x_), m); },
        [](T x0) { return kocifaj_horizontal(x0); });
}

// GPU Pro 3 Listing 2.1 `chapman_h`, "rigged" for sums of segments (§2.5.2): c = sqrt(x),
// Ch' = c / (c cos chi + 1), in units of the 50%-height H50 = H ln 2 and with exp2.
// With X = x (so h = 0 and exp2(−h) = 1) the listing's below-horizon branch
//     2 c0 exp2(X − x0) − c / (1 − c cos chi) exp2(−h)
// is, in scaled form, mantissa = 2 c0 − c/(1 − c cos chi) · exp2(−d50), log_scale = d.
template <class T, bool UseExp2pp>
inline ScaledChapman<T> chapman_schuler2012_rigged(T x, T mu, T sin_chi) {
    const T inv_ln2 = T(1.4426950408889634);
    const T x50 = x * inv_ln2;
    const T c = std::sqrt(x50);
    if (mu >= T(0)) return {c / (c * mu + T(1)), T(0)};
    const T d = x * mu * mu / (T(1) + sin_chi);
    const T x0_50 = x50 * sin_chi;
    const T c0 = std::sqrt(x0_50);
    const T decay = UseExp2pp ? exp2pp_impl(-d * inv_ln2) : std::exp2(-d * inv_ln2);
    return {T(2) * c0 - c / (T(1) - c * mu) * decay, d};
}

// Kocifaj 1996 as distilled by Schüler (§2.3) and Golubev (Eq. 40):
//   Ch = ½ [cos chi + erfcx(sqrt(x cos²chi / 2)) (1/x + 2 − cos²chi) sqrt(pi x / 2)],
// with erfcx in double precision (float evaluates it in double).
//
// erfcx(y) = exp(y²) erfc(y), y ≥ 0: below y = 26 Boost's erfc (accurate to a few ulp far
// into its tail) times exp(y²), with y² split exactly into hi + lo so that exp(y²) keeps full
// relative precision; beyond (exp(y²) overflows) Laplace's continued fraction
// erfc(y) = e^{−y²}/√π · 1/(y + ½/(y + 1/(y + (3/2)/(y + …)))), 40 terms (converged to
// round-off for y ≥ 26). tests/test_chapman_properties.cpp checks it against libcerf.
inline double erfcx_nonnegative(double y) {
    if (!(y >= 0.0)) return std::numeric_limits<double>::quiet_NaN();
    if (y < 26.0) {
        const double hi = y * y;
        const double lo = std::fma(y, y, -hi);
        return std::exp(hi) * (1.0 + lo) * boost::math::erfc(y);
    }
    double t = y;
    for (int k = 40; k >= 1; --k) t = y + 0.5 * k / t;
    return 1.0 / (std::sqrt(std::numbers::pi) * t);
}

template <class T>
inline T kocifaj_upper(T x, T mu) {
    const T e = static_cast<T>(erfcx_nonnegative(static_cast<double>(std::sqrt(x * mu * mu / T(2)))));
    return T(0.5) * (mu + e * (T(1) / x + T(2) - mu * mu) * std::sqrt(std::numbers::pi_v<T> * x / T(2)));
}

template <class T>
inline ScaledChapman<T> chapman_kocifaj1996(T x, T mu, T sin_chi) {
    return reflect_below_horizon<T>(x, mu, sin_chi, [](T x_, T m) { return kocifaj_upper(x_, m); },
                                    [](T x0) { return kocifaj_horizontal(x0); });
}

// Golubev 2019, code listing for Eq. 45 (ChapmanUpperApprox / ChapmanHorizontal /
// RescaledChapmanFunction); Eq. 45's "a z" is the listing's "c z".
template <class T>
inline T golubev_upper(T z, T c) {
    const T n = T(0.761643) * ((T(1) + T(2) * z) - (c * c * z));
    const T d = c * z + std::sqrt(z * (T(1.47721) + T(0.273828) * (c * c * z)));
    return T(0.5) * c + n / d;
}
template <class T>
inline T golubev_horizontal(T z) {
    const T r = T(1) / std::sqrt(z);
    const T s = z * r;
    return T(0.626657) * (r + T(2) * s);
}

template <class T>
inline ScaledChapman<T> chapman_golubev2019(T x, T mu, T sin_chi) {
    return reflect_below_horizon<T>(x, mu, sin_chi, [](T z, T m) { return golubev_upper(z, m); },
                                    [](T z0) { return golubev_horizontal(z0); });
}

}  // namespace detail
}  // namespace airmass
