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
// Below the horizon the reflection identity is exact; on the fast paths Ch∥(x0) comes from a
// table of its own indexed by the bits of x0 (airmass_parallel), on the careful path from the
// v = 0 column.
#pragma once

#include <algorithm>
#include <bit>
#include <cstddef>
#include <cstring>

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

    // NaN (a NaN x or cos chi on the careful path) gives cell 0 and a NaN local coordinate, so a
    // NaN result: converting NaN to int is undefined (GCC gives INT_MIN, a read far outside the
    // table).
    template <class T>
    static int cell(T u, int n, T& local) {
        const T s = u * T(n - 1);
        const int i = s >= T(0) ? static_cast<int>(std::min(s, T(n - 2))) : 0;
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
        const T base = c * (ab * inv);  // ab · inv = 1/q ≤ 1 first: c · ab overflows for x near the largest T
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

// ---- The fast path (chapman.cpp's scalar form; chapman_airmass_batch.inc the batch) -------
// The same interpolant as AirmassTable::scaled, arranged for speed: one square root (√x),
// independent divisions whose latencies overlap, the table read on 2-double vectors, below the
// horizon Ch∥(x0) from its own table by the bits of x0 (airmass_parallel), and a polynomial exp. The batch kernel evaluates the same formulas four lanes at a time (with one
// shared division), so batch and scalar agree to rounding (tests/test_chapman_batch.cpp).
// The arithmetic is in double for float and double inputs: float then costs no accuracy in
// d = x − x0, which multiplies the whole value.
// Inputs the fast path cannot take (x beyond ~1e150, +inf or NaN; below the horizon x sin chi
// ≥ 2^40, beyond the Ch∥ table) go through AirmassTable::scaled.

// e^(−d) for d ≥ 0 (d > 700 gives e^(−700), which no caller can tell from 0 beside the O(1)
// terms it is added to): d = k ln 2 + r, |r| ≤ ln2/2, e^(−r) by its Taylor polynomial to degree
// 7 (truncation ≤ |r|^8 e^|r| / 8! ≤ 7.3e-9, against the method's 1e-6; the identity's mantissa
// inherits at most this relative error, since Ch(x, 180° − chi) e^(−d) ≤ Ch∥(x0); degree 9 cost
// three more vector operations in the batch, whose time is the count of its vector operations),
// in Estrin's scheme (a short dependency chain), and 2^(−k)
// built in the exponent bits. Branch-free. Written once for double and for 4-double vectors.
template <class V, class Bits>
inline V airmass_exp_neg_poly(V d, V kb, double round_magic) {
    constexpr double ln2_hi = 0.6931471805598903, ln2_lo = 5.497923018708371e-14;
    const V k = kb - round_magic;
    const V y = (k * ln2_hi - d) + k * ln2_lo;  // −r
    const V y2 = y * y, y4 = y2 * y2;
    const V p01 = 1.0 + y, p23 = 0.5 + y * (1.0 / 6.0), p45 = 1.0 / 24.0 + y * (1.0 / 120.0);
    const V p67 = 1.0 / 720.0 + y * (1.0 / 5040.0);
    return (p01 + y2 * p23) + y4 * (p45 + y2 * p67);
}

inline double airmass_exp_neg(double d) {
    d = d < 700.0 ? d : 700.0;
    constexpr double inv_ln2 = 1.4426950408889634;
    constexpr double round_magic = 6755399441055744.0;  // 1.5 · 2^52: adding it rounds to an integer
    const double kb = d * inv_ln2 + round_magic;
    const double p = airmass_exp_neg_poly<double, unsigned long long>(d, kb, round_magic);
    // k = the low bits of kb (0 ≤ k ≤ 1010): 2^(−k) has biased exponent 1023 − k.
    const unsigned long long kbits = std::bit_cast<unsigned long long>(kb) - std::bit_cast<unsigned long long>(round_magic);
    return p * std::bit_cast<double>((1023ull - kbits) << 52);
}

// The bicubic at (t, u) in the cell whose coefficients start at `cell`. Estrin's scheme in t on
// the four groups of u-coefficients at once, then in u: two dependent multiply-adds each way
// instead of three. On 2-double vectors (one SSE2 register each; GCC and Clang vector
// extensions): a 4-double vector in baseline code is a register pair, and GCC built its splat of
// t through the stack, two 8-byte stores read back by one 16-byte load, a failed store forwarding
// that was half of the scalar path's time (perf annotate).
#if defined(__GNUC__) || defined(__clang__)
#define AIRMASS_CHAPMAN_VECTORS 1
typedef double AirmassV4 __attribute__((vector_size(32)));  // the baseline batch kernel's lanes
typedef double AirmassV2 __attribute__((vector_size(16)));
[[gnu::always_inline]] inline double airmass_read(const double* coefficients, int cell, double t, double u) {
    const double* c = coefficients + cell;
    AirmassV2 g[8];
    std::memcpy(g, c, sizeof g);
    const AirmassV2 tv{t, t}, t2{t * t, t * t};
    const AirmassV2 lo = (g[0] + g[2] * tv) + (g[4] + g[6] * tv) * t2;  // coefficients of u^0, u^1
    const AirmassV2 hi = (g[1] + g[3] * tv) + (g[5] + g[7] * tv) * t2;  // of u^2, u^3
    return (lo[0] + lo[1] * u) + (hi[0] + hi[1] * u) * (u * u);
}
#else
#define AIRMASS_CHAPMAN_VECTORS 0
[[gnu::always_inline]] inline double airmass_read(const double* coefficients, int cell, double t, double u) {
    const double* c = coefficients + cell;
    double col[4];
    for (int b = 0; b < 4; ++b) col[b] = (c[b] + c[4 + b] * t) + (c[8 + b] + c[12 + b] * t) * (t * t);
    return (col[0] + col[1] * u) + (col[2] + col[3] * u) * (u * u);
}
#endif

// Ch∥(x0) below the horizon, from a table of its own indexed by the bits of x0 (no square root, no
// division): x0 = 2^e (1 + f), the cell is e and the top kParallelCellBits bits of f (contiguous
// over octaves: the bits above bit kParallelShift, less the table's first), the local coordinate
// τ ∈ [0, 2^−kParallelCellBits) the rest of f, and the cell holds the cubic in τ of Ch∥ over it,
// through the exact quadrature at its ends and at a quarter and three quarters of it (continuous
// from cell to cell; plugin/tools/gen_chapman_table.cpp, whose --check prints its error).
// The table's first cell is zeros (the batch points lanes that need no Ch∥ at it); the cells of x0
// follow it. Octaves e ∈ [kParallelExpLo, kParallelExpHi]. Below 2^kParallelExpLo, x0 is raised to it:
// Ch∥(x0) = 1 + x0 + O(x0² ln x0), a relative change ≤ 2^kParallelExpLo ≈ 9.3e-10. From
// 2^(kParallelExpHi + 1) ≈ 1.1e12 on the fast paths send the lane to the careful one.
constexpr int kParallelCellBits = 4;   // 16 cells per octave
constexpr int kParallelExpLo = -30;    // x0 < 2^−30: as 2^−30
constexpr int kParallelExpHi = 39;     // the last octave in the table, [2^39, 2^40)
constexpr int kParallelCells = (kParallelExpHi - kParallelExpLo + 1) << kParallelCellBits;
constexpr int kParallelShift = 52 - kParallelCellBits;
// Offset (in doubles) of x0's cell: (bits(x0) >> kParallelShift) · 4 − kParallelBias.
constexpr unsigned long long kParallelBias = ((static_cast<unsigned long long>(1023 + kParallelExpLo) << kParallelCellBits) - 1) * 4;
constexpr double kParallelLo = 0x1p-30;
constexpr double kParallelEnd = 0x1p40;                  // fast paths: x0 < kParallelEnd
constexpr double kParallelHi = 0x1.fffffffffffffp39;     // the largest double below it
static_assert(kParallelExpLo == -30 && kParallelExpHi == 39);

// The cell (as the offset of its 4 coefficients) and τ of x0, clamped to [kParallelLo, kParallelHi]
// (NaN gives kParallelLo): any x0 gives a cell inside the table.
inline int airmass_parallel_cell(double x0, double& tau) {
    x0 = x0 >= kParallelLo ? x0 : kParallelLo;
    x0 = x0 <= kParallelHi ? x0 : kParallelHi;
    const unsigned long long bits = std::bit_cast<unsigned long long>(x0);
    tau = std::bit_cast<double>((bits & ((1ull << kParallelShift) - 1)) | 0x3FF0000000000000ull) - 1.0;
    return static_cast<int>((bits >> kParallelShift) * 4 - kParallelBias);
}

inline double airmass_read_parallel(const double* parallel, int off, double tau) {
    const double* c = parallel + off;
    return (c[0] + c[1] * tau) + (c[2] + c[3] * tau) * (tau * tau);
}

// Ch∥(x0) from the table, for x0 ∈ [0, kParallelEnd).
inline double airmass_parallel(const double* parallel, double x0) {
    double tau;
    const int off = airmass_parallel_cell(x0, tau);
    return airmass_read_parallel(parallel, off, tau);
}

// The built-in Ch∥ table: 1 + kParallelCells cells × 4 coefficients (generated chapman_airmass_table.cpp).
const double* airmass_parallel_table();

// One lane, for the scalar API. Above the horizon only what the upper branch needs (one square
// root, three independent divisions, one table read); below, also Ch∥(x0) and e^(−d).
template <class T>
inline ScaledChapman<T> airmass_scaled_fast(const AirmassTable& table, const double* parallel, T x_in, T mu_in, T s_in) {
    const double x = x_in, mu = mu_in;
    if (mu >= 0.0) {
        const double sx = std::sqrt(x);
        const double Y = sx * 0.70710678118654752;
        const double c = airmass_base_horizontal(sx);
        const double a = 1.0 + sx, b = 1.0 + mu * Y, q = (c - 1.0) * mu + 1.0;
        // Three independent divisions: on one lane their latencies overlap, which is shorter
        // than the batch's shared division (three multiplications before and after it).
        // Negative, huge or NaN x, and cos chi = +inf: the careful path (a NaN index would read outside
        // the table; cos chi = +inf gives NaN there, as in the batch kernels, whose a b q > 1e300 sends it).
        if (!(x >= 0.0 && x <= 1e300 && mu < std::numeric_limits<double>::infinity())) return table.scaled(x_in, mu_in, s_in);
        const double w = 1.0 / a;
        const double v_raw = mu * (1.0 + Y) / b;
        const double v = v_raw < 1.0 ? v_raw : 1.0;
        const double base = c / q;
        const double sw = w * (table.n_w - 1), sv = v * (table.n_v - 1);
        int iw = static_cast<int>(sw), iv = static_cast<int>(sv);
        iw = iw < table.n_w - 2 ? iw : table.n_w - 2;
        iv = iv < table.n_v - 2 ? iv : table.n_v - 2;
        const double r = airmass_read(table.coefficients, (iw * (table.n_v - 1) + iv) * 16, sw - iw, sv - iv);
        return {static_cast<T>(base * r), T(0)};
    }
    // Below: the same with m = −mu, Ch∥(x0) from its own table and d; again independent divisions (four).
    const double s = s_in;
    // Beyond x ~ 1e150, x sin chi beyond the Ch∥ table, cos chi < −1 (−inf: NaN there) and for negative
    // or NaN x or sin chi the careful path, as the batch kernels do.
    const double x0 = x * s;
    if (!(x >= 0.0 && x <= 1e150 && mu >= -1.0) || !(s >= 0.0) || !(x0 < kParallelEnd)) return table.scaled(x_in, mu_in, s_in);
    const double m = -mu;
    const double sx = std::sqrt(x);
    const double Y = sx * 0.70710678118654752;
    const double c = airmass_base_horizontal(sx);
    const double a = 1.0 + sx, b = 1.0 + m * Y, q = (c - 1.0) * m + 1.0;
    const double sp = 1.0 + s;
    const double w = 1.0 / a;
    const double v_raw = m * (1.0 + Y) / b;
    const double v = v_raw < 1.0 ? v_raw : 1.0;
    const double base = c / q;
    const double d = x * m * m / sp;
    const int n_w = table.n_w, n_v = table.n_v;
    const double sw = w * (n_w - 1), sv = v * (n_v - 1);
    int iw = static_cast<int>(sw), iv = static_cast<int>(sv);
    iw = iw < n_w - 2 ? iw : n_w - 2;
    iv = iv < n_v - 2 ? iv : n_v - 2;
    const double r = airmass_read(table.coefficients, (iw * (n_v - 1) + iv) * 16, sw - iw, sv - iv);
    const double h = airmass_parallel(parallel, x0);
    // The reflection identity in scaled form: mantissa = 2 Ch∥(x0) − Ch(x, 180° − chi) e^(−d).
    return {static_cast<T>(2.0 * h - base * r * airmass_exp_neg(d)), static_cast<T>(d)};
}

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
