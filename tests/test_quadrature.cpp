// Gauss–Legendre rules on [0, 1] (math/quadrature.hpp) against exact integrals: a p-point rule
// integrates every polynomial of degree ≤ 2p − 1 exactly; panels integrate them exactly panel by
// panel; any rule integrates smooth functions to near rounding once the panels are fine.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "math/quadrature.hpp"

namespace airmass {
namespace {

double integrate(const std::vector<double>& rule, auto&& f) {
    double s = 0.0;
    for (std::size_t k = 0; k < rule.size(); k += 2) s += rule[k + 1] * f(rule[k]);
    return s;
}

TEST(Quadrature, NodesIncreaseInsideTheIntervalAndWeightsSumToOne) {
    for (int n : {1, 2, 3, 7, 16, 17, 31, 32, 33, 100, 1000, 65536}) {
        const std::vector<double> r = unit_gauss_legendre(n);
        ASSERT_EQ(r.size(), 2 * std::size_t(n)) << n;
        double sum = 0.0, last = 0.0;
        for (std::size_t k = 0; k < r.size(); k += 2) {
            EXPECT_GT(r[k], last) << n;
            EXPECT_LT(r[k], 1.0) << n;
            EXPECT_GT(r[k + 1], 0.0) << n;
            last = r[k];
            sum += r[k + 1];
        }
        EXPECT_NEAR(sum, 1.0, 1e-15 + n * 1e-16) << n;  // rounding of n terms
    }
    EXPECT_EQ(unit_gauss_legendre(1), (std::vector<double>{0.5, 1.0}));
    EXPECT_THROW(unit_gauss_legendre(0), std::invalid_argument);
}

// ∫₀¹ x^d dx = 1/(d + 1), exactly for d ≤ 2n − 1; for d = 2n the error is the Gauss–Legendre
// remainder on [0, 1], (n!)⁴ / ((2n + 1) ((2n)!)³) · f⁽²ⁿ⁾ = (n!)⁴ / ((2n + 1) ((2n)!)²): the
// nodes and weights are the Gauss–Legendre ones, not merely some exact rule.
TEST(Quadrature, CompileTimeFourPointRuleIsTheComputedOne) {
    // kGauss4Node/kGauss4Weight (render.cpp's box filter and panels, the view quadrature's
    // cancelling intervals) against Boost's Legendre zeros through unit_gauss_legendre(4),
    // mapped to [−1, 1]: nodes increasing, so −x1, −x0, x0, x1.
    const std::vector<double> r = unit_gauss_legendre(4);
    const double x[4] = {-kGauss4Node[1], -kGauss4Node[0], kGauss4Node[0], kGauss4Node[1]};
    const double w[4] = {kGauss4Weight[1], kGauss4Weight[0], kGauss4Weight[0], kGauss4Weight[1]};
    for (int i = 0; i < 4; ++i) {
        EXPECT_NEAR(2.0 * r[2 * i] - 1.0, x[i], 1e-15) << i;
        EXPECT_NEAR(2.0 * r[2 * i + 1], w[i], 1e-15) << i;
    }
}

TEST(Quadrature, ExactForPolynomialsUpToDegreeTwoNMinusOne) {
    for (int n = 1; n <= kMaxGaussPanelNodes; ++n) {
        const std::vector<double> r = unit_gauss_legendre(n);
        for (int d = 0; d <= 2 * n - 1; ++d)
            EXPECT_NEAR(integrate(r, [d](double x) { return std::pow(x, d); }), 1.0 / (d + 1), 2e-15) << n << " " << d;
        const double remainder =
            std::exp(4.0 * std::lgamma(n + 1.0) - 2.0 * std::lgamma(2.0 * n + 1.0)) / (2.0 * n + 1.0);
        const double error = 1.0 / (2 * n + 1) - integrate(r, [n](double x) { return std::pow(x, 2 * n); });
        if (remainder > 1e-11) {
            EXPECT_NEAR(error, remainder, 1e-3 * remainder + 1e-15) << n;
        }
    }
}

// Past 16 nodes, panels: each panel's rule is exact for degree 2p − 1 on its own width, so a
// piecewise polynomial with breaks at the panel ends (here: 100 nodes → 7 panels of 14 or 15 nodes,
// ends at multiples of 14–15 nodes / 100) is exact; and smooth functions are integrated to rounding.
TEST(Quadrature, PanelsAreExactPanelByPanelAndConverge) {
    const std::vector<double> r = unit_gauss_legendre(100);
    EXPECT_NEAR(integrate(r, [](double x) { return std::pow(x, 27); }), 1.0 / 28.0, 2e-15);
    EXPECT_NEAR(integrate(r, [](double x) { return std::exp(-20.0 * x); }), -std::expm1(-20.0) / 20.0, 1e-15);
    EXPECT_NEAR(integrate(unit_gauss_legendre(40), [](double x) { return std::cos(30.0 * x); }),
                std::sin(30.0) / 30.0, 1e-13);
    // the even split: 33 nodes → 3 panels of 11 (the first gets any remainder)
    const std::vector<double> p = unit_gauss_legendre(33);
    EXPECT_LT(p[2 * 10], 1.0 / 3.0);
    EXPECT_GT(p[2 * 11], 1.0 / 3.0);
}

}  // namespace
}  // namespace airmass
