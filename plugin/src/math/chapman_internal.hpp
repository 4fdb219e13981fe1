// Internal declarations shared by the Chapman method implementations, the table
// generator and the dispatcher. Not installed.
#pragma once

#include <cmath>

#include "airmass/chapman.hpp"

namespace airmass::detail {

// ---- exact (chapman_exact.cpp) -------------------------------------------------
// Ch(x, chi) for chi ≤ 90° (mu = cos chi in [0, 1]) by adaptive Gauss–Kronrod
// quadrature of the substituted integral (see chapman_exact.cpp); x ≥ 0.
double chapman_upper_exact(double x, double mu);
ScaledChapman<double> chapman_exact_scaled(double x, double mu, double sin_chi);

// ---- the reflection identity (Schüler 2012 §2.4.2, Golubev Eq. 42) -----------------
// Below the horizon, Ch(x, chi) = 2 exp(x − x0) Ch∥(x0) − Ch(x, 180° − chi), x0 = x sin chi.
// In scaled form with d = x − x0 = x cos²chi / (1 + sin chi) (no cancellation):
//     mantissa = 2 Ch∥(x0) − Ch(x, 180° − chi) exp(−d),  log_scale = d.
// `upper(x, mu)` and `horizontal(x0)` are the method's own pieces, as its author used them.
template <class T, class Upper, class Horizontal>
inline ScaledChapman<T> reflect_below_horizon(T x, T mu, T sin_chi, Upper upper, Horizontal horizontal) {
    if (mu >= T(0)) return {upper(x, mu), T(0)};
    const T d = x * mu * mu / (T(1) + sin_chi);
    const T x0 = x * sin_chi;
    return {T(2) * horizontal(x0) - upper(x, -mu) * std::exp(-d), d};
}

// The exponent of Ch_h(X, h, χ) = mantissa · e^(log_scale − h). Below the horizon every method's
// log_scale is d = (X + h) cos²χ/(1 + sin χ), and d − h = X cos²χ/(1 + sin χ) − h sin χ (= X − x₀,
// the periapsis' depth below the reference level): formed so, without subtracting two terms of
// the size of h (whose rounding, h·1e-16, is the whole exponent for h = 1e308).
template <class T>
inline T rescaled_exponent(T log_scale, T X, T h, T cos_chi, T sin_chi) {
    if (log_scale == T(0)) return -h;
    return X * cos_chi * cos_chi / (T(1) + sin_chi) - h * sin_chi;
}

// ---- the `airmass` method's base (chapman_airmass.hpp, generator) -------------------
// Base function: Schüler's rational form B = c/((c − 1) mu + 1) with a horizontal
// value c = 1 + sqrt(pi x / 2) that is right at both ends (1 at x = 0, ~sqrt(pi x/2)
// for x → ∞) and costs no more than the sqrt(x) the table coordinates need anyway.
template <class T>
inline T airmass_base_horizontal(T sqrt_x) {
    return T(1) + T(1.2533141373155003) * sqrt_x;
}

}  // namespace airmass::detail
