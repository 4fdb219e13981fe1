// The exact Chapman function, by numerical quadrature.
//
// For chi ≤ 90° substitute s = (height gained above the observer, in scale heights)
// in the defining integral (Golubev Eq. 35); with r(u)² = x² + 2xu mu + u²:
//     Ch(x, chi) = ∫_0^∞ e^(−s) (x + s) / sqrt(x² mu² + 2 x s + s²) ds,
// and then s = t², which removes the 1/sqrt(s) singularity at mu = 0:
//     Ch(x, chi) = ∫_0^∞ e^(−t²) · 2 (x + t²) / sqrt((x mu / t)² + 2x + t²) dt.
// The integrand is smooth except for a change of regime at t_k = mu sqrt(x / 2)
// (where (x mu / t)² = 2x; the integrand's branch points sit at ±i t_k); we split
// there and integrate each piece with tanh-sinh quadrature (Boost.Math), which
// converges double-exponentially on both (adaptive Gauss–Kronrod stalls on the
// short piece [0, t_k]), to a relative tolerance of 1e-14. The weight
// e^(−t²) makes t > 9.5 negligible (e^(−90) relative).
// Below the horizon the reflection identity (chapman_internal.hpp) is exact.
#include <boost/math/quadrature/tanh_sinh.hpp>
#include <cmath>
#include <limits>

#include "chapman_internal.hpp"

namespace airmass::detail {

namespace {

double integrate(auto f, double a, double b) {
    if (!(b > a)) return 0.0;
    // A local integrator: Boost's caches its abscissae lazily, and a shared one would be state.
    boost::math::quadrature::tanh_sinh<double> quadrature(12);
    return quadrature.integrate(f, a, b, 1e-14);
}

}  // namespace

double chapman_upper_exact(double x, double mu) {
    // Two-argument form: Boost passes the distance to the nearer endpoint as well and
    // then lets abscissae round onto an endpoint; t = 0 takes the integrand's limit.
    // Above x = 1e100 numerator and root are divided by x: (x mu / t)² overflowed from x ≈ 1e154 on
    // and gave Ch = 0 (ln Ch = -inf) from x ≈ 1e200, a NaN and Boost's evaluation_error at 1e308
    // (fuzz_csv). Below, the form (and every bit of the tables built from it) is unchanged.
    // x = +inf: the plane-parallel limit, as the `airmass` method (the quadrature of the scaled
    // form would divide by 0 at mu = 0 and Boost throw); NaN stays NaN.
    if (!(x <= std::numeric_limits<double>::max())) return mu > 0.0 ? 1.0 / mu : x;
    const bool scaled = x > 1e100;
    const auto integrand = [x, mu, scaled](double t, double /*distance_to_endpoint*/) {
        if (t <= 0.0) return mu > 0.0 ? 0.0 : std::sqrt(2.0) * std::sqrt(x);
        const double t2 = t * t;
        if (scaled) {
            const double a = mu / t;
            const double tx = t / x;
            const double den = std::sqrt(a * a + 2.0 / x + tx * tx);  // > 0: 2 / x is for x <= 1.8e308
            return 2.0 * (1.0 + t2 / x) / den * std::exp(-t2);
        }
        const double a = x * mu / t;
        const double den = std::sqrt(a * a + 2.0 * x + t2);  // 0 only when x = 0 and t² underflows
        return den > 0.0 ? 2.0 * (x + t2) / den * std::exp(-t2) : 0.0;
    };
    constexpr double t_end = 9.5;
    const double t_k = mu * std::sqrt(0.5 * x);
    if (t_k <= 0.0 || t_k >= t_end) return integrate(integrand, 0.0, t_end);
    return integrate(integrand, 0.0, t_k) + integrate(integrand, t_k, t_end);
}

ScaledChapman<double> chapman_exact_scaled(double x, double mu, double sin_chi) {
    return reflect_below_horizon<double>(
        x, mu, sin_chi, [](double x_, double m) { return chapman_upper_exact(x_, m); },
        [](double x0) { return chapman_upper_exact(x0, 0.0); });
}

}  // namespace airmass::detail

namespace airmass {

double chapman_horizontal_exact(double x) { return detail::chapman_upper_exact(x, 0.0); }

}  // namespace airmass
