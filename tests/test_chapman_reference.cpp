// The exact and airmass methods against the independent mpmath reference
// (tests/data/chapman_reference.csv: 741 points, x ∈ [1e-2, 1e7], chi ∈ [0°, 180°],
// including 90° ± 1e-7 and exactly 90° and 180°).
#include <gtest/gtest.h>

#include <cmath>

#include "airmass/chapman.hpp"
#include "chapman_reference.hpp"

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

}  // namespace
}  // namespace airmass
