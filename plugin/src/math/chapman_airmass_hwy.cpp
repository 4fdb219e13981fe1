// The `airmass` method's batch kernel for AVX2/FMA, written with Google Highway (header-only use;
// docs/chapman.md "Speed"). The same formulas as the baseline kernel (chapman_airmass_batch.inc)
// and the scalar path (chapman_airmass.hpp, airmass_scaled_fast), four double lanes per AVX
// register, with the square roots, the shared division, the cell indices and exp(−d) as vector
// instructions, and the table read per lane (four 256-bit loads, three FMAs) followed by one 4×4
// transpose and the Horner step in u on all four lanes at once. Below the horizon the lanes whose
// subtracted term is negligible skip B R (part1, batch()).
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
#include <hwy/contrib/math/math-inl.h>
#include <hwy/highway.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>
#include <iterator>
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

// A chunk of kBlocks blocks of four lanes goes through passes: stage_a computes every block's
// table cells and factors (square root, the shared division) into the chunk, stage_b reads the
// table and forms the results. On one block the whole chain (sqrt → division → cell → table read →
// Horner) is ~150 cycles of latency, longer than a core's reorder window; in passes, every block
// of a pass is independent of the others, so their latencies overlap and the table reads (random,
// mostly L1 misses) are in flight together. Below the horizon, batch() below.
constexpr size_t kBlocks = 16;

// Arrays of a chunk have 4 more lanes: a compressed block is stored whole (4 lanes) at any
// position, and its expansion reads four lanes from any position.
constexpr size_t kLanes = kBlocks * 4 + 4;

struct Chunk {
    // stage_a → stage_b: the cells' local coordinates and offsets, the base B, the slow lanes.
    HWY_ALIGN double t[kLanes], u[kLanes], factor[kLanes];
    HWY_ALIGN int32_t off[kLanes];
    uint8_t slow[kBlocks];  // lanes the fast path cannot take (bit k: lane k)
    // A chunk with lanes below the horizon (part1 and batch()): the tail block's inputs in double;
    // per block in input order Ch∥(x0)'s cell (τ in t0, off0: the zero cell above the horizon or
    // careful), d (0 above), the lanes that need B R and the careful lanes (bit k: lane k); the lanes that need B R compressed (√x, mu, and
    // d below the horizon, −1 above), any of them below per compressed block, and their product
    // B R e^(−d) (−B R above).
    HWY_ALIGN double x[4], mu[4], s[4];
    HWY_ALIGN double t0[kLanes], log_scale[kLanes];
    HWY_ALIGN int64_t off0[kLanes];
    uint8_t need[kBlocks], careful[kBlocks];
    HWY_ALIGN double qx[kLanes], qmu[kLanes], qd[kLanes], product[kLanes];
    bool below[kBlocks];
    HWY_ALIGN double mantissa[kLanes];  // results for finish(), in input order
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

// ... and Ch∥'s cubics (airmass_parallel_table, 35,872 B: more than a 32 KiB L1d, of which x ≤ 1e7
// touches the octaves up to 2^24, 28,160 B) at four lanes' cells, o[k] = the
// cell's offset: one load per lane, a transpose and Estrin in t on all lanes.
HWY_INLINE V read_parallel(const double* parallel, const int64_t* o, V t) {
    const DD dd;
    V C0, C1, C2, C3;
    transpose4(hn::LoadU(dd, parallel + o[0]), hn::LoadU(dd, parallel + o[1]), hn::LoadU(dd, parallel + o[2]),
               hn::LoadU(dd, parallel + o[3]), C0, C1, C2, C3);
    return hn::MulAdd(hn::MulAdd(C3, t, C2), hn::Mul(t, t), hn::MulAdd(C1, t, C0));
}

// Stage a of block j: the cells and the base B of Ch(x, chi) for four lanes with sx = √x, m = |cos chi|
// (formulas: chapman_airmass_batch.inc, above the horizon). kSlow: lanes may be beyond the fast
// path (D > 1e300); without, x ≤ 1e150 in every lane (D ≤ ~1e226).
template <bool kSlow>
HWY_INLINE void stage_a(const AirmassTable& table, V sx, V m, Chunk& ch, size_t j) {
    const DD dd;
    const size_t l = 4 * j;
    const V one = hn::Set(dd, 1.0);
    const V Y = hn::Mul(sx, hn::Set(dd, 0.70710678118654752));
    const V c = hn::MulAdd(hn::Set(dd, 1.2533141373155003), sx, one);
    const V a = hn::Add(one, sx), b = hn::MulAdd(m, Y, one), q = hn::MulAdd(hn::Sub(c, one), m, one);
    const V ab = hn::Mul(a, b);
    const V D = hn::Mul(ab, q);
    const M slow = kSlow ? hn::Not(hn::Le(D, hn::Set(dd, 1e300))) : hn::FirstN(dd, 0);
    const V inv_D = hn::Div(one, kSlow ? hn::IfThenElse(slow, one, D) : D);
    V w = hn::Mul(hn::Mul(b, q), inv_D);
    V v = hn::Min(hn::Mul(hn::Mul(hn::Mul(m, hn::Add(one, Y)), hn::Mul(a, q)), inv_D), one);
    if constexpr (kSlow) w = hn::IfThenZeroElse(slow, w), v = hn::IfThenZeroElse(slow, v);
    const int n_w = table.n_w, n_v = table.n_v;
    V t, u;
    const V iw = cell(hn::Mul(w, hn::Set(dd, double(n_w - 1))), n_w, t);
    const V iv = cell(hn::Mul(v, hn::Set(dd, double(n_v - 1))), n_v, u);
    hn::Store(t, dd, ch.t + l);
    hn::Store(u, dd, ch.u + l);
    offsets(hn::MulAdd(iw, hn::Set(dd, double((n_v - 1) * 16)), hn::Mul(iv, hn::Set(dd, 16.0))), ch.off + l);
    // The cells' two cache lines each, fetched while the rest of the chunk's stage a runs.
    for (size_t k = 0; k < 4; ++k) {
        hwy::Prefetch(table.coefficients + ch.off[l + k]);
        hwy::Prefetch(table.coefficients + ch.off[l + k] + 8);
    }
    hn::Store(hn::Mul(c, hn::Mul(ab, inv_D)), dd, ch.factor + l);  // c · (1/q): c · ab overflows near DBL_MAX
    if constexpr (kSlow) {
        uint8_t bits[8] = {};
        hn::StoreMaskBits(dd, slow, bits);
        ch.slow[j] = bits[0];
    }
}

// Stage b of block j: the table reads, B R.
HWY_INLINE V stage_b(const AirmassTable& table, const Chunk& ch, size_t j) {
    const DD dd;
    const size_t l = 4 * j;
    return hn::Mul(hn::Load(dd, ch.factor + l), read(table.coefficients, ch.off + l, ch.t + l, hn::Load(dd, ch.u + l)));
}

// A chunk with lanes below the horizon goes in two parts. Below the horizon the mantissa is
// 2 Ch∥(x0) − B R e^(−d), and where d > 40 + √x the subtracted term is below 1e-17 of the
// mantissa (B R ≤ 1.2 (1 + 1.26 √x), mantissa ≥ Ch∥(x0) ≥ 1): about half of bench_chapman's lanes
// below the horizon. Part one, on every block in input order: the cell of Ch∥(x0) from the bits of
// x0 (its own table, airmass_parallel_cell: no square root), d by a division of its own, √x, and
// the compression of the lanes that still need B R (above the horizon, or d not large enough), a
// block of four at a time, with their √x; part two evaluates B R (e^(−d)) on those alone: their
// division, table read and exp. √x is taken in part one for every lane because there the divider
// has time (the pass is bound by its other ~60 instructions), while part two, with the shared
// division, waited on it (measured: 4.18 against 4.20 ns per lane, medians of five alternated
// runs). The negligible lanes cost no read of the big table and no exp.
//
// Part one of block j: stores τ and the offset of Ch∥(x0)'s cell (the zero cell above the horizon
// or careful), the lanes that need B R and the careful lanes' bits (x > 1e150, NaN, x0 ≥ 2^40:
// the careful scalar path); returns d below the horizon and −x cos²chi/(1 + sin chi) above (≤ 0 unless sin chi < −1),
// stores d in ch.log_scale (0 above or careful).
HWY_INLINE V part1(V x, V sx, V mu, V s, Chunk& ch, size_t j) {
    const DD dd;
    const hn::RebindToSigned<DD> di;
    const hn::RebindToUnsigned<DD> du;
    const size_t l = 4 * j;
    const V one = hn::Set(dd, 1.0), zero = hn::Zero(dd);
    const M below = hn::Lt(mu, zero);
    // Ch∥(x0)'s cell from the bits of x0 (airmass_parallel_cell), clamped: any x0, also of careful or
    // above-horizon lanes, gives a cell inside the table (NaN: vmaxpd returns its second operand).
    const V x0 = hn::Mul(x, s);
    const V nm = hn::Or(mu, hn::Set(dd, -0.0));  // −|cos chi|
    const M careful = hn::Or(hn::Not(hn::And(hn::Le(x, hn::Set(dd, 1e150)), hn::Ge(nm, hn::Set(dd, -1.0)))),
                             hn::AndNot(hn::And(hn::Ge(s, zero), hn::Lt(x0, hn::Set(dd, detail::kParallelEnd))), below));
    const M fast_below = hn::AndNot(careful, below);
    const auto bits = hn::BitCast(du, hn::Min(hn::Max(x0, hn::Set(dd, detail::kParallelLo)), hn::Set(dd, detail::kParallelHi)));
    const V t0 = hn::Sub(hn::BitCast(dd, hn::Or(hn::And(bits, hn::Set(du, (uint64_t(1) << detail::kParallelShift) - 1)),
                                               hn::Set(du, uint64_t(0x3FF0000000000000)))),
                         one);
    hn::Store(t0, dd, ch.t0 + l);
    // The cell's offset; lanes that need no Ch∥ (above the horizon, careful) read the zero cell.
    const auto off = hn::Sub(hn::ShiftLeft<2>(hn::ShiftRight<detail::kParallelShift>(bits)), hn::Set(du, detail::kParallelBias));
    hn::Store(hn::And(hn::BitCast(di, off), hn::BitCast(di, hn::VecFromMask(dd, fast_below))), di, ch.off0 + l);
    // d below the horizon, −d above it (x cos chi (−|cos chi|) / (1 + sin chi): below, bit for bit the
    // scalar path's x m m / (1 + sin chi)).
    const V d = hn::Div(hn::Mul(hn::Mul(x, mu), nm), hn::Add(one, s));
    hn::Store(hn::IfThenElseZero(fast_below, d), dd, ch.log_scale + l);
    // d − 40 > √x, below the horizon only: above it with sin chi < −1, 1 + sin chi < 0 makes d > 0.
    const M negligible = hn::And(below, hn::Gt(hn::Sub(d, hn::Set(dd, 40.0)), sx));
    uint8_t bits8[8] = {};
    hn::StoreMaskBits(dd, careful, bits8);
    ch.careful[j] = bits8[0];
    hn::StoreMaskBits(dd, hn::Not(hn::Or(careful, negligible)), bits8);
    ch.need[j] = bits8[0];
    return d;
}

// The partition's permutations of a block of four by its negligible lanes' bits m, as pairs of
// 32-bit indices (vpermd: AVX2 has no 64-bit variable permutation): compress[m] takes the lanes in m
// to the front in order; expand[m] sends lane k the r-th lane of its class, r = the lanes of k's
// class below k.
struct Partition {
    int32_t compress[16][8];
    int32_t expand[16][8];
    uint64_t keep[16][4];  // all ones in the lanes of m
};
constexpr Partition make_partition() {
    Partition p{};
    for (unsigned m = 0; m < 16; ++m) {
        int n = 0;
        for (int k = 0; k < 4; ++k)
            if (m & (1u << k)) p.compress[m][2 * n] = 2 * k, p.compress[m][2 * n + 1] = 2 * k + 1, ++n;
        for (int k = 0; k < 4; ++k)
            if (!(m & (1u << k))) p.compress[m][2 * n] = 2 * k, p.compress[m][2 * n + 1] = 2 * k + 1, ++n;
        int r[2] = {0, 0};
        for (int k = 0; k < 4; ++k) {
            const int c = (m >> k) & 1u;
            p.expand[m][2 * k] = 2 * r[c], p.expand[m][2 * k + 1] = 2 * r[c] + 1;
            p.keep[m][k] = c ? ~uint64_t(0) : 0;
            ++r[c];
        }
    }
    return p;
}
HWY_ALIGN constexpr Partition kPartition = make_partition();

HWY_INLINE hn::Indices256<double> permutation(const int32_t* idx) {
    return hn::Indices256<double>{hn::Load(hn::Full256<int32_t>(), idx).raw};
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

// The rescaled output of four lanes, mantissa · e^exponent, when every exponent lies in
// [−700, 700] (Highway's Exp: ≤ 1 ULP there, against std::exp's per lane in the scalar form);
// false, nothing stored, otherwise (the caller takes the lanes one at a time, as before).
template <class T>
HWY_INLINE bool store_rescaled4(V mantissa, V exponent, T* p) {
    const DD dd;
    const V bound = hn::Set(dd, 700.0);
    if (!hn::AllTrue(dd, hn::Le(hn::Abs(exponent), bound))) return false;  // NaN: false too
    store4(hn::Mul(mantissa, hn::Exp(dd, exponent)), p);
    return true;
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
            out1[i] = r.mantissa * std::exp(detail::rescaled_exponent(r.log_scale, X, xh[i], cs[i], ss[i]));
        } else {
            out1[i] = r.mantissa;
            out2[i] = r.log_scale;
        }
    };
    const double* parallel = detail::airmass_parallel_table();
    Chunk ch;
    // The expansion below reads whole blocks of products, some lanes of which no part two wrote
    // (they are masked off): defined values for them, once per call.
    std::fill(std::begin(ch.product), std::end(ch.product), 0.0);
    for (size_t i0 = 0; i0 < n; i0 += kBlocks * 4) {
        const size_t count = n - i0 < kBlocks * 4 ? n - i0 : kBlocks * 4;
        const size_t full = count / 4, blocks = (count + 3) / 4;
        // The tail's last 1–3 lanes in double, padded with the zenith at x = 1.
        if (full < blocks)
            for (size_t k = 0; k < 4; ++k) {
                const size_t i = i0 + 4 * full + k;
                const bool in = 4 * full + k < count;
                ch.x[k] = in ? double(x_of(i)) : 1.0;
                ch.mu[k] = in ? double(cs[i]) : 1.0;
                ch.s[k] = in ? double(ss[i]) : 0.0;
            }
        // Block j's inputs in double.
        const auto load = [&](size_t j, V& x, V& mu, V& s) {
            if (j == full) {
                x = hn::Load(dd, ch.x), mu = hn::Load(dd, ch.mu), s = hn::Load(dd, ch.s);
                return;
            }
            const size_t i = i0 + 4 * j;
            if constexpr (!kRescaled) {
                x = load4(xh + i);
            } else if constexpr (sizeof(T) == sizeof(double)) {
                x = hn::Add(hn::Set(dd, X), hn::LoadU(dd, xh + i));
            } else {
                const hn::Rebind<float, DD> df;
                x = hn::PromoteTo(dd, hn::Add(hn::Set(df, X), hn::LoadU(df, xh + i)));
            }
            mu = load4(cs + i), s = load4(ss + i);
        };
        // Any lane below the horizon, as a mask per block (not the OR of the inputs' bits: a NaN or
        // an infinite cos χ in one lane would hide a negative one in another). A NaN lane counts
        // as above; stage_a sends it to the careful path.
        // The scan stops at the first block with a lane below (a chunk all below costs one block's).
        auto any_below = hn::Lt(hn::Zero(dd), hn::Zero(dd));  // no lane
        for (size_t j = 0; j < blocks; ++j) {
            V x, mu, s;
            load(j, x, mu, s);
            any_below = hn::Or(any_below, hn::Lt(mu, hn::Zero(dd)));
            if (!hn::AllFalse(dd, any_below)) break;
        }
        if (hn::AllFalse(dd, any_below)) {  // all above: B R, log scale 0
            for (size_t j = 0; j < blocks; ++j) {
                V x, mu, s;
                load(j, x, mu, s);
                stage_a<true>(table, hn::Sqrt(x), hn::Abs(mu), ch, j);
            }
            bool stored[kBlocks];
            for (size_t j = 0; j < blocks; ++j) {
                const V mantissa = stage_b(table, ch, j);
                const size_t i = i0 + 4 * j;
                stored[j] = false;
                if (j < full && ch.slow[j] == 0) {
                    if constexpr (kRescaled) {
                        stored[j] = store_rescaled4(mantissa, hn::Neg(load4(xh + i)), out1 + i);  // log scale 0
                    } else {
                        store4(mantissa, out1 + i);
                        store4(hn::Zero(dd), out2 + i);
                        stored[j] = true;
                    }
                }
                if (!stored[j]) hn::Store(mantissa, dd, ch.mantissa + 4 * j);
            }
            for (size_t j = 0; j < blocks; ++j) {
                if (stored[j]) continue;  // stored above
                for (size_t k = 0; k < 4 && 4 * j + k < count; ++k) {
                    const size_t i = i0 + 4 * j + k;
                    if (ch.slow[j] & (1u << k)) finish(i, table.scaled(x_of(i), cs[i], ss[i]));
                    else finish(i, ScaledChapman<T>{static_cast<T>(ch.mantissa[4 * j + k]), T(0)});
                }
            }
            continue;
        }
        // Part one on every block, the lanes that need B R compressed (part1 above).
        size_t n1 = 0;
        for (size_t j = 0; j < blocks; ++j) {
            V x, mu, s;
            load(j, x, mu, s);
            const V sx = hn::Sqrt(x);  // here, where the divider has time; part two takes it compressed
            const V d = part1(x, sx, mu, s, ch, j);
            const V dq = hn::IfThenElse(hn::Lt(mu, hn::Zero(dd)), d, hn::Set(dd, -1.0));
            const unsigned need = ch.need[j];
            const auto to = permutation(kPartition.compress[need]);
            hn::StoreU(hn::TableLookupLanes(sx, to), dd, ch.qx + n1);
            hn::StoreU(hn::TableLookupLanes(mu, to), dd, ch.qmu + n1);
            hn::StoreU(hn::TableLookupLanes(dq, to), dd, ch.qd + n1);
            n1 += size_t(std::popcount(need));
        }
        for (size_t q = n1; q % 4; ++q) ch.qx[q] = 1.0, ch.qmu[q] = 1.0, ch.qd[q] = -1.0;  // the zenith at x = 1
        const size_t g1 = (n1 + 3) / 4;
        // Part two: B R e^(−d) below, −B R above (d = −1 there), on the compressed blocks. e^(−d) in
        // the pass of the table reads: it does not wait for them, and fills their latency.
        for (size_t j = 0; j < g1; ++j) {
            stage_a<false>(table, hn::Load(dd, ch.qx + 4 * j), hn::Abs(hn::Load(dd, ch.qmu + 4 * j)), ch, j);
            ch.below[j] = !hn::AllTrue(dd, hn::Lt(hn::Load(dd, ch.qd + 4 * j), hn::Zero(dd)));
        }
        for (size_t j = 0; j < g1; ++j) {
            const V upper = stage_b(table, ch, j);
            const V d = hn::Load(dd, ch.qd + 4 * j);
            const V e = ch.below[j] ? hn::IfThenElse(hn::Lt(d, hn::Zero(dd)), hn::Set(dd, -1.0), exp_neg(d)) : hn::Set(dd, -1.0);
            hn::Store(hn::Mul(upper, e), dd, ch.product + 4 * j);
        }
        // 2 Ch∥(x0) minus the expanded products, in input order.
        n1 = 0;
        for (size_t j = 0; j < blocks; ++j) {
            const unsigned need = ch.need[j];
            const V h1 = read_parallel(parallel, ch.off0 + 4 * j, hn::Load(dd, ch.t0 + 4 * j));
            const V h = hn::Add(h1, h1);  // 2 Ch∥(x0)
            const V product = hn::TableLookupLanes(hn::LoadU(dd, ch.product + n1), permutation(kPartition.expand[need]));
            const V keep = hn::BitCast(dd, hn::Load(hn::Full256<uint64_t>(), kPartition.keep[need]));
            const V mantissa = hn::Sub(h, hn::And(product, keep));
            n1 += size_t(std::popcount(need));
            const V log_scale = hn::Load(dd, ch.log_scale + 4 * j);
            bool stored = false;
            if (j < full) {
                if constexpr (kRescaled) {
                    // log_scale − h on the lanes, unless an h ≥ 2^20 would leave too few digits of
                    // it: then per lane (rescaled_exponent, as the scalar form).
                    const V hv = load4(xh + i0 + 4 * j);
                    stored = hn::AllTrue(dd, hn::Lt(hv, hn::Set(dd, 1048576.0))) &&
                             store_rescaled4(mantissa, hn::Sub(log_scale, hv), out1 + i0 + 4 * j);
                } else {
                    store4(mantissa, out1 + i0 + 4 * j);
                    store4(log_scale, out2 + i0 + 4 * j);
                    stored = true;
                }
            }
            if (!stored) {
                hn::Store(mantissa, dd, ch.mantissa + 4 * j);
                for (size_t k = 0; k < 4 && 4 * j + k < count; ++k)
                    finish(i0 + 4 * j + k, ScaledChapman<T>{static_cast<T>(ch.mantissa[4 * j + k]), static_cast<T>(ch.log_scale[4 * j + k])});
            }
            if (ch.careful[j])  // over what was stored for them
                for (size_t k = 0; k < 4 && 4 * j + k < count; ++k)
                    if (ch.careful[j] & (1u << k)) {
                        const size_t i = i0 + 4 * j + k;
                        finish(i, table.scaled(x_of(i), cs[i], ss[i]));
                    }
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
