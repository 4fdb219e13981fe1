// The `airmass` method's four-lane kernel on GCC/Clang vector extensions
// (plugin/src/math/chapman_airmass_batch.inc), the only batch kernel on macOS and other non-x86
// platforms. chapman.cpp compiles it only off x86, so CI would never run it: here it is compiled
// into a namespace of its own (the vector extensions work on x86 too, two SSE2 registers per
// vector) and compared lane by lane with the scalar path, airmass_scaled_fast, on the batch tests'
// awkward points and on the inputs where the kernel once went wrong (negative sin chi below the
// horizon, x0 at the Ch∥ table's ends, x near the overflow of x · (a b q)).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <span>
#include <vector>

#include "airmass/chapman.hpp"
#include "math/chapman_airmass.hpp"

#if AIRMASS_CHAPMAN_VECTORS
namespace airmass::v4_test {
#include "math/chapman_airmass_batch.inc"
}  // namespace airmass::v4_test

namespace airmass {
namespace {

std::vector<ScaledChapman<double>> v4_batch(const std::vector<double>& xs, const std::vector<double>& cs,
                                            const std::vector<double>& ss) {
    std::vector<ScaledChapman<double>> r(xs.size());
    auto x_of = [&](size_t i) { return xs[i]; };
    auto out = [&](size_t i, ScaledChapman<double> v) { r[i] = v; };
    v4_test::airmass_batch<double>(detail::airmass_table(), detail::airmass_parallel_table(), x_of,
                                   std::span<const double>(cs), std::span<const double>(ss), out);
    return r;
}

bool same_nan(double a, double b) { return std::isnan(a) && std::isnan(b); }

// Batch vs scalar: the same formulas, differing in rounding (one shared division); the log scale
// d is rounded differently, which moves ln Ch by a few ulp(d).
void expect_agrees(const std::vector<double>& xs, const std::vector<double>& cs, const std::vector<double>& ss) {
    const auto r = v4_batch(xs, cs, ss);
    for (size_t i = 0; i < xs.size(); ++i) {
        const auto one = detail::airmass_scaled_fast<double>(detail::airmass_table(), detail::airmass_parallel_table(), xs[i],
                                                             cs[i], ss[i]);
        char where[160];
        std::snprintf(where, sizeof where, "i=%zu x=%.17g cos=%.17g sin=%.17g", i, xs[i], cs[i], ss[i]);
        if (std::isnan(one.mantissa) || std::isnan(r[i].mantissa)) {
            EXPECT_TRUE(same_nan(one.mantissa, r[i].mantissa)) << where << ": scalar " << one.mantissa << ", v4 " << r[i].mantissa;
            continue;
        }
        EXPECT_EQ(std::isfinite(one.log_scale), std::isfinite(r[i].log_scale)) << where;
        if (one.mantissa == r[i].mantissa && one.log_scale == r[i].log_scale) continue;
        // The same log scale: the mantissas alone (through ln Ch a huge log scale would hide them).
        if (one.log_scale == r[i].log_scale) {
            EXPECT_NEAR(r[i].mantissa / one.mantissa, 1.0, 1e-12)
                << where << ": scalar (" << one.mantissa << ", " << one.log_scale << "), v4 (" << r[i].mantissa << ")";
            continue;
        }
        const double tol = 1e-12 + 8 * std::numeric_limits<double>::epsilon() * std::abs(one.log_scale);
        EXPECT_LE(std::abs(std::expm1(std::log(r[i].mantissa) + r[i].log_scale - std::log(one.mantissa) - one.log_scale)), tol)
            << where << ": scalar (" << one.mantissa << ", " << one.log_scale << "), v4 (" << r[i].mantissa << ", "
            << r[i].log_scale << ")";
    }
}

TEST(ChapmanBatchV4, AgreesWithScalarOnAwkwardPoints) {
    std::vector<double> xs, cs, ss;
    for (double x : {1e-2, 3e-2, 0.5, 1.0, 7.0, 60.0, 760.0, 1e4, 3e5, 1e7, 1e120, 1e130, 5.84e134, 1e150})
        for (double chi : {0.0, 1e-6, 30.0, 60.0, 85.0, 89.9, 90.0 - 1e-7, 90.0, 90.0 + 1e-7, 90.1, 95.0, 120.0, 150.0, 179.0,
                           180.0 - 1e-7, 180.0}) {
            const auto a = ZenithAngle<double>::from_degrees(chi);
            xs.push_back(x), cs.push_back(a.cos_chi), ss.push_back(a.sin_chi);
        }
    expect_agrees(xs, cs, ss);
}

TEST(ChapmanBatchV4, NegativeSinBelowTheHorizonTakesTheCarefulPath) {
    // Was (2.0000000019, 5000) for the first lane where the scalar path gives NaN; s = −1 or −inf
    // made w NaN and its conversion INT_MIN (then a signed overflow in the cell offset).
    const double inf = std::numeric_limits<double>::infinity();
    expect_agrees({1e4, 100, 5, 1e4, 5, 50, 3, 3}, {-0.5, -0.5, -0.5, -0.5, -0.5, -0.5, -0.99, -0.99},
                  {-0.5, -1.0, -inf, -2.0, -1e-300, -0.1, -0.1, -0.01});
    const auto r = v4_batch({1e4}, {-0.5}, {-0.5});
    EXPECT_TRUE(std::isnan(r[0].mantissa)) << r[0].mantissa << " " << r[0].log_scale;
}

TEST(ChapmanBatchV4, HugeXNearTheNadirDoesNotOverflowD) {
    // d = x m²/(1 + sin chi): x · (a b q) overflowed for x ≳ 1e123 near chi = 180°.
    const auto r = v4_batch({5.84e134, 1e125, 1e140}, {-1.0, -1.0, -0.999}, {0.0, 0.0, std::sqrt(1 - 0.999 * 0.999)});
    EXPECT_NEAR(r[0].log_scale / 5.84e134, 1.0, 1e-15);
    EXPECT_NEAR(r[1].log_scale / 1e125, 1.0, 1e-15);
    expect_agrees({5.84e134, 1e125, 1e140}, {-1.0, -1.0, -0.999}, {0.0, 0.0, std::sqrt(1 - 0.999 * 0.999)});
    // Beyond x = 1e150 below the horizon the careful path, as the scalar path (its Ch∥(0) is 2, the
    // fast path's 2^-30 clamp 2.0000000019).
    expect_agrees({std::nextafter(1e150, 2e150), 1e155, 4.55542e156, 1e160}, {-1.0, -1.0, -1.0, -0.5}, {0.0, 0.0, 0.0, std::sqrt(0.75)});
}

TEST(ChapmanBatchV4, TheParallelTablesEnds) {
    std::vector<double> xs, cs, ss;
    const double inf = std::numeric_limits<double>::infinity();
    for (double x0 : {0.0, 5e-324, 1e-310, 0x1p-31, std::nextafter(0x1p-30, 0.0), 0x1p-30, 0x1p39, std::nextafter(0x1p40, 0.0), 0x1p40,
                      std::nextafter(0x1p40, inf), 1e13, 1e149})
        for (double s : {1.0, 0.5, 1e-300, 0.0}) {
            if (s == 0) {
                xs.push_back(x0), cs.push_back(-1.0), ss.push_back(0.0);
                continue;
            }
            xs.push_back(x0 / s), cs.push_back(-std::sqrt(1 - s * s)), ss.push_back(s);
        }
    expect_agrees(xs, cs, ss);
    // NaN, infinities, above-horizon lanes with s < −1 next to lanes below.
    const double nan = std::numeric_limits<double>::quiet_NaN();
    expect_agrees({nan, inf, 1, 1, 1, 1, 1e150, 1.0000000000000002e150, 3, 0, 1e4, 5},
                  {-0.5, -0.5, nan, -0.0, -1.0, -1.0, -0.5, -0.5, -1.0, -1.0, 0.5, -0.5},
                  {0.8660254037844386, 0.8660254037844386, 0.5, 1, 0, 0, 0.8660254037844386, 0.8660254037844386, 0, 0, -1.001,
                   0.8660254037844386});
    // cos chi outside [−1, 1]: ±inf NaN (the careful path), finite beyond −1 the careful path too.
    expect_agrees({10, 10, 10, 10, 1e4, 10, 5}, {inf, -inf, 1.5, -1.5, -1.0 - 1e-7, -1e200, -0.5},
                  {0, 0, 0, 0, 0, 0, 0.8660254037844386});
}

}  // namespace
}  // namespace airmass
#endif
