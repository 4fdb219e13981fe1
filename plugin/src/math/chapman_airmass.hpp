// The `airmass` method: our own Chapman function, max. relative error ≤ 1e-6 over
// x ∈ [1e-2, 1e7] and chi ∈ [0°, 180°] at the cost of a fast approximation.
//
// Above the horizon, Ch = B(x, mu) · R(w, v): B is Schüler's rational form with a
// horizontal value that is right at both ends (chapman_internal.hpp), and R = Ch / B,
// a smooth function bounded in [~0.9, ~1.2], is read from a table in the coordinates
//     w = 1 / (1 + sqrt x),   v = mu (1 + Y) / (1 + mu Y),   Y = sqrt(x / 2),
// with tensor-product cubic Lagrange interpolation (4th order), stored per cell as
// bicubic polynomial coefficients. The table is made at build time from the exact
// quadrature by plugin/tools/gen_chapman_table.cpp.
// Below the horizon the reflection identity is exact; Ch∥(x0) is the v = 0 column.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

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

// Start of the 4-node stencil for cell i of n nodes (one-sided at the edges).
inline int stencil_start(int cell, int n) { return std::clamp(cell, 1, n - 3) - 1; }

// The node values R(w_i, v_j) and their tensor-product cubic Lagrange interpolant.
// Used by the generator, which turns it into per-cell polynomials (AirmassTable).
struct AirmassNodes {
    const double* values;  // rows w, columns v
    int n_w;
    int n_v;

    double interpolate(double w, double v) const {
        const double sw = w * (n_w - 1), sv = v * (n_v - 1);
        const int iw = stencil_start(std::min(int(sw), n_w - 2), n_w);
        const int iv = stencil_start(std::min(int(sv), n_v - 2), n_v);
        double ww[4], wv[4];
        lagrange4(sw - (iw + 1), ww);
        lagrange4(sv - (iv + 1), wv);
        double sum = 0;
        for (int a = 0; a < 4; ++a)
            for (int b = 0; b < 4; ++b) sum += ww[a] * wv[b] * values[(iw + a) * n_v + iv + b];
        return sum;
    }
};

// The same interpolant stored per cell as a bicubic polynomial in the cell's local
// coordinates (t, u) ∈ [0, 1]²: 16 coefficients c[a][b] of t^a u^b, contiguous, so an
// evaluation is one 128-byte read and 15 FMAs (Horner) with no weights to compute.
struct AirmassTable {
    const double* coefficients;  // cell (i, j) at (i * (n_v − 1) + j) * 16
    int n_w;                     // nodes along w (cells: n_w − 1)
    int n_v;                     // nodes along v

    template <class T>
    static int cell(T u, int n, T& local) {
        const T s = u * T(n - 1);
        const int i = std::min(static_cast<int>(s), n - 2);
        local = s - T(i);
        return i;
    }

    template <class T>
    T interpolate(T w, T v) const {
        T t, u;
        const int i = cell(w, n_w, t), j = cell(v, n_v, u);
        const double* c = coefficients + (static_cast<size_t>(i) * (n_v - 1) + j) * 16;
        T row[4];
        for (int a = 0; a < 4; ++a)
            row[a] = ((T(c[4 * a + 3]) * u + T(c[4 * a + 2])) * u + T(c[4 * a + 1])) * u + T(c[4 * a]);
        return ((row[3] * t + row[2]) * t + row[1]) * t + row[0];
    }

    template <class T>
    T interpolate_column0(T w) const {
        T t;
        const int i = cell(w, n_w, t);
        const double* c = coefficients + static_cast<size_t>(i) * (n_v - 1) * 16;
        return ((T(c[12]) * t + T(c[8])) * t + T(c[4])) * t + T(c[0]);
    }

    // Ch(x, chi) for mu = cos chi ∈ [0, 1]. The three quotients w, v and B share one
    // division: with a = 1 + sqrt x, b = 1 + mu Y, q = (c − 1) mu + 1 and D = a b q,
    //     w = b q / D,   v = mu (1 + Y) a q / D,   B = c a b / D.
    template <class T>
    T upper(T x, T mu) const {
        if (!(x <= std::numeric_limits<T>::max())) return mu > T(0) ? T(1) / mu : x;  // the plane-parallel limit
        const T sx = std::sqrt(x);
        const T Y = sx * T(0.70710678118654752);
        const T c = airmass_base_horizontal(sx);
        const T a = T(1) + sx, b = T(1) + mu * Y, q = (c - T(1)) * mu + T(1);
        const T ab = a * b;
        const T D = ab * q;
        // x beyond ~1e200 (double) or ~1e29 (float): D = a b q overflows and the shared division
        // would give 0 · inf = NaN table coordinates; divide separately (w = 1/a, v = mu (1 + Y)/b,
        // base = c/q), which is exact and finite there.
        if (!(D <= std::numeric_limits<T>::max())) return c / q * interpolate(T(1) / a, std::min(mu * (T(1) + Y) / b, T(1)));
        const T inv = T(1) / D;
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
