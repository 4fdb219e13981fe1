// The `airmass` method's batch path (four lanes on vectors, AVX2/FMA or baseline, chapman.cpp)
// against its scalar path and against the exact quadrature, on the inputs where a vectorised
// kernel could go wrong: grazing angles, below the horizon, exactly 90° and 180°, tiny and huge x,
// lengths that leave 1–3 lanes over, and lanes that need the careful path next to lanes that do
// not. Float and double. (Speed: bench/bench_chapman.cpp, no timed test.)
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "airmass/chapman.hpp"
#include "airmass/simd.hpp"

namespace airmass {
namespace {

struct Point {
    double x, chi_deg;
};

std::vector<Point> awkward_points() {
    std::vector<Point> p;
    const double xs[] = {1e-2, 3e-2, 0.5, 1.0, 7.0, 60.0, 760.0, 1e4, 3e5, 1e7};
    const double chis[] = {0.0,   1e-6,  30.0,  60.0,         85.0,         89.9,  90.0 - 1e-7, 90.0,
                           90.0 + 1e-7, 90.1, 95.0, 120.0, 150.0, 179.0, 180.0 - 1e-7, 180.0};
    for (double x : xs)
        for (double chi : chis) p.push_back({x, chi});
    return p;
}

// Relative difference of two scaled values, through ln Ch (the scales can be huge).
double rel_diff(double m1, double l1, double m2, double l2) {
    return std::abs(std::expm1(std::log(m1) + l1 - std::log(m2) - l2));
}

template <class T>
class ChapmanBatch : public ::testing::Test {};
using Types = ::testing::Types<float, double>;
TYPED_TEST_SUITE(ChapmanBatch, Types);

TYPED_TEST(ChapmanBatch, AgreesWithScalarAndExact) {
    using T = TypeParam;
    const auto pts = awkward_points();
    std::vector<T> x, c, s;
    for (const auto& p : pts) {
        const auto a = ZenithAngle<T>::from_degrees(p.chi_deg);
        x.push_back(T(p.x));
        c.push_back(a.cos_chi);
        s.push_back(a.sin_chi);
    }
    std::vector<T> m(x.size()), e(x.size());
    chapman_scaled_batch<T>(ChapmanMethod::airmass, x, c, s, m, e);
    // The log scale d = x cos²chi/(1 + sin chi) (up to 1e7 here) is rounded to a few ulps of the
    // type, and each path forms it differently (one shared division or its own): Ch then differs
    // by that absolute error in ln Ch, 8 ulp(d) allowed (as test_chapman_reference allows for
    // rounding the angle). Float values are compared with the exact one at the float inputs.
    const bool is_float = std::is_same_v<T, float>;
    const double eps = std::numeric_limits<T>::epsilon();
    for (size_t i = 0; i < x.size(); ++i) {
        const auto scalar = chapman_scaled(ChapmanMethod::airmass, x[i], ZenithAngle<T>{c[i], s[i]});
        const auto exact = chapman_scaled(ChapmanMethod::exact, double(x[i]), ZenithAngle<double>{double(c[i]), double(s[i])});
        ASSERT_TRUE(std::isfinite(m[i]) && m[i] > 0 && std::isfinite(e[i]) && e[i] >= 0)
            << "x=" << pts[i].x << " chi=" << pts[i].chi_deg << " m=" << m[i] << " e=" << e[i];
        // Batch and scalar: the same formulas, differing only in rounding (shared vs separate
        // divisions, FMA in the AVX2 copy).
        const double rounding_d = 8 * eps * double(e[i]);
        const double tol_same = (is_float ? 4 * eps : 1e-12) + rounding_d;
        EXPECT_LE(rel_diff(m[i], e[i], scalar.mantissa, scalar.log_scale), tol_same)
            << "batch vs scalar, x=" << pts[i].x << " chi=" << pts[i].chi_deg;
        const double tol_exact = 1e-6 + (is_float ? 4 * eps : 0.0) + rounding_d;
        EXPECT_LE(rel_diff(m[i], e[i], exact.mantissa, exact.log_scale), tol_exact)
            << "batch vs exact, x=" << pts[i].x << " chi=" << pts[i].chi_deg;
        EXPECT_LE(rel_diff(scalar.mantissa, scalar.log_scale, exact.mantissa, exact.log_scale), tol_exact)
            << "scalar vs exact, x=" << pts[i].x << " chi=" << pts[i].chi_deg;
    }
}

TEST(ChapmanBatch, EveryTailLengthAndCarefulLanesAmongFastOnes) {
    // Lengths 1…9 leave 0–3 lanes after the groups of four; x beyond the fast path (1e300, the
    // largest double) and NaN share groups with ordinary lanes and must not disturb them.
    const double specials[] = {1e300, std::numeric_limits<double>::max(), 2.0, 5e3};
    for (size_t n = 1; n <= 9; ++n) {
        std::vector<double> x, c, s;
        for (size_t i = 0; i < n; ++i) {
            const auto a = ZenithAngle<double>::from_degrees(i % 2 ? 135.0 : 45.0);
            x.push_back(specials[i % 4]);
            c.push_back(a.cos_chi);
            s.push_back(a.sin_chi);
        }
        std::vector<double> m(n), e(n), out(n);
        chapman_scaled_batch<double>(ChapmanMethod::airmass, x, c, s, m, e);
        for (size_t i = 0; i < n; ++i) {
            const auto one = chapman_scaled(ChapmanMethod::airmass, x[i], ZenithAngle<double>{c[i], s[i]});
            EXPECT_LE(rel_diff(m[i], e[i], one.mantissa, one.log_scale), 1e-12 + 8e-16 * e[i]) << "n=" << n << " i=" << i;
        }
        // The rescaled batch is the scaled one times exp(log_scale − h).
        std::vector<double> h(n, 0.0);
        chapman_rescaled_batch<double>(ChapmanMethod::airmass, 0.0, x, c, s, out);
        for (size_t i = 0; i < n; ++i)
            if (e[i] == 0.0) {
                EXPECT_DOUBLE_EQ(out[i], m[i] * std::exp(-x[i])) << "n=" << n << " i=" << i;
            }
    }
    std::vector<double> x{2.0, std::nan(""), 3.0, 4.0, 5.0}, c(5, 0.5), s(5, std::sqrt(0.75)), m(5), e(5);
    chapman_scaled_batch<double>(ChapmanMethod::airmass, x, c, s, m, e);
    for (size_t i = 0; i < 5; ++i) {
        const auto one = chapman_scaled(ChapmanMethod::airmass, x[i], ZenithAngle<double>{c[i], s[i]});
        if (i == 1)  // whatever the careful path makes of NaN, the batch makes the same
            EXPECT_TRUE((std::isnan(m[i]) && std::isnan(one.mantissa)) || m[i] == one.mantissa) << m[i];
        else
            EXPECT_LE(rel_diff(m[i], e[i], one.mantissa, one.log_scale), 1e-12) << "i=" << i;
    }
    ::testing::Test::RecordProperty("simd", std::string(simd_target_name(simd_target())));
}

TEST(ChapmanBatch, OddSinesNextToLanesBelowTheHorizon) {
    // Whatever the scalar path makes of sin chi outside [0, 1] (it trusts the caller's angle above the
    // horizon, takes the careful path below it), the batch makes the same, also in a block that has
    // lanes below the horizon. Above the horizon with sin chi < −1 the Highway kernel once took
    // 1 + sin chi < 0 for a negligible reflected term and returned 0 ({1e4, 0.5, −1.001}: scalar 1.9994).
    const double inf = std::numeric_limits<double>::infinity();
    const std::vector<double> x0{1e4, 1e4, 1e4, 1e4, 5.0, 1e4, 100.0, 5.0, 1e4, 5.0};
    const std::vector<double> c0{0.5, 0.5, 0.9, 0.1, -0.5, -0.5, -0.5, -0.5, -0.5, -0.5};
    const std::vector<double> s0{-1.001, -3.0, -1.5, -1.0001, std::sqrt(0.75), -0.5, -1.0, -inf, -2.0, -1e-300};
    for (size_t n : {size_t(1), size_t(2), size_t(5), x0.size()}) {
        std::vector<double> x(x0.begin(), x0.begin() + n), c(c0.begin(), c0.begin() + n), s(s0.begin(), s0.begin() + n);
        if (n == 2) x = {1e4, 5.0}, c = {0.5, -0.5}, s = {-1.001, std::sqrt(0.75)};
        std::vector<double> m(n), e(n);
        chapman_scaled_batch<double>(ChapmanMethod::airmass, x, c, s, m, e);
        for (size_t i = 0; i < n; ++i) {
            const auto one = chapman_scaled(ChapmanMethod::airmass, x[i], ZenithAngle<double>{c[i], s[i]});
            if (std::isnan(one.mantissa) || std::isnan(m[i])) {
                EXPECT_TRUE(std::isnan(one.mantissa) && std::isnan(m[i])) << "n=" << n << " i=" << i << ": " << m[i] << " vs " << one.mantissa;
                continue;
            }
            EXPECT_LE(rel_diff(m[i], e[i], one.mantissa, one.log_scale), 1e-12 + 8e-16 * e[i])
                << "n=" << n << " i=" << i << ": batch (" << m[i] << ", " << e[i] << "), scalar (" << one.mantissa << ", "
                << one.log_scale << ")";
        }
    }
}

TEST(ChapmanBatch, CosineOutsideItsRange) {
    // cos chi = ±inf: NaN from the scalar path and the batch (the careful path), alone, next to a lane
    // below the horizon and next to one above; |cos chi| slightly or far beyond 1: the same value from
    // both (below the horizon both take the careful path, above it both the fast one).
    const double inf = std::numeric_limits<double>::infinity();
    for (double c : {inf, -inf, 1.5, -1.5, 1.0 + 1e-7, -1.0 - 1e-7, 1e200, -1e200})
        for (const std::vector<double>& other : {std::vector<double>{c, 0.0}, {-0.5, std::sqrt(0.75)}, {0.5, std::sqrt(0.75)}}) {
            const std::vector<double> x{10.0, 5.0, 1e4, 10.0, 10.0}, cs{c, other[0], c, c, c}, s{0.0, other[1], 0.0, 0.0, 0.0};
            std::vector<double> m(x.size()), e(x.size());
            chapman_scaled_batch<double>(ChapmanMethod::airmass, x, cs, s, m, e);
            for (size_t i = 0; i < x.size(); ++i) {
                const auto one = chapman_scaled(ChapmanMethod::airmass, x[i], ZenithAngle<double>{cs[i], s[i]});
                if (std::isinf(cs[i])) {
                    EXPECT_TRUE(std::isnan(one.mantissa) && std::isnan(m[i]))
                        << "cos=" << cs[i] << " i=" << i << ": scalar " << one.mantissa << ", batch " << m[i];
                    continue;
                }
                if (std::isnan(one.mantissa) || std::isnan(m[i])) {
                    EXPECT_TRUE(std::isnan(one.mantissa) && std::isnan(m[i])) << "cos=" << cs[i] << " i=" << i;
                    continue;
                }
                if (m[i] == one.mantissa && e[i] == one.log_scale) continue;  // also an infinite log scale
                EXPECT_LE(rel_diff(m[i], e[i], one.mantissa, one.log_scale), 1e-12 + 8e-16 * e[i])
                    << "cos=" << cs[i] << " i=" << i << ": batch (" << m[i] << ", " << e[i] << "), scalar (" << one.mantissa
                    << ", " << one.log_scale << ")";
            }
        }
}

}  // namespace
}  // namespace airmass
