// The `airmass` method: our own Chapman function, max. relative error ≤ 1e-6 over
// x ∈ [1e-2, 1e7] and chi ∈ [0°, 180°] at the cost of a fast approximation.
//
// Above the horizon, Ch = B(x, mu) · R(w, v): B is Schüler's rational form with a
// horizontal value that is right at both ends (chapman_internal.hpp), and R = Ch / B,
// a smooth function bounded in [~0.9, ~1.2], is read from a table in the coordinates
//     w = 1 / (1 + sqrt x),   v = mu (1 + Y) / (1 + mu Y),   Y = sqrt(x / 2),
// with tensor-product cubic Lagrange interpolation (4th order). The table is made at
// build time from the exact quadrature by plugin/tools/gen_chapman_table.cpp.
// Below the horizon the reflection identity is exact; Ch∥(x0) is the v = 0 column.
#pragma once

#include <algorithm>
#include <cmath>

#include "chapman_internal.hpp"

namespace airmass::detail {

// Cubic Lagrange weights for stencil nodes −1, 0, 1, 2 at position t (t ∈ [−1, 2]).
template <class T>
inline void lagrange4(T t, T w[4]) {
    const T tp1 = t + T(1), tm1 = t - T(1), tm2 = t - T(2);
    w[0] = -t * tm1 * tm2 * T(1.0 / 6.0);
    w[1] = tp1 * tm1 * tm2 * T(0.5);
    w[2] = -tp1 * t * tm2 * T(0.5);
    w[3] = tp1 * t * tm1 * T(1.0 / 6.0);
}

// Stencil start index and local coordinate for u ∈ [0, 1] on n uniform nodes.
template <class T>
inline int stencil(T u, int n, T& t) {
    const T s = u * T(n - 1);
    const int i = std::clamp(static_cast<int>(s), 1, n - 3);
    t = s - T(i);
    return i - 1;
}

// A table of R(w, v) (rows w, columns v) and its evaluation.
struct AirmassTable {
    const double* values;
    int n_w;
    int n_v;

    template <class T>
    T interpolate(T w, T v) const {
        T tw, tv, ww[4], wv[4];
        const int iw = stencil(w, n_w, tw);
        const int iv = stencil(v, n_v, tv);
        lagrange4(tw, ww);
        lagrange4(tv, wv);
        T sum = T(0);
        for (int a = 0; a < 4; ++a) {
            const double* row = values + (iw + a) * n_v + iv;
            const T r = wv[0] * T(row[0]) + wv[1] * T(row[1]) + wv[2] * T(row[2]) + wv[3] * T(row[3]);
            sum += ww[a] * r;
        }
        return sum;
    }

    template <class T>
    T interpolate_column0(T w) const {
        T tw, ww[4];
        const int iw = stencil(w, n_w, tw);
        lagrange4(tw, ww);
        T sum = T(0);
        for (int a = 0; a < 4; ++a) sum += ww[a] * T(values[(iw + a) * n_v]);
        return sum;
    }

    // Ch(x, chi) for mu = cos chi ∈ [0, 1]. The three quotients w, v and B share one
    // division: with a = 1 + sqrt x, b = 1 + mu Y, q = (c − 1) mu + 1 and D = a b q,
    //     w = b q / D,   v = mu (1 + Y) a q / D,   B = c a b / D.
    template <class T>
    T upper(T x, T mu) const {
        const T sx = std::sqrt(x);
        const T Y = sx * T(0.70710678118654752);
        const T c = airmass_base_horizontal(sx);
        const T a = T(1) + sx, b = T(1) + mu * Y, q = (c - T(1)) * mu + T(1);
        const T ab = a * b;
        const T inv = T(1) / (ab * q);
        const T w = b * q * inv;
        const T v = mu * (T(1) + Y) * a * q * inv;
        const T base = c * ab * inv;
        return base * interpolate(w, std::min(v, T(1)));
    }

    // Ch∥(x) = Ch(x, 90°).
    template <class T>
    T horizontal(T x) const {
        const T sx = std::sqrt(x);
        return airmass_base_horizontal(sx) * interpolate_column0(T(1) / (T(1) + sx));
    }

    template <class T>
    ScaledChapman<T> scaled(T x, T mu, T sin_chi) const {
        return reflect_below_horizon<T>(
            x, mu, sin_chi, [this](T x_, T m) { return upper(x_, m); }, [this](T x0) { return horizontal(x0); });
    }
};

// Table coordinates → (x, mu), for the generator. w ∈ (0, 1], v ∈ [0, 1].
inline void airmass_table_point(double w, double v, double& x, double& mu) {
    const double sx = (1.0 - w) / w;
    x = sx * sx;
    const double Y = sx * 0.70710678118654752;
    mu = v / (1.0 + Y - v * Y);
}

// The built-in table (generated chapman_airmass_table.cpp).
const AirmassTable& airmass_table();

}  // namespace airmass::detail
