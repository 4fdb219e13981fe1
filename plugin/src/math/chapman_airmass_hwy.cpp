// The `airmass` method's batch kernel for AVX2/FMA, written with Google Highway (header-only use;
// docs/chapman.md "Speed"). The same formulas as the baseline kernel (chapman_airmass_batch.inc)
// and the scalar path (chapman_airmass.hpp, airmass_scaled_fast), four double lanes per AVX
// register, with the square roots, the shared division, the cell indices and exp(−d) as vector
// instructions, and the table read per lane (four 256-bit loads, three FMAs) followed by one 4×4
// transpose and the Horner step in u on all four lanes at once.
//
// Highway is used without libhwy: no HWY_EXPORT / HWY_DYNAMIC_DISPATCH (they need libhwy's
// hwy::GetChosenTarget and hwy::SupportedTargets). foreach_target.h compiles this file once per
// target in HWY_TARGETS, each inside Highway's own target pragmas; only the AVX2 pass holds code,
// and chapman.cpp calls it after our own CPU check (airmass::simd_target(), simd.cpp). Nothing
// here references hwy::Abort (HWY_IS_DEBUG_BUILD is 0 even in sanitizer builds, so no
// HWY_DASSERT; `nm` of the library shows no hwy:: symbol), so the library links no libhwy.
// Only where the library dispatches at all (AIRMASS_SIMD_DISPATCH: x86-64 GCC/Clang, not macOS).
#include "airmass/simd.hpp"

#if AIRMASS_SIMD_DISPATCH

#include "math/chapman_airmass_hwy.hpp"

#ifndef HWY_IS_DEBUG_BUILD
#define HWY_IS_DEBUG_BUILD 0  // no HWY_DASSERT, hence no reference to libhwy's hwy::Abort
#endif
// Only AVX2 (and Highway's mandatory static target, which holds nothing here).
#ifndef HWY_DISABLED_TARGETS
#define HWY_DISABLED_TARGETS (HWY_AVX3 | HWY_AVX3_DL | HWY_SSE4 | HWY_SSSE3)
#endif

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "math/chapman_airmass_hwy.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/cache_control.h>
#include <hwy/highway.h>

#include <cmath>
#include <cstddef>
#include <cstdint>

#include "math/chapman_airmass.hpp"

HWY_BEFORE_NAMESPACE();
namespace airmass::airmass_hwy {
namespace HWY_NAMESPACE {
#if HWY_TARGET == HWY_AVX2
namespace hn = hwy::HWY_NAMESPACE;
using detail::AirmassTable;

using DD = hn::Full256<double>;
using V = hn::Vec<DD>;
using M = hn::Mask<DD>;

// e^(−d) for d ≥ 0: airmass_exp_neg_poly (chapman_airmass.hpp) on four lanes.
HWY_INLINE V exp_neg(V d) {
    const DD dd;
    const hn::RebindToSigned<DD> di;
    d = hn::Min(d, hn::Set(dd, 700.0));  // NaN → 700, as the scalar path's d < 700 ? d : 700
    const V magic = hn::Set(dd, 6755399441055744.0);
    const V kb = hn::MulAdd(d, hn::Set(dd, 1.4426950408889634), magic);
    const V k = hn::Sub(kb, magic);
    const V y = hn::MulAdd(k, hn::Set(dd, 5.497923018708371e-14), hn::MulSub(k, hn::Set(dd, 0.6931471805598903), d));
    const V y2 = hn::Mul(y, y), y4 = hn::Mul(y2, y2);
    const V p01 = hn::Add(hn::Set(dd, 1.0), y);
    const V p23 = hn::MulAdd(y, hn::Set(dd, 1.0 / 6.0), hn::Set(dd, 0.5));
    const V p45 = hn::MulAdd(y, hn::Set(dd, 1.0 / 120.0), hn::Set(dd, 1.0 / 24.0));
    const V p67 = hn::MulAdd(y, hn::Set(dd, 1.0 / 5040.0), hn::Set(dd, 1.0 / 720.0));
    const V p = hn::MulAdd(y4, hn::MulAdd(y2, p67, p45), hn::MulAdd(y2, p23, p01));
    const auto kbits = hn::Sub(hn::BitCast(di, kb), hn::BitCast(di, magic));
    return hn::Mul(p, hn::BitCast(dd, hn::ShiftLeft<52>(hn::Sub(hn::Set(di, 1023), kbits))));
}

// Cell index along an axis of n nodes at s = coordinate · (n − 1) ≥ 0 (as a double: exact), and
// the local coordinate in it.
HWY_INLINE V cell(V s, int n, V& local) {
    const DD dd;
    const V i = hn::Min(hn::Floor(s), hn::Set(dd, double(n - 2)));
    local = hn::Sub(s, i);
    return i;
}

// A chunk of kBlocks blocks of four lanes goes through two passes: stage_a computes every block's
// table cells and factors (square roots, the shared division, exp(−d)) into the chunk, stage_b
// reads the table and forms the results. On one block the whole chain (sqrt → division → cell →
// table read → Horner) is ~150 cycles of latency, longer than the reorder window of a Zen 1
// core; in passes, every block of a pass is independent of the others, so their latencies
// overlap and the table reads (random, mostly L1 misses) are in flight together.
constexpr size_t kBlocks = 16;

struct Chunk {
    HWY_ALIGN double t[kBlocks * 4], u[kBlocks * 4], t0[kBlocks * 4];
    HWY_ALIGN double factor[kBlocks * 4];     // the base B: mantissa = B R above the horizon
    HWY_ALIGN double factor0[kBlocks * 4];    // 2 c0 below, 0 above (stage b: e^(−d) = −1 there)
    // log_scale: d below, 0 above; stage b takes e^(−d) from it.
    HWY_ALIGN double log_scale[kBlocks * 4];
    HWY_ALIGN double mantissa[kBlocks * 4];
    HWY_ALIGN int32_t off[kBlocks * 4], off0[kBlocks * 4];
    uint8_t slow[kBlocks];   // lanes the fast path cannot take (bit k: lane k)
    bool below[kBlocks];     // any lane below the horizon
};

// Element offsets (exact in double) → four int32 in memory.
HWY_INLINE void offsets(V off, int32_t* out) {
    const DD dd;
    const hn::Rebind<int32_t, DD> di32;
    hn::Store(hn::DemoteTo(di32, off), di32, out);
}

// The bicubic's Horner step in t for one lane's cell: its four u-coefficient sums.
HWY_INLINE V read_t(const double* c, const double* t) {
    const DD dd;
    const V tv = hn::Set(dd, *t);
    const V g0 = hn::LoadU(dd, c), g1 = hn::LoadU(dd, c + 4), g2 = hn::LoadU(dd, c + 8), g3 = hn::LoadU(dd, c + 12);
    return hn::MulAdd(hn::MulAdd(hn::MulAdd(g3, tv, g2), tv, g1), tv, g0);  // Horner: throughput, not latency
}

// [lo.upper, hi.upper] without vperm2f128, which Zen 1 splits into 8 µops: two extracts and an
// insert.
HWY_INLINE V upper_upper(V hi, V lo) {
    const DD dd;
    const hn::Half<DD> dh;
    return hn::Combine(dd, hn::UpperHalf(dh, hi), hn::UpperHalf(dh, lo));
}

// 4×4 transpose: lane k of C_b is element b of col_k.
HWY_INLINE void transpose4(V col0, V col1, V col2, V col3, V& C0, V& C1, V& C2, V& C3) {
    const DD dd;
    const V t0 = hn::InterleaveLower(dd, col0, col1), t1 = hn::InterleaveUpper(dd, col0, col1);
    const V t2 = hn::InterleaveLower(dd, col2, col3), t3 = hn::InterleaveUpper(dd, col2, col3);
    C0 = hn::ConcatLowerLower(dd, t2, t0), C1 = hn::ConcatLowerLower(dd, t3, t1);
    C2 = upper_upper(t2, t0), C3 = upper_upper(t3, t1);
}

// The bicubic at four lanes' cells: per lane the t step, then a 4×4 transpose (lane k of C_b is
// lane k's coefficient of u^b) and the u step on all lanes.
HWY_INLINE V read(const double* coefficients, const int32_t* o, const double* t, V u) {
    const V col0 = read_t(coefficients + o[0], t), col1 = read_t(coefficients + o[1], t + 1);
    const V col2 = read_t(coefficients + o[2], t + 2), col3 = read_t(coefficients + o[3], t + 3);
    V C0, C1, C2, C3;
    transpose4(col0, col1, col2, col3, C0, C1, C2, C3);
    return hn::MulAdd(hn::MulAdd(hn::MulAdd(C3, u, C2), u, C1), u, C0);
}

// ... and the v = 0 column (u = 0), c[0] + c[4] t + c[8] t² + c[12] t³, from the column's own
// copy (airmass_column0: the four per cell contiguous, in L1), o[k] = 4 · cell: one load per lane,
// a transpose and Estrin in t on all lanes. (Per lane in scalars, with the four results stored
// and reloaded as a vector, was ~0.5 ns more per evaluation below the horizon, bench_chapman.)
HWY_INLINE V read_column0(const double* column0, const int32_t* o, V t) {
    const DD dd;
    V C0, C1, C2, C3;
    transpose4(hn::LoadU(dd, column0 + o[0]), hn::LoadU(dd, column0 + o[1]), hn::LoadU(dd, column0 + o[2]),
               hn::LoadU(dd, column0 + o[3]), C0, C1, C2, C3);
    return hn::MulAdd(hn::MulAdd(C3, t, C2), hn::Mul(t, t), hn::MulAdd(C1, t, C0));
}

// Stage a of block j: Ch's cells and factors for four lanes (formulas: chapman_airmass_batch.inc).
HWY_INLINE void stage_a(const AirmassTable& table, V x, V mu, V s, Chunk& ch, size_t j) {
    const DD dd;
    const size_t l = 4 * j;
    const V one = hn::Set(dd, 1.0), zero = hn::Zero(dd);
    const M below = hn::Lt(mu, zero);
    const V m = hn::Abs(mu);
    const V sx = hn::Sqrt(x);
    const V Y = hn::Mul(sx, hn::Set(dd, 0.70710678118654752));
    const V c = hn::MulAdd(hn::Set(dd, 1.2533141373155003), sx, one);
    const V a = hn::Add(one, sx), b = hn::MulAdd(m, Y, one), q = hn::MulAdd(hn::Sub(c, one), m, one);
    const V ab = hn::Mul(a, b);
    const V D = hn::Mul(ab, q);
    const V bq = hn::Mul(b, q), v_num = hn::Mul(hn::Mul(m, hn::Add(one, Y)), hn::Mul(a, q));
    const int n_w = table.n_w, n_v = table.n_v;
    const V wscale = hn::Set(dd, double(n_w - 1)), vscale = hn::Set(dd, double(n_v - 1));
    const V row = hn::Set(dd, double((n_v - 1) * 16)), sixteen = hn::Set(dd, 16.0);
    const bool any_below = !hn::AllFalse(dd, below);
    ch.below[j] = any_below;
    V inv_D;
    M slow;
    V w, v;
    if (!any_below) {
        slow = hn::Not(hn::Le(D, hn::Set(dd, 1e300)));
        inv_D = hn::Div(one, hn::IfThenElse(slow, one, D));
        hn::Store(zero, dd, ch.log_scale + l);
    } else {
        const V sp = hn::Add(one, s);
        const V sx0 = hn::Sqrt(hn::Mul(x, s));
        const V a0 = hn::Add(one, sx0);
        const V e = hn::Mul(a0, sp);
        const V P = hn::Mul(D, e);
        slow = hn::Not(hn::Le(P, hn::Set(dd, 1e300)));
        const V inv = hn::Div(one, hn::IfThenElse(slow, one, P));
        inv_D = hn::Mul(e, inv);
        const V w0 = hn::IfThenZeroElse(slow, hn::Mul(hn::Mul(D, sp), inv));
        V t0;
        const V iw0 = cell(hn::Mul(w0, wscale), n_w, t0);
        hn::Store(t0, dd, ch.t0 + l);
        offsets(hn::Mul(iw0, hn::Set(dd, 4.0)), ch.off0 + l);
        const V c0 = hn::MulAdd(hn::Set(dd, 1.2533141373155003), sx0, one);
        const V d = hn::Mul(hn::Mul(hn::Mul(x, hn::Mul(m, m)), hn::Mul(D, a0)), inv);
        hn::Store(hn::IfThenElseZero(below, hn::Add(c0, c0)), dd, ch.factor0 + l);
        hn::Store(hn::IfThenElseZero(below, d), dd, ch.log_scale + l);
    }
    w = hn::IfThenZeroElse(slow, hn::Mul(bq, inv_D));
    v = hn::IfThenZeroElse(slow, hn::Min(hn::Mul(v_num, inv_D), one));
    V t, u;
    const V iw = cell(hn::Mul(w, wscale), n_w, t), iv = cell(hn::Mul(v, vscale), n_v, u);
    hn::Store(t, dd, ch.t + l);
    hn::Store(u, dd, ch.u + l);
    offsets(hn::MulAdd(iw, row, hn::Mul(iv, sixteen)), ch.off + l);
    // The cells' two cache lines each, fetched while the rest of the chunk's stage a runs.
    for (size_t k = 0; k < 4; ++k) {
        hwy::Prefetch(table.coefficients + ch.off[l + k]);
        hwy::Prefetch(table.coefficients + ch.off[l + k] + 8);
    }
    hn::Store(hn::Mul(hn::Mul(c, ab), inv_D), dd, ch.factor + l);
    uint8_t bits[8] = {};
    hn::StoreMaskBits(dd, slow, bits);
    ch.slow[j] = bits[0];
}

// Stage b of block j: the table reads and the mantissa.
HWY_INLINE V stage_b(const AirmassTable& table, const double* column0, const Chunk& ch, size_t j) {
    const DD dd;
    const size_t l = 4 * j;
    const double* coefficients = table.coefficients;
    const V upper = hn::Mul(hn::Load(dd, ch.factor + l), read(coefficients, ch.off + l, ch.t + l, hn::Load(dd, ch.u + l)));
    if (!ch.below[j]) return upper;
    const V h = read_column0(column0, ch.off0 + l, hn::Load(dd, ch.t0 + l));
    // 2 c0 Ch∥(x0) − B R e^(−d) below; above (2 c0 = 0, e^(−d) = −1) exactly B R. e^(−d) here
    // rather than in stage a: it does not wait for the table read, and fills that latency (batch
    // below the horizon 5.93 → 5.69 ns, bench_chapman, interleaved runs).
    const V factor0 = hn::Load(dd, ch.factor0 + l);
    const V exp_d = hn::IfThenElse(hn::Gt(factor0, hn::Zero(dd)), exp_neg(hn::Load(dd, ch.log_scale + l)), hn::Set(dd, -1.0));
    return hn::NegMulAdd(upper, exp_d, hn::Mul(factor0, h));
}

// Loads four T as doubles.
template <class T>
HWY_INLINE V load4(const T* p) {
    const DD dd;
    if constexpr (sizeof(T) == sizeof(double)) {
        return hn::LoadU(dd, p);
    } else {
        return hn::PromoteTo(dd, hn::LoadU(hn::Rebind<float, DD>(), p));
    }
}

template <class T>
HWY_INLINE void store4(V v, T* p) {
    const DD dd;
    if constexpr (sizeof(T) == sizeof(double)) {
        hn::StoreU(v, dd, p);
    } else {
        const hn::Rebind<float, DD> df;
        hn::StoreU(hn::DemoteTo(df, v), df, p);
    }
}

// The batch. kRescaled: x = X + xh[i] (in T, as chapman_rescaled) and out1[i] = Ch(x) e^(−xh[i]);
// else x = xh[i], out1 = mantissa, out2 = log_scale. Lanes the fast path cannot take go through
// AirmassTable::scaled in T, as in the scalar form.
template <class T, bool kRescaled>
HWY_INLINE void batch(const AirmassTable& table, T X, const T* xh, const T* cs, const T* ss, size_t n, T* out1,
                      T* out2) {
    const DD dd;
    const auto x_of = [&](size_t i) -> T {
        if constexpr (kRescaled) return X + xh[i];
        else return xh[i];
    };
    const auto finish = [&](size_t i, const ScaledChapman<T>& r) {
        if constexpr (kRescaled) {
            out1[i] = r.mantissa * std::exp(r.log_scale - xh[i]);
        } else {
            out1[i] = r.mantissa;
            out2[i] = r.log_scale;
        }
    };
    const double* column0 = detail::airmass_column0();
    Chunk ch;
    for (size_t i0 = 0; i0 < n; i0 += kBlocks * 4) {
        const size_t count = n - i0 < kBlocks * 4 ? n - i0 : kBlocks * 4;
        const size_t full = count / 4, blocks = (count + 3) / 4;
        for (size_t j = 0; j < full; ++j) {
            const size_t i = i0 + 4 * j;
            V x;
            if constexpr (!kRescaled) {
                x = load4(xh + i);
            } else if constexpr (sizeof(T) == sizeof(double)) {
                x = hn::Add(hn::Set(dd, X), hn::LoadU(dd, xh + i));
            } else {
                const hn::Rebind<float, DD> df;
                x = hn::PromoteTo(dd, hn::Add(hn::Set(df, X), hn::LoadU(df, xh + i)));
            }
            stage_a(table, x, load4(cs + i), load4(ss + i), ch, j);
        }
        if (full < blocks) {  // the last 1–3 lanes, padded with the zenith at x = 1
            HWY_ALIGN double x[4] = {1, 1, 1, 1}, mu[4] = {1, 1, 1, 1}, s[4] = {0, 0, 0, 0};
            for (size_t k = 0; 4 * full + k < count; ++k) {
                const size_t i = i0 + 4 * full + k;
                x[k] = double(x_of(i));
                mu[k] = double(cs[i]);
                s[k] = double(ss[i]);
            }
            stage_a(table, hn::Load(dd, x), hn::Load(dd, mu), hn::Load(dd, s), ch, full);
        }
        for (size_t j = 0; j < blocks; ++j) {
            const V mantissa = stage_b(table, column0, ch, j);
            const size_t i = i0 + 4 * j;
            if (!kRescaled && j < full && ch.slow[j] == 0) {
                store4(mantissa, out1 + i);
                store4(hn::Load(dd, ch.log_scale + 4 * j), out2 + i);
            } else {
                hn::Store(mantissa, dd, ch.mantissa + 4 * j);
            }
        }
        for (size_t j = 0; j < blocks; ++j) {
            if (!kRescaled && j < full && ch.slow[j] == 0) continue;  // stored above
            for (size_t k = 0; k < 4 && 4 * j + k < count; ++k) {
                const size_t i = i0 + 4 * j + k;
                if (ch.slow[j] & (1u << k)) continue;
                finish(i, ScaledChapman<T>{static_cast<T>(ch.mantissa[4 * j + k]), static_cast<T>(ch.log_scale[4 * j + k])});
            }
        }
        for (size_t j = 0; j < blocks; ++j)
            if (ch.slow[j])
                for (size_t k = 0; k < 4 && 4 * j + k < count; ++k) {
                    const size_t i = i0 + 4 * j + k;
                    if (ch.slow[j] & (1u << k)) finish(i, table.scaled(x_of(i), cs[i], ss[i]));
                }
    }
}

template <class T>
HWY_NOINLINE void scaled_batch(const AirmassTable& table, const T* x, const T* cs, const T* ss, size_t n, T* mantissa,
                               T* log_scale) {
    batch<T, false>(table, T(0), x, cs, ss, n, mantissa, log_scale);
}

template <class T>
HWY_NOINLINE void rescaled_batch(const AirmassTable& table, T X, const T* h, const T* cs, const T* ss, size_t n,
                                 T* out) {
    batch<T, true>(table, X, h, cs, ss, n, out, nullptr);
}
#endif  // HWY_TARGET == HWY_AVX2
}  // namespace HWY_NAMESPACE
}  // namespace airmass::airmass_hwy
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace airmass::detail {

template <class T>
void airmass_scaled_batch_avx2(const AirmassTable& table, const T* x, const T* cs, const T* ss, size_t n, T* mantissa,
                               T* log_scale) {
    airmass_hwy::N_AVX2::scaled_batch<T>(table, x, cs, ss, n, mantissa, log_scale);
}

template <class T>
void airmass_rescaled_batch_avx2(const AirmassTable& table, T X, const T* h, const T* cs, const T* ss, size_t n,
                                 T* out) {
    airmass_hwy::N_AVX2::rescaled_batch<T>(table, X, h, cs, ss, n, out);
}

#define AIRMASS_INSTANTIATE(T)                                                                                      \
    template void airmass_scaled_batch_avx2<T>(const AirmassTable&, const T*, const T*, const T*, size_t, T*, T*); \
    template void airmass_rescaled_batch_avx2<T>(const AirmassTable&, T, const T*, const T*, const T*, size_t, T*);
AIRMASS_INSTANTIATE(float)
AIRMASS_INSTANTIATE(double)
#undef AIRMASS_INSTANTIATE

}  // namespace airmass::detail
#endif  // HWY_ONCE

#endif  // AIRMASS_SIMD_DISPATCH
