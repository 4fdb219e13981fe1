// The exact and airmass methods against the independent mpmath reference
// (tests/data/chapman_reference.csv: 741 points, x ∈ [1e-2, 1e7], chi ∈ [0°, 180°],
// including 90° ± 1e-7 and exactly 90° and 180°).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include <boost/math/special_functions/bessel.hpp>

#include "airmass/chapman.hpp"
#include "chapman_reference.hpp"
#include "math/chapman_airmass.hpp"

namespace airmass {
namespace {

// Relative error of Ch from ln Ch: |Ch/Ch_ref − 1| = |expm1(ln − ln_ref)|.
double rel_err(double ln, double ln_ref) { return std::abs(std::expm1(ln - ln_ref)); }

// Below the horizon, rounding chi (in radians) to double already moves ln Ch by about
// x |cos chi| · 1e-16 (d ln Ch / d chi ≈ x cos chi), and ln Ch itself is only
// representable to ulp(ln Ch); the tolerance allows for both.
double allowed(double base, const test::ChapmanReference& r) {
    const auto chi = ZenithAngle<double>::from_degrees(r.chi_deg);
    const double rounding = r.chi_deg > 90.0 ? 4e-16 * r.x * std::abs(chi.cos_chi) : 0.0;
    return base + rounding + 4.0 * std::numeric_limits<double>::epsilon() * std::abs(r.ln_ch);
}

TEST(ChapmanReference, FileIsComplete) {
    const auto rows = test::load_chapman_reference();
    EXPECT_EQ(rows.size(), 741u);
}

// Every reference point within `tolerance` (plus the rounding allowance above).
void expect_within(ChapmanMethod method, double tolerance) {
    double worst = 0;
    for (const auto& r : test::load_chapman_reference()) {
        const double ln = log_chapman(method, r.x, ZenithAngle<double>::from_degrees(r.chi_deg));
        const double e = rel_err(ln, r.ln_ch);
        worst = std::max(worst, e);
        EXPECT_LE(e, allowed(tolerance, r)) << chapman_method_name(method) << " x=" << r.x << " chi=" << r.chi_deg;
    }
    ::testing::Test::RecordProperty("worst_rel_err", std::to_string(worst));
}

TEST(ChapmanReference, ExactWithin1e10) { expect_within(ChapmanMethod::exact, 1e-10); }

TEST(ChapmanReference, AirmassWithin1e6) { expect_within(ChapmanMethod::airmass, 1e-6); }

TEST(ChapmanReference, HorizontalExactIsBessel) {
    // Ch(x, 90°) = x e^x K1(x): std::cyl_bessel_k is an independent implementation.
    for (double x : {0.01, 0.1, 1.0, 10.0, 100.0, 600.0}) {
        const double bessel = x * std::exp(x) * std::cyl_bessel_k(1.0, x);
        EXPECT_NEAR(chapman_horizontal_exact(x) / bessel, 1.0, 1e-12) << "x=" << x;
    }
}

TEST(ChapmanReference, AirmassBelowHorizonIsTwiceBesselWhereTheReflectedTermVanishes) {
    // Below the horizon the mantissa is 2 Ch∥(x0) − Ch(x, 180° − chi) e^(−d), x0 = x sin chi, and Ch∥
    // comes from its own table (by the bits of x0). Where d = x cos²chi/(1 + sin chi) ≥ 60 + √x the
    // subtracted term is below 1e-20 of the mantissa, which is then 2 x0 e^(x0) K1(x0):
    // std::cyl_bessel_k is independent of both the table and the quadrature it was fitted to.
    // x0 from 0 (chi = 180°) to ~700 (e^x0 still finite), scalar and batch, float inputs too.
    std::vector<double> xs, cs, ss, want;
    for (double x : {200.0, 1e3, 1e4})
        for (double chi : {100.0, 120.0, 150.0, 170.0, 176.0, 178.0, 179.0, 179.9, 179.99, 180.0 - 1e-5, 180.0}) {
            const auto a = ZenithAngle<double>::from_degrees(chi);
            const double x0 = x * a.sin_chi;
            const double d = x * a.cos_chi * a.cos_chi / (1.0 + a.sin_chi);
            if (x0 > 700.0 || d < 60.0 + std::sqrt(x)) continue;
            xs.push_back(x), cs.push_back(a.cos_chi), ss.push_back(a.sin_chi);
            want.push_back(x0 == 0.0 ? 2.0 : 2.0 * x0 * std::exp(x0) * std::cyl_bessel_k(1.0, x0));
        }
    ASSERT_GE(xs.size(), 20u);
    std::vector<double> m(xs.size()), e(xs.size());
    chapman_scaled_batch<double>(ChapmanMethod::airmass, xs, cs, ss, m, e);
    for (size_t i = 0; i < xs.size(); ++i) {
        const auto one = chapman_scaled(ChapmanMethod::airmass, xs[i], ZenithAngle<double>{cs[i], ss[i]});
        // The table: ≤ 8.3e-9 (gen_chapman_table --check); 2e-8 leaves room for the Bessel function's
        // own rounding at x0 ~ 700.
        EXPECT_NEAR(one.mantissa / want[i], 1.0, 2e-8) << "x=" << xs[i] << " cos=" << cs[i];
        EXPECT_NEAR(m[i] / want[i], 1.0, 2e-8) << "batch, x=" << xs[i] << " cos=" << cs[i];
        const auto f = chapman_scaled(ChapmanMethod::airmass, float(xs[i]), ZenithAngle<float>{float(cs[i]), float(ss[i])});
        // Float: the double path at the float inputs, the mantissa and the log scale each rounded to float.
        const auto fd = chapman_scaled(ChapmanMethod::airmass, double(float(xs[i])),
                                       ZenithAngle<double>{double(float(cs[i])), double(float(ss[i]))});
        ASSERT_TRUE(std::isfinite(f.mantissa) && f.mantissa > 0.0f) << "float, x=" << xs[i] << " cos=" << cs[i];
        EXPECT_NEAR(double(f.mantissa) / fd.mantissa, 1.0, 1e-6) << "float, x=" << xs[i] << " cos=" << cs[i];
        EXPECT_NEAR(double(f.log_scale), fd.log_scale, 1e-6 * fd.log_scale) << "float, x=" << xs[i] << " cos=" << cs[i];
    }
}

// Ch∥(x0) = x0 e^x0 K1(x0), independently of the quadrature the table was fitted to: Boost's K1 in
// long double below x0 = 1000, above it the asymptotic series e^x K1(x) √(2x/π) = Σ a_k,
// a_k = Π_{i=1..k} (4 − (2i − 1)²) / (k! 8^k x^k) (terms < 1e-30 from x = 1000 on by k = 12).
long double parallel_reference(double x0) {
    if (x0 == 0.0) return 1.0L;
    const long double x = x0;
    if (x0 < 1000.0) return x * std::exp(x) * boost::math::cyl_bessel_k(1, x);
    long double term = 1.0L, sum = 1.0L;
    for (int k = 1; k <= 12; ++k) {
        term *= (4.0L - (2.0L * k - 1) * (2.0L * k - 1)) / (8.0L * k * x);
        sum += term;
    }
    return std::sqrt(3.14159265358979323846264338327950288L * x / 2.0L) * sum;
}

TEST(ChapmanReference, ParallelTableEveryCellWithinItsClaim) {
    // The Ch∥ table (docs/chapman.md: max relative error 8.2e-9; gen_chapman_table --check) at every
    // cell of every octave [2^-30, 2^40), at its start and at eight points between the fitting nodes
    // (τ = 0, ¼, ¾, 1 of the cell), against the reference at 1e-8. Below 2^-30 x0 is raised to it:
    // Ch∥ = 1 + x0 + …, within 2^-30 ≈ 9.3e-10.
    const double* parallel = detail::airmass_parallel_table();
    constexpr int cells_per_octave = 1 << detail::kParallelCellBits;
    double worst = 0.0, at = 0.0;
    for (int e = detail::kParallelExpLo; e <= detail::kParallelExpHi; ++e)
        for (int c = 0; c < cells_per_octave; ++c)
            for (int j = -1; j < 8; ++j) {
                const double frac = j < 0 ? 0.0 : (j + 0.5) / 8.0;  // of the cell
                const double x0 = std::ldexp(1.0 + (c + frac) / cells_per_octave, e);
                const double err = std::abs(double(detail::airmass_parallel(parallel, x0) / parallel_reference(x0) - 1.0L));
                if (err > worst) worst = err, at = x0;
                ASSERT_LE(err, 1e-8) << "x0=" << x0 << " (octave " << e << ", cell " << c << ")";
            }
    for (double x0 : {0.0, 5e-324, 1e-300, 1e-20, 0x1p-31, std::nextafter(0x1p-30, 0.0)})
        EXPECT_LE(std::abs(double(detail::airmass_parallel(parallel, x0) / parallel_reference(x0) - 1.0L)), 0x1p-30 + 1e-15)
            << "x0=" << x0;
    ::testing::Test::RecordProperty("max_rel_error", std::to_string(worst) + " at x0=" + std::to_string(at));
}

TEST(ChapmanReference, AirmassBelowHorizonBeyondTheParallelTable) {
    // x0 = x sin chi ≥ 2^40 takes the careful path (the Ch∥ table ends there), x0 below it the fast
    // one: on both sides of the boundary the batch agrees with the scalar form and the value is
    // finite, and on both sides Ch∥(x0) = √(πx0/2)(1 + 3/(8x0)) to 1e-7 where d is large.
    const double chis[] = {100.0, 135.0, 170.0};
    for (double x0_target : {0x1p40 * (1.0 - 1e-9), 0x1p40, 0x1p40 * (1.0 + 1e-9), 1e13})
        for (double chi : chis) {
            const auto a = ZenithAngle<double>::from_degrees(chi);
            const double x = x0_target / a.sin_chi;
            std::vector<double> xs{x, 2.0, x, 5.0}, cs{a.cos_chi, 0.5, a.cos_chi, -0.5},
                ss{a.sin_chi, std::sqrt(0.75), a.sin_chi, std::sqrt(0.75)}, m(4), e(4);
            chapman_scaled_batch<double>(ChapmanMethod::airmass, xs, cs, ss, m, e);
            const auto one = chapman_scaled(ChapmanMethod::airmass, x, a);
            const double x0 = x * a.sin_chi;
            const double par = std::sqrt(M_PI * x0 / 2.0) * (1.0 + 3.0 / (8.0 * x0));
            for (size_t i : {size_t(0), size_t(2)}) {
                ASSERT_TRUE(std::isfinite(m[i]) && m[i] > 0.0) << "x0=" << x0 << " chi=" << chi;
                EXPECT_NEAR(m[i] / one.mantissa, 1.0, 1e-12) << "x0=" << x0 << " chi=" << chi;
                EXPECT_NEAR(e[i] / one.log_scale, 1.0, 1e-15) << "x0=" << x0 << " chi=" << chi;
            }
            // x0 < 2^40: the table's path, within its 8.2e-9 (the careful path's quadrature beyond).
            EXPECT_NEAR(one.mantissa / (2.0 * par), 1.0, x0 < 0x1p40 ? 1e-8 : 1e-7) << "x0=" << x0 << " chi=" << chi;
            if (x0 < 0x1p40) {
                EXPECT_NEAR(m[0] / (2.0 * par), 1.0, 1e-8) << "batch, x0=" << x0 << " chi=" << chi;
            }
        }
    // Just below the horizon at x ≈ 2^40 (chi = 90.0001°: d ≈ 1.7, the reflected term counts): x0 on
    // both sides of the table's end, against the exact method (the airmass method's 1e-7).
    const auto a = ZenithAngle<double>::from_degrees(90.0001);
    for (double x : {0x1p40 * (1.0 - 1e-9), 0x1p40, 0x1p40 * (1.0 + 1e-9)}) {
        std::vector<double> xs{x, 2.0, 5.0, x}, cs{a.cos_chi, 0.5, -0.5, a.cos_chi},
            ss{a.sin_chi, std::sqrt(0.75), std::sqrt(0.75), a.sin_chi}, m(4), e(4);
        chapman_scaled_batch<double>(ChapmanMethod::airmass, xs, cs, ss, m, e);
        const auto one = chapman_scaled(ChapmanMethod::airmass, x, a);
        const auto ex = chapman_scaled(ChapmanMethod::exact, x, a);
        EXPECT_LE(rel_err(std::log(one.mantissa) + one.log_scale, std::log(ex.mantissa) + ex.log_scale), 1e-7) << "x=" << x;
        for (size_t i : {size_t(0), size_t(3)})
            EXPECT_LE(rel_err(std::log(m[i]) + e[i], std::log(one.mantissa) + one.log_scale), 1e-12) << "batch, x=" << x;
    }
}

}  // namespace
}  // namespace airmass
