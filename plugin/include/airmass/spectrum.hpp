// Per-wavelength arithmetic (model: pbrt-v4's SampledSpectrum), for a wavelength count known
// only at run time (3 for an RGB basis, 16–48 for spectral renders).
//
//   SpectrumView<T>     non-owning, span-like: T* + length. SpectrumView<const T> reads.
//   Spectrum<T>         owning (std::vector<T>), converts to both views.
//   SpectrumScratch<T>  owning with N elements inline (no allocation up to N, heap above):
//                       per-call scratch in kernels that promise not to allocate.
//
// Operations (T = float or double; a scalar is a T):
//   a += b, a -= b, a *= b, a /= b, and the same with a scalar     (members of SpectrumView)
//   fill(a, x), assign(a, b) (also converting float ↔ double)
//   add_scaled(a, b, s)          a += b · s       (τ += σt · m: one constituent's optical depth)
//   add_product(a, b, c[, s])    a += b · c [· s], evaluated as (s · b) · c
//   add_triple_product(a, b, c, d)  a += (b · c) · d, c of another element type
//   exp_neg(a) / exp_neg(out, a) a = e^(−a)       (optical depth → transmittance, libm's exp)
//   exp_neg_nonneg(a)            a = e^(−a) for a ≥ 0 (a polynomial that vectorises; ≤ 1e-15)
//   min(out, a, b), max(out, a, b), min(a, s), max(a, s), sum(a), average(a),
//   min_value(a), max_value(a)
//   Spectrum operators +, −, ·, / returning a new Spectrum (they allocate: not for kernels).
//
// Vectorisation: every elementwise operation is one contiguous loop over `size()` elements
// with no reduction, so GCC/Clang vectorise it at -O3 (with a run-time overlap check where the
// pointers may alias). Everything is inline header code on purpose: the transport kernels are
// compiled twice (baseline and AVX2/FMA, airmass/simd.hpp), and each copy inlines and
// vectorises these loops for its own target. sum/average stay sequential (a vectorised
// floating-point reduction would reorder the additions; results would differ per target).
//
// Aliasing: an operand may be the same view as the destination (a += a doubles a); the result
// is always that of the plain sequential loop w = 0, 1, …, n−1, also for partly overlapping
// views (the vectoriser checks overlap at run time).
//
// Lengths: the operands of an elementwise operation must have the same length. A mismatch
// throws std::length_error naming the operation and both lengths, in every build type (one
// predictable compare per call, outside the loop; the message is built in a cold function).
// Empty spectra are valid: operations on them do nothing, sum = 0, average/min_value/max_value
// of an empty spectrum throw std::length_error (there is no value to return).
#pragma once

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstddef>
#include <initializer_list>
#include <span>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace airmass {

namespace spectrum_detail {

[[noreturn, gnu::cold, gnu::noinline]] inline void length_mismatch(const char* op, std::size_t a, std::size_t b) {
    throw std::length_error(std::string("spectrum ") + op + ": lengths differ (" + std::to_string(a) + " and " +
                            std::to_string(b) + " wavelengths)");
}
[[noreturn, gnu::cold, gnu::noinline]] inline void empty_spectrum(const char* op) {
    throw std::length_error(std::string("spectrum ") + op + ": the spectrum is empty (0 wavelengths)");
}
inline void check(const char* op, std::size_t a, std::size_t b) {
    if (a != b) [[unlikely]]
        length_mismatch(op, a, b);
}

}  // namespace spectrum_detail

template <class T>
class SpectrumView {
public:
    using element_type = T;
    using value_type = std::remove_cv_t<T>;

    constexpr SpectrumView() = default;
    constexpr SpectrumView(T* data, std::size_t size) : data_(data), size_(size) {}
    constexpr SpectrumView(std::span<T> s) : data_(s.data()), size_(s.size()) {}  // NOLINT: implicit
    // SpectrumView<const T> from SpectrumView<T>
    template <class U>
        requires(std::is_const_v<T> && std::is_same_v<std::remove_const_t<T>, U>)
    constexpr SpectrumView(SpectrumView<U> v) : data_(v.data()), size_(v.size()) {}  // NOLINT: implicit
    template <class U>
        requires(std::is_const_v<T> && std::is_same_v<std::remove_const_t<T>, U>)
    constexpr SpectrumView(std::span<U> s) : data_(s.data()), size_(s.size()) {}  // NOLINT: implicit
    // From a vector (e.g. AtmosphereConstituent::extinction_per_m).
    template <class Alloc>
    SpectrumView(std::vector<value_type, Alloc>& v)  // NOLINT: implicit
        requires(!std::is_const_v<T>)
        : data_(v.data()), size_(v.size()) {}
    template <class Alloc>
    SpectrumView(const std::vector<value_type, Alloc>& v)  // NOLINT: implicit
        requires(std::is_const_v<T>)
        : data_(v.data()), size_(v.size()) {}

    constexpr T* data() const { return data_; }
    constexpr std::size_t size() const { return size_; }
    constexpr bool empty() const { return size_ == 0; }
    constexpr T& operator[](std::size_t w) const { return data_[w]; }
    constexpr T* begin() const { return data_; }
    constexpr T* end() const { return data_ + size_; }
    constexpr std::span<T> span() const { return {data_, size_}; }
    constexpr operator std::span<T>() const { return span(); }  // NOLINT: implicit
    // Elements [offset, offset + count) (spectrum k of a ray-major batch: subview(k * nw, nw)).
    constexpr SpectrumView subview(std::size_t offset, std::size_t count) const { return {data_ + offset, count}; }

    // Elementwise, in place. Return the view (not a reference to it) so chains stay cheap.
    const SpectrumView& operator+=(SpectrumView<const value_type> b) const {
        spectrum_detail::check("+=", size_, b.size());
        const value_type* q = b.data();
        for (std::size_t w = 0; w < size_; ++w) data_[w] += q[w];
        return *this;
    }
    const SpectrumView& operator-=(SpectrumView<const value_type> b) const {
        spectrum_detail::check("-=", size_, b.size());
        const value_type* q = b.data();
        for (std::size_t w = 0; w < size_; ++w) data_[w] -= q[w];
        return *this;
    }
    const SpectrumView& operator*=(SpectrumView<const value_type> b) const {
        spectrum_detail::check("*=", size_, b.size());
        const value_type* q = b.data();
        for (std::size_t w = 0; w < size_; ++w) data_[w] *= q[w];
        return *this;
    }
    const SpectrumView& operator/=(SpectrumView<const value_type> b) const {
        spectrum_detail::check("/=", size_, b.size());
        const value_type* q = b.data();
        for (std::size_t w = 0; w < size_; ++w) data_[w] /= q[w];
        return *this;
    }
    const SpectrumView& operator+=(value_type s) const {
        for (std::size_t w = 0; w < size_; ++w) data_[w] += s;
        return *this;
    }
    const SpectrumView& operator-=(value_type s) const {
        for (std::size_t w = 0; w < size_; ++w) data_[w] -= s;
        return *this;
    }
    const SpectrumView& operator*=(value_type s) const {
        for (std::size_t w = 0; w < size_; ++w) data_[w] *= s;
        return *this;
    }
    const SpectrumView& operator/=(value_type s) const {
        for (std::size_t w = 0; w < size_; ++w) data_[w] /= s;
        return *this;
    }

private:
    T* data_ = nullptr;
    std::size_t size_ = 0;
};

template <class T>
SpectrumView(std::vector<T>&) -> SpectrumView<T>;
template <class T>
SpectrumView(const std::vector<T>&) -> SpectrumView<const T>;
template <class T>
SpectrumView(std::span<T>) -> SpectrumView<T>;

// ---- owning spectra ---------------------------------------------------------------------------

template <class T>
class Spectrum {
public:
    Spectrum() = default;
    explicit Spectrum(std::size_t n, T value = T(0)) : v_(n, value) {}
    Spectrum(std::initializer_list<T> values) : v_(values) {}
    explicit Spectrum(SpectrumView<const T> values) : v_(values.begin(), values.end()) {}

    std::size_t size() const { return v_.size(); }
    bool empty() const { return v_.empty(); }
    T* data() { return v_.data(); }
    const T* data() const { return v_.data(); }
    T& operator[](std::size_t w) { return v_[w]; }
    const T& operator[](std::size_t w) const { return v_[w]; }
    T* begin() { return v_.data(); }
    T* end() { return v_.data() + v_.size(); }
    const T* begin() const { return v_.data(); }
    const T* end() const { return v_.data() + v_.size(); }
    void resize(std::size_t n, T value = T(0)) { v_.resize(n, value); }
    void assign(std::size_t n, T value) { v_.assign(n, value); }

    SpectrumView<T> view() { return {v_.data(), v_.size()}; }
    SpectrumView<const T> view() const { return {v_.data(), v_.size()}; }
    operator SpectrumView<T>() { return view(); }                   // NOLINT: implicit
    operator SpectrumView<const T>() const { return view(); }       // NOLINT: implicit
    operator std::span<T>() { return {v_.data(), v_.size()}; }      // NOLINT: implicit
    operator std::span<const T>() const { return {v_.data(), v_.size()}; }  // NOLINT: implicit

    Spectrum& operator+=(SpectrumView<const T> b) { view() += b; return *this; }
    Spectrum& operator-=(SpectrumView<const T> b) { view() -= b; return *this; }
    Spectrum& operator*=(SpectrumView<const T> b) { view() *= b; return *this; }
    Spectrum& operator/=(SpectrumView<const T> b) { view() /= b; return *this; }
    Spectrum& operator+=(T s) { view() += s; return *this; }
    Spectrum& operator-=(T s) { view() -= s; return *this; }
    Spectrum& operator*=(T s) { view() *= s; return *this; }
    Spectrum& operator/=(T s) { view() /= s; return *this; }

    friend bool operator==(const Spectrum&, const Spectrum&) = default;

private:
    std::vector<T> v_;
};

// N elements inline, heap above: scratch per call without allocation for the usual counts.
// Not copyable (a view into it would dangle), movable only by rebuilding.
template <class T, std::size_t N = 64>
class SpectrumScratch {
public:
    explicit SpectrumScratch(std::size_t n) : size_(n) {
        if (n > N) heap_.resize(n);
    }
    SpectrumScratch(const SpectrumScratch&) = delete;
    SpectrumScratch& operator=(const SpectrumScratch&) = delete;

    std::size_t size() const { return size_; }
    T* data() { return size_ > N ? heap_.data() : inline_; }
    const T* data() const { return size_ > N ? heap_.data() : inline_; }
    T& operator[](std::size_t w) { return data()[w]; }
    const T& operator[](std::size_t w) const { return data()[w]; }
    SpectrumView<T> view() { return {data(), size_}; }
    SpectrumView<const T> view() const { return {data(), size_}; }
    operator SpectrumView<T>() { return view(); }              // NOLINT: implicit
    operator SpectrumView<const T>() const { return view(); }  // NOLINT: implicit
    operator std::span<T>() { return {data(), size_}; }        // NOLINT: implicit

private:
    std::size_t size_;
    T inline_[N];
    std::vector<T> heap_;
};

// ---- free functions (destination first) -------------------------------------------------------
//
// Any of SpectrumView, Spectrum, SpectrumScratch, std::span or std::vector can be passed as
// the destination; its element type T fixes the type of the other operands, which convert
// implicitly to SpectrumView<const T>.

template <class T>
constexpr SpectrumView<T> as_view(SpectrumView<T> v) { return v; }
template <class T, std::size_t E>
constexpr SpectrumView<T> as_view(std::span<T, E> s) { return {s.data(), s.size()}; }
template <class T>
SpectrumView<T> as_view(Spectrum<T>& s) { return s.view(); }
template <class T>
SpectrumView<const T> as_view(const Spectrum<T>& s) { return s.view(); }
template <class T, std::size_t N>
SpectrumView<T> as_view(SpectrumScratch<T, N>& s) { return s.view(); }
template <class T, std::size_t N>
SpectrumView<const T> as_view(const SpectrumScratch<T, N>& s) { return s.view(); }
template <class T, class Alloc>
SpectrumView<T> as_view(std::vector<T, Alloc>& v) { return {v.data(), v.size()}; }
template <class T, class Alloc>
SpectrumView<const T> as_view(const std::vector<T, Alloc>& v) { return {v.data(), v.size()}; }

template <class A>
using spectrum_value_t = typename decltype(as_view(std::declval<A&>()))::value_type;
// The read-only operand type for a destination of type A.
template <class A>
using SpectrumIn = SpectrumView<const spectrum_value_t<A>>;

template <class A>
inline void fill(A&& dst, spectrum_value_t<A> x) {
    const auto a = as_view(dst);
    for (std::size_t w = 0; w < a.size(); ++w) a[w] = x;
}

// a = b, converting (float ↔ double).
template <class A, class B>
inline void assign(A&& dst, const B& src) {
    const auto a = as_view(dst);
    const auto b = as_view(src);
    spectrum_detail::check("assign", a.size(), b.size());
    using T = typename decltype(a)::value_type;
    for (std::size_t w = 0; w < a.size(); ++w) a[w] = T(b[w]);
}

// a += b · s
template <class A>
inline void add_scaled(A&& dst, SpectrumIn<A> b, spectrum_value_t<A> s) {
    const auto a = as_view(dst);
    spectrum_detail::check("add_scaled", a.size(), b.size());
    for (std::size_t w = 0; w < a.size(); ++w) a[w] += b[w] * s;
}

// a += b · c
template <class A>
inline void add_product(A&& dst, SpectrumIn<A> b, SpectrumIn<A> c) {
    const auto a = as_view(dst);
    spectrum_detail::check("add_product", a.size(), b.size());
    spectrum_detail::check("add_product", a.size(), c.size());
    for (std::size_t w = 0; w < a.size(); ++w) a[w] += b[w] * c[w];
}

// a += (s · b) · c
template <class A>
inline void add_product(A&& dst, SpectrumIn<A> b, SpectrumIn<A> c, spectrum_value_t<A> s) {
    const auto a = as_view(dst);
    spectrum_detail::check("add_product", a.size(), b.size());
    spectrum_detail::check("add_product", a.size(), c.size());
    for (std::size_t w = 0; w < a.size(); ++w) a[w] += s * b[w] * c[w];
}

// a += (b · c) · d, c of any element type (converted to a's: float table weights in double sums)
template <class A, class U>
inline void add_triple_product(A&& dst, SpectrumIn<A> b, SpectrumView<const U> c, SpectrumIn<A> d) {
    const auto a = as_view(dst);
    using T = typename decltype(a)::value_type;
    spectrum_detail::check("add_triple_product", a.size(), b.size());
    spectrum_detail::check("add_triple_product", a.size(), c.size());
    spectrum_detail::check("add_triple_product", a.size(), d.size());
    for (std::size_t w = 0; w < a.size(); ++w) a[w] += b[w] * T(c[w]) * d[w];
}

// out = b + c, b − c, b · c, b / c
#define AIRMASS_SPECTRUM_BINARY(name, op)                                              \
    template <class A>                                                                 \
    inline void name(A&& dst, SpectrumIn<A> b, SpectrumIn<A> c) {                      \
        const auto a = as_view(dst);                                                   \
        spectrum_detail::check(#name, a.size(), b.size());                             \
        spectrum_detail::check(#name, a.size(), c.size());                             \
        for (std::size_t w = 0; w < a.size(); ++w) a[w] = b[w] op c[w];                \
    }
AIRMASS_SPECTRUM_BINARY(add, +)
AIRMASS_SPECTRUM_BINARY(subtract, -)
AIRMASS_SPECTRUM_BINARY(multiply, *)
AIRMASS_SPECTRUM_BINARY(divide, /)
#undef AIRMASS_SPECTRUM_BINARY

// out = min(b, c), max(b, c) elementwise, as std::min(b, c) / std::max(b, c) (b when unordered).
template <class A>
inline void min(A&& dst, SpectrumIn<A> b, SpectrumIn<A> c) {
    const auto a = as_view(dst);
    spectrum_detail::check("min", a.size(), b.size());
    spectrum_detail::check("min", a.size(), c.size());
    for (std::size_t w = 0; w < a.size(); ++w) a[w] = c[w] < b[w] ? c[w] : b[w];
}
template <class A>
inline void max(A&& dst, SpectrumIn<A> b, SpectrumIn<A> c) {
    const auto a = as_view(dst);
    spectrum_detail::check("max", a.size(), b.size());
    spectrum_detail::check("max", a.size(), c.size());
    for (std::size_t w = 0; w < a.size(); ++w) a[w] = b[w] < c[w] ? c[w] : b[w];
}

// a = max(s, a), a = min(s, a) elementwise with a scalar, as std::max(s, a) / std::min(s, a)
// (s where a is NaN).
template <class A>
inline void max(A&& dst, spectrum_value_t<A> s) {
    const auto a = as_view(dst);
    for (std::size_t w = 0; w < a.size(); ++w) a[w] = s < a[w] ? a[w] : s;
}
template <class A>
inline void min(A&& dst, spectrum_value_t<A> s) {
    const auto a = as_view(dst);
    for (std::size_t w = 0; w < a.size(); ++w) a[w] = a[w] < s ? a[w] : s;
}

// a = e^(−a), out = e^(−b), out = e^b: optical depth → transmittance (std::exp per element;
// libm's exp is not vectorised without -ffast-math, the loops around it are).
template <class A>
inline void exp_neg(A&& dst) {
    const auto a = as_view(dst);
    for (std::size_t w = 0; w < a.size(); ++w) a[w] = std::exp(-a[w]);
}
template <class A>
inline void exp_neg(A&& dst, SpectrumIn<A> b) {
    const auto a = as_view(dst);
    spectrum_detail::check("exp_neg", a.size(), b.size());
    for (std::size_t w = 0; w < a.size(); ++w) a[w] = std::exp(-b[w]);
}
template <class A>
inline void exp(A&& dst, SpectrumIn<A> b) {
    const auto a = as_view(dst);
    spectrum_detail::check("exp", a.size(), b.size());
    for (std::size_t w = 0; w < a.size(); ++w) a[w] = std::exp(b[w]);
}

// e^(−x) for x ≥ 0 (an optical depth), beyond 708 (+inf included) e^(−708) ≈ 3e-308: 2^n
// by the 1.5·2^52 shift, r = −x − n ln2 with ln2 split in two (Cody–Waite: n·ln2_hi is exact),
// the degree-12 Taylor polynomial on |r| ≤ ln2/2; relative error ≤ 1e-15 (tests/test_spectrum.cpp).
// Branch-free and without float compares (the clamp compares the bits of non-negative
// doubles, which order as their integers do; under the default -ftrapping-math a float
// compare keeps a loop scalar), so a loop of it vectorises — libm's exp does not. Only for
// x ≥ 0 and not NaN: the callers' optical depths are sums of non-negative terms. A NaN is not
// passed on (a positive NaN gives e^(−708), a negative one NaN): a caller that can see one
// keeps exp_neg.
inline double exp_neg_nonneg(double x) {
    const auto bits = [](double v) { return std::bit_cast<std::int64_t>(v); };
    x = std::bit_cast<double>(std::min(bits(x), bits(708.0)));
    constexpr double kShift = 6755399441055744.0;  // 1.5 · 2^52
    const double shifted = x * -1.44269504088896341 + kShift;
    const double n = shifted - kShift;
    constexpr double kLn2Hi = 0.693147180369123816490;  // 32 significant bits: n · kLn2Hi is exact
    constexpr double kLn2Lo = 1.90821492927058770002e-10;
    const double r = n * -kLn2Lo + (n * -kLn2Hi - x);
    double p = 1.0 / 479001600.0;
    p = p * r + 1.0 / 39916800.0;
    p = p * r + 1.0 / 3628800.0;
    p = p * r + 1.0 / 362880.0;
    p = p * r + 1.0 / 40320.0;
    p = p * r + 1.0 / 5040.0;
    p = p * r + 1.0 / 720.0;
    p = p * r + 1.0 / 120.0;
    p = p * r + 1.0 / 24.0;
    p = p * r + 1.0 / 6.0;
    p = p * r + 0.5;
    p = p * r + 1.0;
    p = p * r + 1.0;
    const std::int64_t ni = bits(shifted) - bits(kShift);  // n ∈ [−1022, 0]
    return p * std::bit_cast<double>((ni + 1023) << 52);
}
// a = e^(−a) elementwise by exp_neg_nonneg (float spectra through double).
template <class A>
    requires(!std::is_arithmetic_v<std::remove_cvref_t<A>>)
inline void exp_neg_nonneg(A&& dst) {
    const auto a = as_view(dst);
    for (std::size_t w = 0; w < a.size(); ++w) a[w] = static_cast<spectrum_value_t<A>>(exp_neg_nonneg(double(a[w])));
}

// Reductions, in wavelength order (sequential: the same sum on every target).
template <class A>
inline auto sum(const A& src) {
    const auto a = as_view(src);
    typename decltype(a)::value_type s(0);
    for (std::size_t w = 0; w < a.size(); ++w) s += a[w];
    return s;
}
template <class A>
inline auto average(const A& src) {
    const auto a = as_view(src);
    if (a.empty()) spectrum_detail::empty_spectrum("average");
    using T = typename decltype(a)::value_type;
    return sum(a) / T(a.size());
}
template <class A>
inline auto min_value(const A& src) {
    const auto a = as_view(src);
    if (a.empty()) spectrum_detail::empty_spectrum("min_value");
    typename decltype(a)::value_type m = a[0];
    for (std::size_t w = 1; w < a.size(); ++w) m = a[w] < m ? a[w] : m;
    return m;
}
template <class A>
inline auto max_value(const A& src) {
    const auto a = as_view(src);
    if (a.empty()) spectrum_detail::empty_spectrum("max_value");
    typename decltype(a)::value_type m = a[0];
    for (std::size_t w = 1; w < a.size(); ++w) m = m < a[w] ? a[w] : m;
    return m;
}

// ---- value operators on owning spectra (allocate; for set-up code and tests) -------------------

template <class T>
inline Spectrum<T> operator+(const Spectrum<T>& a, const Spectrum<T>& b) { Spectrum<T> r(a.size()); add(r, a, b); return r; }
template <class T>
inline Spectrum<T> operator-(const Spectrum<T>& a, const Spectrum<T>& b) { Spectrum<T> r(a.size()); subtract(r, a, b); return r; }
template <class T>
inline Spectrum<T> operator*(const Spectrum<T>& a, const Spectrum<T>& b) { Spectrum<T> r(a.size()); multiply(r, a, b); return r; }
template <class T>
inline Spectrum<T> operator/(const Spectrum<T>& a, const Spectrum<T>& b) { Spectrum<T> r(a.size()); divide(r, a, b); return r; }
template <class T>
inline Spectrum<T> operator*(Spectrum<T> a, T s) { a *= s; return a; }
template <class T>
inline Spectrum<T> operator*(T s, Spectrum<T> a) { a *= s; return a; }
template <class T>
inline Spectrum<T> operator/(Spectrum<T> a, T s) { a /= s; return a; }
template <class T>
inline Spectrum<T> operator+(Spectrum<T> a, T s) { a += s; return a; }
template <class T>
inline Spectrum<T> operator-(Spectrum<T> a, T s) { a -= s; return a; }
template <class T>
inline Spectrum<T> min(const Spectrum<T>& a, const Spectrum<T>& b) { Spectrum<T> r(a.size()); min(r, a, b); return r; }
template <class T>
inline Spectrum<T> max(const Spectrum<T>& a, const Spectrum<T>& b) { Spectrum<T> r(a.size()); max(r, a, b); return r; }

}  // namespace airmass
