// Extremes, for every method, in float and double: chi exactly 90° and 180°, 90° ± 1e-7,
// x = 1e-2 and 1e7, and the rescaled form with h ≪ X and h ≫ X. The accurate methods
// (exact, airmass) must be finite, positive and right everywhere; the published ones
// must be finite and positive wherever their authors' formulas are, and where a
// published formula itself breaks, the test pins down exactly where and how
// (docs/chapman.md "Where the published methods break").
#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

#include "airmass/chapman.hpp"

namespace airmass {
namespace {

const std::vector<double> kXs = {1e-2, 0.1, 1.0, 2.0, 10.0, 100.0, 760.0, 1e4, 1e7};
const std::vector<double> kChis = {0.0,   1e-7,  45.0,  89.0, 90.0 - 1e-7, 90.0, 90.0 + 1e-7, 91.0,
                                   120.0, 150.0, 170.0, 179.0, 179.9,      179.99, 180.0 - 1e-7, 180.0};

template <class T>
bool valid(ChapmanMethod m, double x, double chi) {
    const auto s = chapman_scaled(m, T(x), ZenithAngle<T>::from_degrees(chi));
    const T ln = log_chapman(m, T(x), ZenithAngle<T>::from_degrees(chi));
    const T plain = chapman(m, T(x), ZenithAngle<T>::from_degrees(chi));
    return std::isfinite(s.mantissa) && s.mantissa > T(0) && std::isfinite(s.log_scale) && s.log_scale >= T(0) &&
           std::isfinite(ln) && !std::isnan(plain) && plain > T(0);
}

template <class T>
class ChapmanExtremes : public ::testing::Test {};
using Precisions = ::testing::Types<float, double>;
TYPED_TEST_SUITE(ChapmanExtremes, Precisions);

TYPED_TEST(ChapmanExtremes, AccurateMethodsValidEverywhere) {
    using T = TypeParam;
    for (auto m : {ChapmanMethod::exact, ChapmanMethod::airmass})
        for (double x : kXs)
            for (double chi : kChis) EXPECT_TRUE(valid<T>(m, x, chi)) << chapman_method_name(m) << " x=" << x << " chi=" << chi;
}

TYPED_TEST(ChapmanExtremes, PlainValueIsInfOnlyBeyondTheTypesRange) {
    using T = TypeParam;
    const double ln_max = std::log(double(std::numeric_limits<T>::max()));
    for (double x : kXs)
        for (double chi : kChis) {
            const auto a = ZenithAngle<T>::from_degrees(chi);
            const double ln = log_chapman(ChapmanMethod::airmass, T(x), a);
            const T plain = chapman(ChapmanMethod::airmass, T(x), a);
            if (ln < ln_max - 1) {
                EXPECT_TRUE(std::isfinite(plain)) << "x=" << x << " chi=" << chi;
            }
            if (ln > ln_max + 1) {
                EXPECT_TRUE(std::isinf(plain)) << "x=" << x << " chi=" << chi;
            }
        }
}

TYPED_TEST(ChapmanExtremes, ExactlyNinetyAndOneEighty) {
    using T = TypeParam;
    const bool is_float = std::is_same_v<T, float>;
    for (double x : kXs) {
        // Ch(x, 90°) = x e^x K1(x), Ch(x, 180°) = 2 e^x − 1 (ln form: x + ln(2 − e^−x)).
        const double h = chapman_horizontal_exact(double(T(x)));
        const double xf = double(T(x));
        for (auto m : {ChapmanMethod::exact, ChapmanMethod::airmass}) {
            const double tol = is_float ? 2e-6 : (m == ChapmanMethod::exact ? 1e-10 : 3e-7);
            EXPECT_NEAR(chapman(m, T(x), ZenithAngle<T>::from_degrees(90.0)) / h, 1.0, tol) << x;
            const double ln180 = xf + std::log(2.0 - std::exp(-xf));
            EXPECT_NEAR(log_chapman(m, T(x), ZenithAngle<T>::from_degrees(180.0)), ln180,
                        tol * std::max(1.0, ln180)) << chapman_method_name(m) << " x=" << x;
        }
    }
}

TYPED_TEST(ChapmanExtremes, ContinuousAcrossTheHorizon) {
    using T = TypeParam;
    // 90° − 1e-7, 90°, 90° + 1e-7: the two branches (rational/table vs reflection identity)
    // must meet. The derivative there is ~x Ch∥, so 1e-7 rad·(deg) moves Ch by ≲ 1e-7·x.
    for (const auto& info : chapman_methods())
        for (double x : {1.0, 760.0, 1e4}) {
            const double lo = chapman(info.method, T(x), ZenithAngle<T>::from_degrees(90.0 - 1e-7));
            const double mid = chapman(info.method, T(x), ZenithAngle<T>::from_degrees(90.0));
            const double hi = chapman(info.method, T(x), ZenithAngle<T>::from_degrees(90.0 + 1e-7));
            // 1e-7° = 1.75e-9 rad, and |d ln Ch / d chi| ≤ x + 2 around the horizon.
            const double allowed = 1.75e-9 * (x + 2) + (std::is_same_v<T, float> ? 1e-5 : 1e-12) +
                                   (info.method == ChapmanMethod::golubev2019 ? 1e-5 : 0.0);
            EXPECT_NEAR(lo / mid, 1.0, allowed) << info.name << " x=" << x;
            EXPECT_NEAR(hi / mid, 1.0, allowed) << info.name << " x=" << x;
        }
}

TYPED_TEST(ChapmanExtremes, RescaledFormNeverOverflowsInIntermediates) {
    using T = TypeParam;
    // Ch_h(X, h, chi) = Ch(X + h, chi) e^(−h). h ≫ X: a thin shell seen from far above
    // (e^h alone overflows); h ≪ X: an observer just above the reference radius.
    struct Case { double X, h; };
    for (auto [X, h] : {Case{1.0, 1e6}, Case{10.0, 5e3}, Case{760.0, 1e-6}, Case{1e6, 1e-3}, Case{1e6, 0.0}})
        for (double chi : {0.0, 60.0, 90.0, 90.0 + 1e-7, 95.0}) {
            const auto a = ZenithAngle<T>::from_degrees(chi);
            for (auto m : {ChapmanMethod::exact, ChapmanMethod::airmass}) {
                const T r = chapman_rescaled(m, T(X), T(h), a);
                // Reference in log space, from the same method's scaled form at x = X + h.
                const double ln_ref = double(log_chapman(ChapmanMethod::exact, T(X + h), a)) - double(T(h));
                if (ln_ref < std::log(double(std::numeric_limits<T>::max())) - 1 &&
                    ln_ref > std::log(double(std::numeric_limits<T>::min())) + 1) {
                    ASSERT_TRUE(std::isfinite(r)) << "X=" << X << " h=" << h << " chi=" << chi;
                    const double tol = std::is_same_v<T, float> ? 1e-4 * std::max(1.0, std::abs(ln_ref)) : 1e-6;
                    EXPECT_NEAR(std::log(double(r)), ln_ref, tol)
                        << chapman_method_name(m) << " X=" << X << " h=" << h << " chi=" << chi;
                } else {
                    EXPECT_FALSE(std::isnan(r));
                }
            }
        }
}

TYPED_TEST(ChapmanExtremes, PublishedMethodsValidWhereTheirFormulasAre) {
    using T = TypeParam;
    // Away from the antizenith (chi ≤ 179°) and for x ≥ 10 every published method is
    // finite and positive, including exactly at 90° and 90° ± 1e-7.
    for (const auto& info : chapman_methods())
        for (double x : {10.0, 100.0, 760.0, 1e4, 1e7})
            for (double chi : kChis)
                if (chi <= 179.0) {
                    EXPECT_TRUE(valid<T>(info.method, x, chi)) << info.name << " x=" << x << " chi=" << chi;
                }
}

TYPED_TEST(ChapmanExtremes, WherePublishedMethodsBreak) {
    using T = TypeParam;
    // At chi = 180° the periapsis height x0 = x sin chi is 0, and each published
    // horizontal function fails there in its own way:
    //  * Schüler's Ch∥ ≈ 1.2533 sqrt(x0) and the rigged sqrt(x0) vanish instead of → 1, so
    //    2 Ch∥(x0) − Ch(x, 0) e^(−x) is negative (or 0 once e^(−x) underflows): ln Ch = NaN/−inf.
    //  * Kocifaj's (1/2x0 + 1) sqrt(pi x0/2) and Golubev's 0.626657 (x0^−½ + 2 x0^½) have a
    //    1/sqrt(x0) pole: at x0 = 0 it is 0·inf → NaN (just below 180° they overestimate).
    const auto at180 = ZenithAngle<T>::from_degrees(180.0);
    for (double x : kXs) {
        for (auto m : {ChapmanMethod::schuler2012, ChapmanMethod::schuler2012_rigged,
                       ChapmanMethod::schuler2012_rigged_exp2pp}) {
            const auto s = chapman_scaled(m, T(x), at180);
            EXPECT_LE(s.mantissa, T(0)) << chapman_method_name(m) << " x=" << x;
        }
        for (auto m : {ChapmanMethod::schuler2012_full, ChapmanMethod::kocifaj1996, ChapmanMethod::golubev2019})
            EXPECT_TRUE(std::isnan(chapman_scaled(m, T(x), at180).mantissa)) << chapman_method_name(m) << " x=" << x;
    }
    // Schüler 2012's negative region reaches far from 180° when x is small: at x = 0.01
    // it is negative already at 150°; for x ≥ 10 only the last 1e-3 degrees break.
    EXPECT_LT(chapman_scaled(ChapmanMethod::schuler2012, T(0.01), ZenithAngle<T>::from_degrees(150.0)).mantissa, T(0));
    EXPECT_GT(chapman_scaled(ChapmanMethod::schuler2012, T(10.0), ZenithAngle<T>::from_degrees(179.99)).mantissa, T(0));
}

TEST(ChapmanExtremes, Exp2ppIsAccurateTo12Bits) {
    // GPU Pro 3 Listing 2.3 claims 12 bits; check on a dense grid, and that 1 − exp2pp(−x) > 0 for x > 0.
    double worst = 0;
    for (int i = -4000; i <= 4000; ++i) {
        const double x = i * 0.01;
        worst = std::max(worst, std::abs(exp2pp(x) / std::exp2(x) - 1.0));
        if (x > 0) {
            EXPECT_GT(1.0 - exp2pp(-x), 0.0) << x;
        }
    }
    EXPECT_LT(worst, 1.0 / 4096);
}

// x up to the largest double (float: float), where c·a·b of the `airmass` method's base used to
// overflow while the shared denominator did not (inf at 90°, NaN just below the horizon). The
// references are the asymptotes: Ch(x, 90°) → √(πx/2); Ch(x, χ) → 1/cos χ once x cos²χ ≫ 1;
// below the horizon the mantissa → 2 Ch∥(x sin χ).
TEST(ChapmanExtremes, HugeXNearTheHorizon) {
    const double big[] = {1e200, 1e250, 1e300, 1e307, std::numeric_limits<double>::max()};
    for (double x : big) {
        const double horizontal = std::sqrt(0.5 * 3.141592653589793) * std::sqrt(x);
        const double mu = 1e-90;  // x mu² ≥ 1e20
        const double s = std::sqrt(1.0 - mu * mu);
        const std::vector<double> xs(7, x), cs = {0.0, mu, -mu, 0.0, mu, -mu, 0.0}, ss = {1.0, s, s, 1.0, s, s, 1.0};
        std::vector<double> mant(7), ls(7);
        chapman_scaled_batch<double>(ChapmanMethod::airmass, xs, cs, ss, mant, ls);
        for (std::size_t i = 0; i < 7; ++i) {
            const auto one = chapman_scaled(ChapmanMethod::airmass, x, ZenithAngle<double>{cs[i], ss[i]});
            const double expect = cs[i] == 0.0 ? horizontal : cs[i] > 0.0 ? 1.0 / mu : 2.0 * horizontal;
            EXPECT_NEAR(one.mantissa / expect, 1.0, 1e-6) << "x " << x << " cos " << cs[i];
            EXPECT_NEAR(mant[i] / expect, 1.0, 1e-6) << "batch, x " << x << " cos " << cs[i];
            EXPECT_TRUE(std::isfinite(one.log_scale) && std::isfinite(ls[i])) << "x " << x;
        }
    }
    // float: from 1e28 on, within a degree of the horizon, against the double form
    for (float x : {1e28f, 1e30f, 1e34f, std::numeric_limits<float>::max()})
        for (double chi : {89.0, 90.0, 90.001, 91.0}) {
            const auto f = chapman_scaled(ChapmanMethod::airmass, x, ZenithAngle<float>::from_degrees(chi));
            const auto d = chapman_scaled(ChapmanMethod::airmass, double(x), ZenithAngle<double>::from_degrees(chi));
            ASSERT_TRUE(std::isfinite(f.mantissa) && std::isfinite(f.log_scale)) << "x " << x << " chi " << chi;
            EXPECT_NEAR(double(f.mantissa) / d.mantissa, 1.0, 1e-4) << "x " << x << " chi " << chi;
            EXPECT_NEAR(double(f.log_scale), d.log_scale, 1e-4 * std::max(1.0, d.log_scale)) << "x " << x;
        }
    // the exact method at x = +inf: the plane-parallel limit, not Boost's evaluation_error
    const double inf = std::numeric_limits<double>::infinity();
    EXPECT_DOUBLE_EQ(chapman(ChapmanMethod::exact, inf, ZenithAngle<double>::from_degrees(60.0)), 2.0);
    EXPECT_NO_THROW(chapman_scaled(ChapmanMethod::exact, inf, ZenithAngle<double>::from_cos(1e-320)));
}

// Ch(X + h, χ) e^(−h) where X + h exceeds the largest double: 0 from the point upward (its
// density is e^(−h)); below the horizon the line's mass both ways from its periapsis h_p
// scale heights up, 2 Ch(X + h_p, 90°) e^(−h_p) — checked against that identity evaluated where
// nothing overflows. Scalar and batch, both accurate methods; nothing thrown, nothing NaN.
TEST(ChapmanExtremes, RescaledBeyondTheLargestDouble) {
    const double X = 760.0, inf = std::numeric_limits<double>::infinity();
    for (auto m : {ChapmanMethod::exact, ChapmanMethod::airmass}) {
        for (double h : {std::numeric_limits<double>::max(), 1e308, inf})
            for (double chi : {0.0, 60.0, 90.0}) {
                const auto a = ZenithAngle<double>::from_degrees(chi);
                EXPECT_EQ(chapman_rescaled(m, X, h, a), 0.0) << chapman_method_name(m) << " h " << h << " chi " << chi;
            }
        const double h = 1e308;
        std::vector<double> hs, cs, ss, expect;
        for (double hp : {-5.0, 0.0, 10.0, 300.0}) {
            const double s = (X + hp) / (X + h), c = -std::sqrt(1.0 - s * s);
            const double r = chapman_rescaled(m, X, h, ZenithAngle<double>{c, s});
            const double ref = 2.0 * chapman_rescaled(m, X, hp, ZenithAngle<double>{0.0, 1.0});
            EXPECT_NEAR(r / ref, 1.0, 1e-9) << chapman_method_name(m) << " h_p " << hp;
            hs.push_back(h), cs.push_back(c), ss.push_back(s), expect.push_back(ref);
        }
        hs.push_back(inf), cs.push_back(-1.0), ss.push_back(0.0), expect.push_back(-1.0);  // not NaN
        hs.push_back(inf), cs.push_back(0.5), ss.push_back(std::sqrt(0.75)), expect.push_back(0.0);
        std::vector<double> out(hs.size());
        chapman_rescaled_batch<double>(m, X, hs, cs, ss, out);
        for (std::size_t i = 0; i < out.size(); ++i) {
            ASSERT_FALSE(std::isnan(out[i])) << chapman_method_name(m) << " lane " << i;
            if (expect[i] > 0.0) {
                EXPECT_NEAR(out[i] / expect[i], 1.0, 1e-9) << chapman_method_name(m) << " batch lane " << i;
            } else if (expect[i] == 0.0) {
                EXPECT_EQ(out[i], 0.0) << chapman_method_name(m) << " batch lane " << i;
            }
        }
    }
}

}  // namespace
}  // namespace airmass
