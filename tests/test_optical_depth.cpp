// Optical depth along rays (optical_depth.hpp) against brute-force adaptive quadrature of
// the scene's own DensityProfile::at (profile_segment_mass_reference, long-double
// geometry), and against the mpmath table tests/data/optical_depth_reference.csv
// (scripts/gen_optical_depth_reference.py, 30 digits, independent of this code).
#include <gtest/gtest.h>

#include <boost/math/quadrature/gauss.hpp>

#include <cmath>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "test_scenes.hpp"
#include "airmass/optical_depth.hpp"

namespace airmass {
namespace {

constexpr double kR = 6360e3;
constexpr double kTop = 60e3;
constexpr double kInf = std::numeric_limits<double>::infinity();

PlanetRay<double> ray_deg(double h0, double zenith_deg) {
    return {kR, h0, ZenithAngle<double>::from_degrees(zenith_deg)};
}

// Zenith angle (deg) of the ray from altitude h0 whose periapsis is at altitude hp.
double zenith_for_periapsis(double h0, double hp) {
    return 180.0 - std::asin((kR + hp) / (kR + h0)) * 180.0 / M_PI;
}

using test::exponential_profile;
using test::tent_profile;

struct Segment {
    const char* what;
    PlanetRay<double> ray;
    double t0, t1;
};

// The geometries the brief names: zenith, horizontal, grazing, below the horizon to the
// ground, from space through the limb, finite segments on either side of the periapsis,
// a segment across it, short segments.
std::vector<Segment> segments(double H) {
    std::vector<Segment> s;
    s.push_back({"zenith from the ground", ray_deg(0.0, 0.0), 0.0, kInf});
    s.push_back({"horizontal from the ground", ray_deg(0.0, 90.0), 0.0, kInf});
    s.push_back({"horizontal from 5 km", ray_deg(5e3, 90.0), 0.0, kInf});
    const auto graze = ray_deg(10e3, zenith_for_periapsis(10e3, 100.0));
    s.push_back({"grazing, periapsis 100 m up", graze, 0.0, kInf});
    const auto below = ray_deg(10e3, 95.0);
    s.push_back({"below the horizon to the ground", below, 0.0, ground_distance_m(below)});
    const auto down = ray_deg(2e3, 180.0);
    s.push_back({"straight down to the ground", down, 0.0, ground_distance_m(down)});
    const auto limb = ray_deg(1e6, zenith_for_periapsis(1e6, 20e3));
    const double tp = -limb.periapsis_offset_m();
    s.push_back({"from 1000 km through the limb", limb, intersect_sphere(limb, 50.0 * H).t_near, kInf});
    s.push_back({"segment descending to the periapsis", limb, tp - 300e3, tp - 1e3});
    s.push_back({"segment across the periapsis", limb, tp - 50e3, tp + 80e3});
    s.push_back({"short segment at the periapsis", limb, tp - 10.0, tp + 10.0});
    s.push_back({"short segment, slant", ray_deg(3e3, 60.0), 100.0, 101.0});
    s.push_back({"segment above the periapsis", ray_deg(5e3, 80.0), 1e3, 50e3});
    return s;
}

// exponential_segment_mass with the exact Chapman method vs quadrature, ≤ 1e-6 relative
// (observed ~1e-12: the only error sources are the quadratures).
TEST(OpticalDepth, ExponentialSegmentsMatchQuadrature) {
    for (double H : {8000.0, 1200.0, 10.0, 1e6}) {
        for (const auto& seg : segments(H)) {
            const double got = exponential_segment_mass(ChapmanMethod::exact, seg.ray, H, 0.0, seg.t0, seg.t1);
            // no top: integrate to where the density is e^-50 of the origin's
            const double top = seg.ray.altitude_m + 50.0 * H;
            const double ref = profile_segment_mass_reference(exponential_profile(H), seg.ray, top, seg.t0, seg.t1, 1e-13);
            ASSERT_TRUE(std::isfinite(got)) << seg.what << " H=" << H;
            if (ref < 1e-290) {  // e.g. H = 10 m at 20 km: both underflow
                EXPECT_LT(got, 1e-280) << seg.what << " H=" << H;
                continue;
            }
            EXPECT_NEAR(got / ref, 1.0, 1e-6) << seg.what << " H=" << H << " got " << got << " ref " << ref;
        }
    }
}

// Every Chapman method gives finite, non-negative masses on the same segments, within its
// own accuracy of the exact one (the short-segment fallback keeps even the crude methods
// meaningful where a difference would cancel).
TEST(OpticalDepth, EveryMethodIsFiniteAndClose) {
    for (const auto& m : chapman_methods()) {
        // the published approximations are 10–30 % off near the horizon (their reports)
        const double tol = m.method == ChapmanMethod::airmass ? 1e-5 : 0.5;
        for (const auto& seg : segments(8000.0)) {
            const double got = exponential_segment_mass(m.method, seg.ray, 8000.0, 0.0, seg.t0, seg.t1);
            const double ref = exponential_segment_mass(ChapmanMethod::exact, seg.ray, 8000.0, 0.0, seg.t0, seg.t1);
            ASSERT_TRUE(std::isfinite(got) && got >= 0.0) << m.name << " " << seg.what;
            EXPECT_NEAR(got / ref, 1.0, tol) << m.name << " " << seg.what;
        }
    }
}

TEST(OpticalDepth, FloatExponentialIsFiniteAndClose) {
    for (const auto& seg : segments(8000.0)) {
        const PlanetRay<float> rf{float(kR), float(seg.ray.altitude_m),
                                  {float(seg.ray.zenith.cos_chi), float(seg.ray.zenith.sin_chi)}};
        const float got = exponential_segment_mass<float>(ChapmanMethod::airmass, rf, 8000.0f, 0.0f, float(seg.t0),
                                                          float(seg.t1));
        const double ref = exponential_segment_mass(ChapmanMethod::exact, seg.ray, 8000.0, 0.0, seg.t0, seg.t1);
        ASSERT_TRUE(std::isfinite(got) && got >= 0.0f) << seg.what;
        // float positions carry ~0.4 m at planet scale: 1e-3 relative except the 1 m segment
        const double tol = seg.t1 - seg.t0 < 100.0 ? 0.5 : 1e-3;
        EXPECT_NEAR(got / ref, 1.0, tol) << seg.what;
    }
}

TEST(OpticalDepth, IntegralOfRadiusClosedForm) {
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> U(0.0, 1.0);
    for (int k = 0; k < 2000; ++k) {
        const double p = k % 10 == 0 ? 0.0 : 7e6 * U(rng);
        const double s0 = k % 7 == 0 ? 0.0 : 3e6 * U(rng) * U(rng);
        const double s1 = s0 + 1e6 * U(rng) * U(rng) * U(rng);
        // long-double closed form ½[s r + p² asinh(s/p)] evaluated naively, as reference
        using LD = long double;
        const auto F = [&](LD s) {
            const LD r = std::sqrt(LD(p) * p + s * s);
            return p > 0 ? 0.5L * (s * r + LD(p) * p * std::asinh(s / LD(p))) : 0.5L * s * s;
        };
        const LD ref = F(s1) - F(s0);
        EXPECT_NEAR(integral_of_radius(p, s0, s1), double(ref), 1e-12 * double(ref) + 1e-6) << p << " " << s0;
    }
}

// Lengths from the smallest subnormal to the largest double: never NaN; a number between the
// bounds (s1 − s0)·r(s0) and (s1 − s0)·r(s1) (r grows with s) whenever those are numbers, +inf only
// where the integral itself exceeds the largest double.
TEST(OpticalDepth, IntegralOfRadiusAtExtremeLengths) {
    using LD = long double;  // x87 extended: neither bound under- or overflows at these lengths
    const double v[] = {0.0, 4.9e-324, 1e-310, 1e-200, 1e-160, 1e-20, 1.0, 6.4e6, 1e100, 1e150, 1e154, 1e200, 1e308};
    for (double p : v)
        for (double s0 : v)
            for (double s1 : v) {
                if (s1 < s0) continue;
                const double got = integral_of_radius(p, s0, s1);
                ASSERT_FALSE(std::isnan(got)) << p << " " << s0 << " " << s1;
                const LD d = LD(s1) - LD(s0);
                const LD lo = d * std::sqrt(LD(p) * p + LD(s0) * s0), hi = d * std::sqrt(LD(p) * p + LD(s1) * s1);
                if (hi < 1e307L) {
                    EXPECT_GE(LD(got), lo * (1 - 1e-12L) - 1e-300L) << p << " " << s0 << " " << s1;
                    EXPECT_LE(LD(got), hi * (1 + 1e-12L) + 1e-300L) << p << " " << s0 << " " << s1;
                } else if (lo > 1.8e308L) {
                    EXPECT_TRUE(std::isinf(got)) << p << " " << s0 << " " << s1;
                }
            }
}

// A finite far end beyond 1.3e154 m (float 1.8e19 m): the same mass as to infinity (it was NaN,
// or a quadrature's garbage, when the squared length overflowed).
TEST(OpticalDepth, SegmentsToHugeFiniteEnds) {
    const PlanetRay<double> up{6360e3, 0.0, ZenithAngle<double>::from_degrees(0.0)};
    const PlanetRay<double> slant{6360e3, 2e3, ZenithAngle<double>::from_degrees(70.0)};
    const double inf = std::numeric_limits<double>::infinity();
    for (const auto* ray : {&up, &slant})
        for (double H : {1e-3, 8000.0, 1e7})
            for (double end : {1e155, 1e200, std::numeric_limits<double>::max()}) {
                const double to_inf = exponential_segment_mass(ChapmanMethod::airmass, *ray, H, 0.0, 0.0, inf);
                const double got = exponential_segment_mass(ChapmanMethod::airmass, *ray, H, 0.0, 0.0, end);
                EXPECT_NEAR(got, to_inf, 1e-12 * to_inf) << "H " << H << " end " << end;  // 0 both: H = 1 mm from 2 km
            }
    const PlanetRay<float> upf{6360e3f, 0.0f, ZenithAngle<float>::from_degrees(0.0)};
    const float to_inf = exponential_segment_mass(ChapmanMethod::airmass, upf, 8000.0f, 0.0f, 0.0f,
                                                  std::numeric_limits<float>::infinity());
    for (float end : {1e20f, 1e30f, std::numeric_limits<float>::max()})
        EXPECT_NEAR(exponential_segment_mass(ChapmanMethod::airmass, upf, 8000.0f, 0.0f, 0.0f, end) / to_inf, 1.0f,
                    1e-5f) << end;
}

// Piecewise-linear profiles (tent, constant, knots with a jump) in closed form vs quadrature.
TEST(OpticalDepth, PiecewiseLinearClosedFormMatchesQuadrature) {
    std::vector<DensityProfile> profiles;
    profiles.push_back(tent_profile(10e3, 25e3, 40e3));
    profiles.push_back(tent_profile(0.0, 0.0, 3e3));  // a jump at the ground
    DensityProfile c;
    c.kind = DensityProfile::Kind::constant;
    c.bottom_m = 1e3;
    c.top_m = 2e3;
    c.value = 0.5;
    profiles.push_back(c);
    DensityProfile k;
    k.kind = DensityProfile::Kind::piecewise_linear;
    k.knots = {{0.0, 2.0}, {1e3, 1.0}, {5e3, 1.5}, {20e3, 0.1}, {30e3, 0.3}};
    profiles.push_back(k);

    Scene scene;
    scene.planet = {kR, kR + kTop, 0.1};
    for (const auto& p : profiles) {
        Constituent con;
        con.name = "x";
        con.profile = p;
        con.absorption.value_per_m = 1e-6;
        scene.constituents.push_back(con);
    }
    const double wl[] = {550.0};
    const Atmosphere atm = compile_atmosphere(scene, wl);
    ASSERT_EQ(atm.constituents.size(), profiles.size());
    std::vector<Segment> segs = segments(8000.0);
    segs.push_back({"ozone tangent", ray_deg(100e3, zenith_for_periapsis(100e3, 25e3)), 0.0, kInf});
    segs.push_back({"ozone from below", ray_deg(0.0, 70.0), 0.0, kInf});
    // a finite end so far out that s² overflows (review of 36b4bf0: it returned 0 for the tent)
    segs.push_back({"ozone from below, end at 1e200 m", ray_deg(0.0, 70.0), 0.0, 1e200});
    for (std::size_t i = 0; i < profiles.size(); ++i) {
        for (const auto& seg : segs) {
            const double got = profile_segment_mass(atm.constituents[i].profile, ChapmanMethod::exact, seg.ray, kTop,
                                                    seg.t0, seg.t1);
            const double ref = profile_segment_mass_reference(profiles[i], seg.ray, kTop, seg.t0, seg.t1, 1e-13);
            ASSERT_TRUE(std::isfinite(got)) << i << " " << seg.what;
            EXPECT_NEAR(got, ref, 1e-9 * ref + 1e-9) << "profile " << i << ": " << seg.what;
        }
    }
}

// The reference itself from just below a tent's top: there (top − h) of an altitude rounded to a
// double is noisy at ~1e-9 of itself, which Boost's relative-only bisection never accepted at
// 1e-9 — the 4 mm case took 2²⁵ pieces and 58 s (a sun ray of single_scattering_reference,
// `earth` from 400 km through a tangent altitude of 40 km). With the column's absolute floor every
// case takes a few pieces and agrees with the closed form; before, these 20 cases together ran
// past the test's 600 s limit.
TEST(OpticalDepth, ReferenceMassesFromJustBelowATentsTopMatchTheClosedForm) {
    Scene scene;
    scene.planet = {kR, kR + kTop, 0.1};
    Constituent con;
    con.name = "ozone";
    con.profile = tent_profile(10e3, 25e3, 40e3);
    con.absorption.value_per_m = 1e-6;
    scene.constituents.push_back(con);
    const double wl[] = {550.0};
    EvalSettings es;
    es.chapman = ChapmanMethod::exact;
    const Atmosphere atm = compile_atmosphere(scene, wl, es);
    for (double below_m : {1e-6, 1e-3, 4e-3, 1e-2, 1.0})
        for (double zenith : {0.0, 30.0, 66.0, 89.0}) {
            const PlanetRay<double> ray = ray_deg(40e3 - below_m, zenith);
            const double got = profile_segment_mass(atm.constituents[0].profile, ChapmanMethod::exact, ray, kTop, 0.0, kInf);
            const double ref = profile_segment_mass_reference(con.profile, ray, kTop, 0.0, kInf, 1e-9);
            // the mass of ≈ (below_m / cos χ) of density ≈ below_m / 15 km: 1e-16 … 1e-4 m
            EXPECT_GT(ref, 0.0) << below_m << " m below, " << zenith << "°";
            EXPECT_NEAR(got, ref, 1e-6 * ref + 1e-14) << below_m << " m below, " << zenith << "°";
        }
}

Scene earth_like() { return test::earth_like_scene(); }

TEST(OpticalDepth, AtmosphereMassesMatchQuadratureToTheTop) {
    const Scene scene = earth_like();
    const double wl[] = {680.0, 550.0, 440.0};
    EvalSettings es;
    es.chapman = ChapmanMethod::exact;
    const Atmosphere atm = compile_atmosphere(scene, wl, es);
    ASSERT_EQ(atm.constituents.size(), 3u);
    EXPECT_TRUE(atm.constituents[0].profile.truncate_at_top);   // Rayleigh: e^-7.5 at the top matters
    EXPECT_FALSE(atm.constituents[1].profile.truncate_at_top);  // Mie: e^-50 does not
    for (const auto& seg : segments(8000.0)) {
        double m[kMaxConstituents];
        const bool open = constituent_masses(atm, seg.ray, seg.t0, seg.t1, std::span<double>(m, 3));
        ASSERT_TRUE(open) << seg.what;
        for (std::size_t i = 0; i < 3; ++i) {
            const double ref =
                profile_segment_mass_reference(scene.constituents[i].profile, seg.ray, kTop, seg.t0, seg.t1, 1e-13);
            EXPECT_NEAR(m[i], ref, 1e-6 * ref + 1e-12) << seg.what << " constituent " << i;
        }
    }
}

TEST(OpticalDepth, TransmittanceIdentities) {
    const Scene scene = earth_like();
    const double wl[] = {680.0, 550.0, 440.0};
    for (ChapmanMethod method : {ChapmanMethod::exact, ChapmanMethod::airmass}) {
        EvalSettings es;
        es.chapman = method;
        const Atmosphere atm = compile_atmosphere(scene, wl, es);
        const double tol = method == ChapmanMethod::exact ? 1e-10 : 1e-5;
        std::mt19937 rng(11);
        std::uniform_real_distribution<double> U(-1.0, 1.0);
        int tested = 0;
        for (int k = 0; k < 300; ++k) {
            // three points inside the shell, a and c up to 400 km apart, b between them
            const Vec3<double> a(0.0, 0.0, kR + 30e3 * (U(rng) + 1.0));
            const Vec3<double> c = a + Vec3<double>(200e3 * U(rng), 200e3 * U(rng), 30e3 * U(rng));
            const double f = 0.5 * (U(rng) + 1.0);
            const Vec3<double> b = a + f * (c - a);
            double tab[3], tbc[3], tac[3], tba[3];
            transmittance_between(atm, a, b, tab);
            transmittance_between(atm, b, c, tbc);
            transmittance_between(atm, a, c, tac);
            transmittance_between(atm, b, a, tba);
            for (int w = 0; w < 3; ++w) {
                ASSERT_TRUE(tab[w] >= 0.0 && tab[w] <= 1.0);
                if (tac[w] == 0.0) continue;  // through the ground
                EXPECT_NEAR(tab[w] * tbc[w] / tac[w], 1.0, tol) << k;
                EXPECT_NEAR(tab[w] / tba[w], 1.0, tol) << k;
                ++tested;
            }
        }
        EXPECT_GT(tested, 300);
    }
}

TEST(OpticalDepth, GroundIsOpaque) {
    const Atmosphere atm = compile_atmosphere(earth_like(), std::vector<double>{550.0});
    double T[1];
    // two points on opposite sides of the planet, and a ray from space through it
    transmittance_between(atm, {0.0, 0.0, kR + 1e3}, {0.0, 0.0, -(kR + 1e3)}, T);
    EXPECT_EQ(T[0], 0.0);
    transmittance(atm, ray_deg(1e6, 180.0), 0.0, kInf, T);
    EXPECT_EQ(T[0], 0.0);
    // but a segment that ends exactly on the ground is not blocked
    const auto down = ray_deg(1e3, 180.0);
    transmittance(atm, down, 0.0, ground_distance_m(down), T);
    EXPECT_GT(T[0], 0.9);
}

TEST(OpticalDepth, ExtremesAreFinite) {
    const Atmosphere atm = compile_atmosphere(earth_like(), std::vector<double>{440.0});
    for (double h0 : {0.0, 1.0, 30e3, kTop, kTop + 1.0, 1e6, 1e8}) {
        for (double zen : {0.0, 1e-6, 45.0, 89.999, 90.0, 90.001, 91.0, 100.0, 135.0, 179.999, 180.0}) {
            double tau[1];
            optical_depth(atm, ray_deg(h0, zen), 0.0, kInf, tau);
            EXPECT_FALSE(std::isnan(tau[0])) << h0 << " " << zen;
            EXPECT_GE(tau[0], 0.0);
        }
    }
}

// ∫ e^(−h(t)/H) dt from altitude h0 along zenith chi to where the line leaves the top, in
// long double: h(t) − h0 = t (2 s0 + t)/(r(t) + r0) (no difference of radii), 64-point
// Gauss–Legendre on each side of the periapsis (the integrand is smooth there; the adaptive
// reference subdivides the rounding of the top's step without end on segments this short).
double exponential_mass_to_the_top(double H, double h0, ZenithAngle<double> chi) {
    using LD = long double;
    const LD r0 = LD(kR) + h0, s0 = r0 * LD(chi.cos_chi), p = r0 * LD(chi.sin_chi);
    const LD rt = LD(kR) + kTop;
    // the top's far crossing, −s0 + √(c + s0²) with c = rt² − r0², as c/(s0 + √…) where that cancels
    const LD c = (rt - r0) * (rt + r0), root = std::sqrt(c + s0 * s0);
    const LD t_end = s0 > 0 ? c / (s0 + root) : root - s0;
    const auto rho = [&](LD t) {
        const LD r = std::sqrt(p * p + (s0 + t) * (s0 + t));
        return double(std::exp(-(LD(h0) + t * (2 * s0 + t) / (r + r0)) / H));
    };
    const auto gl = [&](LD a, LD b) {
        return boost::math::quadrature::gauss<double, 64>::integrate([&](double u) { return rho(a + (b - a) * LD(u)); },
                                                                   0.0, 1.0) *
               double(b - a);
    };
    const LD tp = -s0;
    return tp > 0 && tp < t_end ? gl(0, tp) + gl(tp, t_end) : gl(0, t_end);
}

// Sun masses from just below the top of the atmosphere: the closed form subtracts two
// column-sized Chapman terms there (the point's and the exit's), which cancel. Against the
// brute-force quadrature of the scene's profiles, for upward, horizontal and slightly
// downward suns, from 1 nm to 1 km below the top, at Earth's scale heights and at H = 1e7 m.
TEST(OpticalDepth, SunMassesJustBelowTheTop) {
    for (double H : {8000.0, 1e7}) {
        Scene scene = earth_like();
        scene.constituents[0].profile = exponential_profile(H);
        scene.constituents.resize(1);
        const Atmosphere atm = compile_atmosphere(scene, std::vector<double>{550.0});
        ASSERT_TRUE(atm.constituents[0].profile.truncate_at_top) << H;
        std::vector<double> hs, single;
        std::vector<ZenithAngle<double>> chis;
        for (double below : {1e-9, 1e-6, 1e-3, 1.0, 1e3})
            for (double zen : {0.0, 45.0, 89.0, 90.0, 90.5}) {
                const double h = kTop - below;
                const ZenithAngle<double> chi = ZenithAngle<double>::from_degrees(zen);
                double m[1] = {-1.0};
                ASSERT_TRUE(sun_masses(atm, h, chi, m));
                const double ref = exponential_mass_to_the_top(H, h, chi);
                ASSERT_GT(ref, 0.0) << H << " " << below << " " << zen;
                EXPECT_NEAR(m[0], ref, 1e-6 * ref) << "H " << H << ", " << below << " m below the top, " << zen << " deg";
                hs.push_back(h);
                chis.push_back(chi);
                single.push_back(m[0]);
            }
        // the same points in one batch (several lanes, and points far from the top mixed in) agree
        // with the single calls to the Chapman batch's rounding (1–2 ulps)
        for (double h : {0.0, 10e3, 40e3})
            for (double zen : {30.0, 89.0, 95.0}) {
                const ZenithAngle<double> chi = ZenithAngle<double>::from_degrees(zen);
                double m[1];
                if (!sun_masses(atm, h, chi, m)) continue;  // from the ground at 95°: in the shadow
                hs.push_back(h);
                chis.push_back(chi);
                single.push_back(m[0]);
            }
        std::vector<double> batch(hs.size(), -1.0);
        std::vector<unsigned char> lit(hs.size(), 0);
        sun_masses_batch(atm, hs, chis, batch, lit);
        for (std::size_t k = 0; k < hs.size(); ++k) {
            EXPECT_TRUE(lit[k]) << k;
            EXPECT_NEAR(batch[k], single[k], 1e-13 * single[k]) << "H " << H << ", point " << k;
        }
    }
}

// A point inside the planet sees no sun, whatever the sun's direction.
TEST(OpticalDepth, SunMassesBelowTheGroundAreDark) {
    const Atmosphere atm = compile_atmosphere(earth_like(), std::vector<double>{550.0});
    for (double h : {-1e-3, -1.0, -1e3, -kR + 1.0, -kR})
        for (double zen : {0.0, 45.0, 90.0, 135.0, 180.0}) {
            double m[3] = {-1.0, -1.0, -1.0}, T[1] = {-1.0};
            EXPECT_FALSE(sun_masses(atm, h, ZenithAngle<double>::from_degrees(zen), m)) << h << " " << zen;
            EXPECT_EQ(m[0], -1.0);  // left as it was
            EXPECT_FALSE(sun_transmittance(atm, h, ZenithAngle<double>::from_degrees(zen), T));
            EXPECT_EQ(T[0], 0.0);
        }
    // just above the ground, the sun overhead: lit, the whole column
    double m[3];
    EXPECT_TRUE(sun_masses(atm, 0.0, ZenithAngle<double>::from_degrees(0.0), m));
    EXPECT_NEAR(m[0], 8000.0, 8000.0 * 0.01);
}

// Segments that start or end at the planet's centre (or pass through it) go through the
// ground: opaque, not NaN.
TEST(OpticalDepth, FromThePlanetsCentre) {
    const Atmosphere atm = compile_atmosphere(earth_like(), std::vector<double>{550.0});
    const Vec3<double> centre(0.0, 0.0, 0.0);
    for (const Vec3<double>& p : {Vec3<double>(0.0, 0.0, kR + 1e3), Vec3<double>(1.0, 2.0, 3.0),
                                  Vec3<double>(3e6, -2e6, 7e6), Vec3<double>(0.0, 0.0, -1e9)}) {
        double T[1] = {-1.0};
        transmittance_between(atm, centre, p, T);
        EXPECT_EQ(T[0], 0.0) << p.x << " " << p.y << " " << p.z;
        T[0] = -1.0;
        transmittance_between(atm, p, centre, T);
        EXPECT_EQ(T[0], 0.0) << p.x << " " << p.y << " " << p.z;
    }
}

// The mpmath table: optical depths to 30 digits along rays of the Earth-like atmosphere
// (generated by scripts/gen_optical_depth_reference.py, which integrates the densities
// with mpmath.quad in its own geometry).
TEST(OpticalDepth, MatchesMpmathTable) {
    std::ifstream in(std::string(AIRMASS_TEST_DATA_DIR) + "/optical_depth_reference.csv");
    ASSERT_TRUE(in) << "tests/data/optical_depth_reference.csv missing";
    std::string line;
    std::getline(in, line);  // header
    EvalSettings es;
    es.chapman = ChapmanMethod::exact;
    const Scene scene = earth_like();
    int rows = 0;
    while (std::getline(in, line)) {
        if (line.empty() || line[0] == '#') continue;
        std::stringstream ss(line);
        std::string f;
        std::vector<double> v;
        while (std::getline(ss, f, ',')) v.push_back(std::stod(f));
        ASSERT_EQ(v.size(), 7u) << line;
        // altitude_m, zenith_deg, t0_m, t1_m (-1: to the top), mass_rayleigh, mass_mie, mass_ozone
        const auto ray = ray_deg(v[0], v[1]);
        const double t1 = v[3] < 0 ? kInf : v[3];
        const double wl[] = {550.0};
        const Atmosphere atm = compile_atmosphere(scene, wl, es);
        for (std::size_t i = 0; i < 3; ++i) {
            const double got = profile_segment_mass(atm.constituents[i].profile, es.chapman, ray, kTop, v[2], t1);
            EXPECT_NEAR(got, v[4 + i], 1e-9 * v[4 + i] + 1e-12) << line << " constituent " << i;
        }
        ++rows;
    }
    EXPECT_GE(rows, 10);
}

}  // namespace
}  // namespace airmass
