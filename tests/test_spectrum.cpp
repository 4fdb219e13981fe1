// Spectrum value and view types (airmass/spectrum.hpp): values against numbers written out
// here, aliasing (a += a), empty spectra and the length-mismatch error, for float and double.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "airmass/spectrum.hpp"

namespace {

using airmass::Spectrum;
using airmass::SpectrumScratch;
using airmass::SpectrumView;

template <class T>
class SpectrumTyped : public ::testing::Test {};
using Types = ::testing::Types<float, double>;
TYPED_TEST_SUITE(SpectrumTyped, Types);

TYPED_TEST(SpectrumTyped, ElementwiseArithmeticBySpectrumAndScalar) {
    using T = TypeParam;
    Spectrum<T> a{T(1), T(2), T(4)}, b{T(0.5), T(4), T(-2)};
    EXPECT_EQ(a + b, (Spectrum<T>{T(1.5), T(6), T(2)}));
    EXPECT_EQ(a - b, (Spectrum<T>{T(0.5), T(-2), T(6)}));
    EXPECT_EQ(a * b, (Spectrum<T>{T(0.5), T(8), T(-8)}));
    EXPECT_EQ(a / b, (Spectrum<T>{T(2), T(0.5), T(-2)}));
    EXPECT_EQ(a * T(3), (Spectrum<T>{T(3), T(6), T(12)}));
    EXPECT_EQ(T(3) * a, (Spectrum<T>{T(3), T(6), T(12)}));
    EXPECT_EQ(a / T(2), (Spectrum<T>{T(0.5), T(1), T(2)}));
    EXPECT_EQ(a + T(1), (Spectrum<T>{T(2), T(3), T(5)}));
    EXPECT_EQ(a - T(1), (Spectrum<T>{T(0), T(1), T(3)}));
    Spectrum<T> c = a;
    c += b;
    c -= a;
    EXPECT_EQ(c, b);
    c *= b;
    EXPECT_EQ(c, (Spectrum<T>{T(0.25), T(16), T(4)}));
    c /= b;
    EXPECT_EQ(c, b);
    c *= T(2);
    c /= T(4);
    c += T(1);
    c -= T(0.5);
    EXPECT_EQ(c, (Spectrum<T>{T(0.75), T(2.5), T(-0.5)}));
}

TYPED_TEST(SpectrumTyped, FusedFormsAndExp) {
    using T = TypeParam;
    // τ += σt · m for two constituents, then T = e^{−τ}
    const std::vector<T> ext0{T(1e-5), T(2e-5), T(4e-5)}, ext1{T(3e-6), T(3e-6), T(3e-6)};
    SpectrumScratch<T> tau(3);
    airmass::fill(tau, T(0));
    airmass::add_scaled(tau, ext0, T(1000));
    airmass::add_scaled(tau, ext1, T(2000));
    EXPECT_EQ(tau[0], T(1e-5) * T(1000) + T(3e-6) * T(2000));
    EXPECT_EQ(tau[2], T(4e-5) * T(1000) + T(3e-6) * T(2000));
    Spectrum<T> t(3);
    airmass::exp_neg(t, tau);
    for (std::size_t w = 0; w < 3; ++w) EXPECT_EQ(t[w], std::exp(-tau[w]));
    airmass::exp_neg(tau);  // in place
    for (std::size_t w = 0; w < 3; ++w) EXPECT_EQ(tau[w], t[w]);
    Spectrum<T> e(3);
    airmass::exp(e, std::vector<T>{T(0), T(1), T(-1)});
    EXPECT_EQ(e[0], T(1));
    EXPECT_EQ(e[1], std::exp(T(1)));
    // L += (s · σs) · T and L += σs · T
    Spectrum<T> L(3, T(1));
    const Spectrum<T> sigma{T(2), T(3), T(5)};
    airmass::add_product(L, sigma, Spectrum<T>{T(1), T(0.5), T(0.25)}, T(4));
    EXPECT_EQ(L, (Spectrum<T>{T(9), T(7), T(6)}));
    airmass::add_product(L, sigma, Spectrum<T>{T(1), T(2), T(0)});
    EXPECT_EQ(L, (Spectrum<T>{T(11), T(13), T(6)}));
    // L += (σs · w) · T with float weights w
    const std::vector<float> wf{1.0f, 0.5f, 2.0f};
    airmass::add_triple_product(L, sigma, SpectrumView<const float>(wf), Spectrum<T>{T(1), T(2), T(0.5)});
    EXPECT_EQ(L, (Spectrum<T>{T(13), T(16), T(11)}));
}

TYPED_TEST(SpectrumTyped, MinMaxAndReductions) {
    using T = TypeParam;
    const Spectrum<T> a{T(1), T(5), T(-2), T(8)}, b{T(3), T(4), T(-2), T(9)};
    EXPECT_EQ(airmass::min(a, b), (Spectrum<T>{T(1), T(4), T(-2), T(8)}));
    EXPECT_EQ(airmass::max(a, b), (Spectrum<T>{T(3), T(5), T(-2), T(9)}));
    Spectrum<T> c{T(-1), T(0.5), T(NAN), T(3)};
    airmass::max(c, T(0));  // std::max(0, c): 0 where c is NaN
    EXPECT_EQ(c, (Spectrum<T>{T(0), T(0.5), T(0), T(3)}));
    airmass::min(c, T(1));
    EXPECT_EQ(c, (Spectrum<T>{T(0), T(0.5), T(0), T(1)}));
    EXPECT_EQ(airmass::sum(a), T(12));
    EXPECT_EQ(airmass::average(a), T(3));
    EXPECT_EQ(airmass::min_value(a), T(-2));
    EXPECT_EQ(airmass::max_value(a), T(8));
    // sum is sequential in wavelength order (the same rounding on every target)
    std::vector<T> many(37);
    for (std::size_t w = 0; w < many.size(); ++w) many[w] = T(1) / T(w + 1);
    T seq(0);
    for (T v : many) seq += v;
    EXPECT_EQ(airmass::sum(many), seq);
}

TYPED_TEST(SpectrumTyped, AliasingIsTheSequentialLoop) {
    using T = TypeParam;
    // Long enough (67) that the vectorised body and its tail both run.
    std::vector<T> x(67);
    for (std::size_t w = 0; w < x.size(); ++w) x[w] = T(w) + T(0.5);
    const std::vector<T> x0 = x;
    SpectrumView<T> a(x);
    a += a;  // a = 2a
    for (std::size_t w = 0; w < x.size(); ++w) EXPECT_EQ(x[w], T(2) * x0[w]);
    a *= a;  // a = a²
    for (std::size_t w = 0; w < x.size(); ++w) EXPECT_EQ(x[w], (T(2) * x0[w]) * (T(2) * x0[w]));
    airmass::add_product(a, a, a, T(1));  // a += a·a
    a -= a;
    for (T v : x) EXPECT_EQ(v, T(0));
    // partly overlapping views: a[w] += a[w − 1] in order, i.e. running sums of the original
    std::vector<T> y(67, T(1));
    SpectrumView<T> tail(y.data() + 1, y.size() - 1), head(y.data(), y.size() - 1);
    tail += head;
    for (std::size_t w = 0; w < y.size(); ++w) EXPECT_EQ(y[w], T(w + 1)) << "w = " << w;
    // and the other direction: a[w] += a[w + 1] (reads the not-yet-updated neighbour)
    std::vector<T> z(67);
    for (std::size_t w = 0; w < z.size(); ++w) z[w] = T(w);
    SpectrumView<T>(z.data(), 66) += SpectrumView<const T>(z.data() + 1, 66);
    for (std::size_t w = 0; w + 1 < z.size(); ++w) EXPECT_EQ(z[w], T(2 * w + 1)) << "w = " << w;
}

TYPED_TEST(SpectrumTyped, EmptySpectra) {
    using T = TypeParam;
    Spectrum<T> a, b;
    a += b;
    a *= T(2);
    airmass::add_scaled(a, b, T(3));
    airmass::exp_neg(a);
    EXPECT_TRUE((a + b).empty());
    EXPECT_EQ(airmass::sum(a), T(0));
    EXPECT_THROW(airmass::average(a), std::length_error);
    EXPECT_THROW(airmass::min_value(a), std::length_error);
    EXPECT_THROW(airmass::max_value(a), std::length_error);
    SpectrumView<T> v;
    EXPECT_TRUE(v.empty());
    v += v;
}

TYPED_TEST(SpectrumTyped, LengthMismatchThrowsNamingTheLengths) {
    using T = TypeParam;
    Spectrum<T> a(3), b(4);
    const auto message = [&](auto&& f) {
        try {
            f();
        } catch (const std::length_error& e) {
            return std::string(e.what());
        }
        return std::string("no exception");
    };
    EXPECT_EQ(message([&] { a += b; }), "spectrum +=: lengths differ (3 and 4 wavelengths)");
    EXPECT_EQ(message([&] { airmass::add_scaled(a, b, T(1)); }),
              "spectrum add_scaled: lengths differ (3 and 4 wavelengths)");
    EXPECT_THROW(a - b, std::length_error);
    EXPECT_THROW(a * b, std::length_error);
    EXPECT_THROW(a / b, std::length_error);
    EXPECT_THROW(airmass::add_product(a, a, b), std::length_error);
    EXPECT_THROW(airmass::min(a, b), std::length_error);
    EXPECT_THROW(airmass::exp_neg(a, b), std::length_error);
    EXPECT_THROW(airmass::assign(a, b), std::length_error);
    // nothing was written by a rejected operation
    EXPECT_EQ(a, Spectrum<T>(3));
}

TEST(Spectrum, ExpNegNonnegIsLibmsExpToE15OnEveryOpticalDepth) {
    // exp_neg_nonneg (the vectorisable polynomial) against std::exp on a dense sweep of [0, 708] — every binade from 1e-300 up, and every
    // 1/64 of the range reduction's intervals — then its ends: 0 → 1, beyond 708 and +inf
    // → e^(−708) (≈ 3e-308, nothing a transmittance can tell from 0).
    double worst = 0.0;
    const auto check = [&](double x) {
        const double want = std::exp(-x), got = airmass::exp_neg_nonneg(x);
        worst = std::max(worst, std::abs(got - want) / want);
    };
    for (double x = 1e-300; x < 1.0; x *= 1.37) check(x);
    for (int k = 0; k <= 708 * 64 * 4; ++k) check(k / 256.0);
    EXPECT_LT(worst, 1e-15);  // measured 2026-12-03: 3.2e-16 (degree 12; degree 11 was 8.8e-15)
    EXPECT_EQ(airmass::exp_neg_nonneg(0.0), 1.0);
    EXPECT_EQ(airmass::exp_neg_nonneg(-0.0), 1.0);
    EXPECT_NEAR(airmass::exp_neg_nonneg(800.0) / std::exp(-708.0), 1.0, 1e-15);
    EXPECT_NEAR(airmass::exp_neg_nonneg(std::numeric_limits<double>::infinity()) / std::exp(-708.0), 1.0, 1e-15);
    // The spectrum form, float and double, in place.
    std::vector<float> tf{0.0f, 0.5f, 30.0f};
    airmass::exp_neg_nonneg(tf);
    for (std::size_t w = 0; w < 3; ++w) EXPECT_FLOAT_EQ(tf[w], std::exp(-std::vector<float>{0.0f, 0.5f, 30.0f}[w]));
    std::vector<double> td{1e-3, 7.0};
    airmass::exp_neg_nonneg(td);
    EXPECT_NEAR(td[1] / std::exp(-7.0), 1.0, 1e-15);
}

TEST(Spectrum, ViewsOfVectorsSpansAndConversion) {
    std::vector<double> d{1.0, 2.0, 3.0};
    SpectrumView<double> v(d);
    std::span<double> s = v;
    EXPECT_EQ(s.size(), 3u);
    SpectrumView<const double> cv = v;
    EXPECT_EQ(cv[2], 3.0);
    EXPECT_EQ(v.subview(1, 2)[0], 2.0);
    std::vector<float> f(3);
    airmass::assign(f, d);  // double → float
    EXPECT_EQ(f[1], 2.0f);
    airmass::fill(std::span<double>(d), 7.0);
    EXPECT_EQ(d[0], 7.0);
    // scratch: inline up to N, heap beyond, same behaviour
    SpectrumScratch<double, 4> small(3), big(9);
    airmass::fill(small, 1.0);
    airmass::fill(big, 2.0);
    EXPECT_EQ(airmass::sum(small), 3.0);
    EXPECT_EQ(airmass::sum(big), 18.0);
}

}  // namespace
