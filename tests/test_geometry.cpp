// Ray–sphere geometry (geometry.hpp) against long-double brute force, at planet scale,
// for observers on the ground, inside, at the top and far out, and at the degenerate
// angles (exactly 90°, tangent rays, straight down).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <glm/geometric.hpp>
#include <stdexcept>
#include <limits>

#include "airmass/geometry.hpp"

namespace airmass {
namespace {

constexpr double kR = 6360e3;
constexpr double kTop = 60e3;

// Long-double roots of |O + t d| = R + a for the observer at altitude h0, zenith mu.
bool roots_ld(double h0, double mu, double a, long double& lo, long double& hi) {
    using LD = long double;
    const LD r0 = LD(kR) + LD(h0), rr = LD(kR) + LD(a);
    const LD b = r0 * LD(mu);
    const LD D = b * b - (r0 - rr) * (r0 + rr);
    if (D < 0) return false;
    lo = -b - std::sqrt(D);
    hi = -b + std::sqrt(D);
    return true;
}

PlanetRay<double> ray_deg(double h0, double zenith_deg) {
    return {kR, h0, ZenithAngle<double>::from_degrees(zenith_deg)};
}

TEST(Geometry, SphereCrossingsMatchLongDouble) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> U(0.0, 1.0);
    int checked = 0;
    for (int k = 0; k < 20000; ++k) {
        const double h0 = std::pow(10.0, 7.0 * U(rng)) - 1.0;  // 0 … 1e7 m
        const double zen = 180.0 * U(rng);
        const double a = U(rng) < 0.5 ? 0.0 : kTop * U(rng);
        const auto ray = ray_deg(h0, zen);
        long double lo, hi;
        const bool hit_ld = roots_ld(h0, ray.zenith.cos_chi, a, lo, hi);
        const auto x = intersect_sphere(ray, a);
        // near-tangent lines may be classified either way; everywhere else they must agree
        const long double scale = (long double)(kR + h0);
        if (hit_ld && hi - lo > 1e-6L * scale) {
            ASSERT_TRUE(x.hit) << h0 << " " << zen;
            // each root to within rounding of the inputs (relative 1e-15 of the radius)
            EXPECT_NEAR(double(x.t_near), double(lo), 1e-8 * double(scale) + 1e-12 * std::abs(double(lo)));
            EXPECT_NEAR(double(x.t_far), double(hi), 1e-8 * double(scale) + 1e-12 * std::abs(double(hi)));
            ++checked;
        } else if (!hit_ld) {
            // the discriminant is within rounding of zero or negative
            EXPECT_TRUE(!x.hit || x.t_far - x.t_near < 1e-3 * double(scale));
        }
        EXPECT_TRUE(std::isfinite(x.t_near) && std::isfinite(x.t_far));
    }
    EXPECT_GT(checked, 10000);
}

TEST(Geometry, NearRootHasNoCancellation) {
    // A ground observer looking up: the top crossing 60 km away computed as c/q, not as
    // −b + √D (which would lose ~7 digits to the planet radius).
    const auto ray = ray_deg(0.0, 0.0);
    const auto x = intersect_sphere(ray, kTop);
    EXPECT_DOUBLE_EQ(x.t_far, kTop);
    // 1 mm above the top sphere, looking straight down: 1 mm to the top
    const double h0 = kTop + 1e-3;  // h0 − kTop is exact in binary (Sterbenz)
    const auto down = ray_deg(h0, 180.0);
    const auto y = intersect_sphere(down, kTop);
    EXPECT_NEAR(y.t_near, h0 - kTop, 1e-18);
    // and the ground is reached after exactly the altitude
    EXPECT_TRUE(hits_ground(down));
    EXPECT_NEAR(ground_distance_m(down), h0, 1e-9);
}

TEST(Geometry, ExactlyTangentRaysAreFiniteAndNotBlocked) {
    // On the ground looking at 90°: the double root at t = 0, no NaN, not blocked.
    const auto flat = ray_deg(0.0, 90.0);
    EXPECT_EQ(flat.zenith.cos_chi, 0.0);
    const auto g = intersect_sphere(flat, 0.0);
    EXPECT_TRUE(g.hit);
    EXPECT_EQ(g.t_near, 0.0);
    EXPECT_EQ(g.t_far, 0.0);
    EXPECT_FALSE(hits_ground(flat));
    const auto seg = atmosphere_segment(flat, kTop);
    EXPECT_TRUE(seg.valid);
    EXPECT_FALSE(seg.hits_ground);
    EXPECT_NEAR(seg.t_end, std::sqrt((2 * kR + kTop) * kTop), 1e-6);
    // the smallest step below the horizon from the ground is blocked at distance 0
    const PlanetRay<double> below{kR, 0.0, {-1e-150, 1.0}};  // (R cos)² still > 0
    EXPECT_TRUE(hits_ground(below));
    EXPECT_EQ(ground_distance_m(below), 0.0);
    // looking down from the ground: hits at 0
    EXPECT_TRUE(hits_ground(ray_deg(0.0, 180.0)));
    EXPECT_EQ(ground_distance_m(ray_deg(0.0, 180.0)), 0.0);
}

TEST(Geometry, GrazingGroundFromAltitude) {
    // From 10 km the geometric horizon dips by acos(R/(R+h)); 1e-6 rad beyond it the ray
    // still hits, 1e-6 rad before it it does not.
    const double h0 = 10e3;
    const double dip = std::acos(kR / (kR + h0));
    const double zen_h = 90.0 + dip * 180.0 / M_PI;
    const auto hit = ray_deg(h0, zen_h + 1e-4);
    const auto miss = ray_deg(h0, zen_h - 1e-4);
    EXPECT_TRUE(hits_ground(hit));
    EXPECT_FALSE(hits_ground(miss));
    long double lo, hi;
    ASSERT_TRUE(roots_ld(h0, hit.zenith.cos_chi, 0.0, lo, hi));
    EXPECT_NEAR(ground_distance_m(hit), double(lo), 1e-6 * double(lo));
    // periapsis altitude of the missing ray is positive and tiny, computed without cancellation
    const double hp = miss.periapsis_altitude_m();
    const long double r0 = (long double)kR + h0, s = std::sin((long double)(zen_h - 1e-4) * M_PIl / 180.0L);
    EXPECT_NEAR(hp, double(r0 * s - kR), 1e-6);
    EXPECT_GT(hp, 0.0);
}

TEST(Geometry, AltitudeAlongTheRay) {
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> U(0.0, 1.0);
    for (int k = 0; k < 5000; ++k) {
        const double h0 = 1e6 * U(rng) * U(rng);
        const double zen = 180.0 * U(rng);
        const double t = 2e6 * U(rng) * U(rng);
        const auto ray = ray_deg(h0, zen);
        using LD = long double;
        const LD r0 = LD(kR) + h0, mu = ray.zenith.cos_chi;
        const LD h_ld = std::sqrt(r0 * r0 + 2 * r0 * mu * t + LD(t) * t) - kR;
        // absolute accuracy ~1e-15 of the radius (1e-8 m), whatever the cancellation
        EXPECT_NEAR(ray.altitude_at(t), double(h_ld), 1e-8 + 1e-14 * std::abs(double(h_ld)));
        const auto z = ray.zenith_at(t);
        EXPECT_NEAR(z.cos_chi * z.cos_chi + z.sin_chi * z.sin_chi, 1.0, 1e-14);
    }
}

TEST(Geometry, AtmosphereSegments) {
    // ground, looking up
    auto s = atmosphere_segment(ray_deg(0.0, 0.0), kTop);
    EXPECT_TRUE(s.valid && !s.hits_ground);
    EXPECT_DOUBLE_EQ(s.t_end, kTop);
    // inside, looking down: hits the ground after the altitude
    s = atmosphere_segment(ray_deg(5e3, 180.0), kTop);
    EXPECT_TRUE(s.valid && s.hits_ground);
    EXPECT_NEAR(s.t_end, 5e3, 1e-9);
    // at the top, looking up: an empty segment
    s = atmosphere_segment(ray_deg(kTop, 0.0), kTop);
    EXPECT_TRUE(s.valid);
    EXPECT_EQ(s.t_end, 0.0);
    // 1000 km out: straight down enters at 940 km and hits the ground at 1000 km
    s = atmosphere_segment(ray_deg(1e6, 180.0), kTop);
    EXPECT_TRUE(s.valid && s.hits_ground);
    EXPECT_NEAR(s.t_begin, 1e6 - kTop, 1e-6);
    EXPECT_NEAR(s.t_end, 1e6, 1e-6);
    // 1000 km out looking away, or missing the atmosphere
    EXPECT_FALSE(atmosphere_segment(ray_deg(1e6, 10.0), kTop).valid);
    EXPECT_FALSE(atmosphere_segment(ray_deg(1e6, 100.0), kTop).valid);
    // through the limb: periapsis 30 km up, no ground
    const double r0 = kR + 1e6, p = kR + 30e3;
    const double zen = 180.0 - std::asin(p / r0) * 180.0 / M_PI;
    s = atmosphere_segment(ray_deg(1e6, zen), kTop);
    EXPECT_TRUE(s.valid && !s.hits_ground);
    const double half = std::sqrt((kR + kTop) * (kR + kTop) - p * p);
    EXPECT_NEAR(s.t_end - s.t_begin, 2 * half, 1e-3);
}

TEST(Geometry, FromVectorsKeepsHorizonAccuracy) {
    // A point 1 m above a 6360 km sphere with a direction 1e-9 rad below the horizontal.
    const Vec3<double> O(0.0, 0.0, kR + 1.0);
    const Vec3<double> d(1.0, 0.0, -1e-9);
    const auto ray = PlanetRay<double>::from_vectors(kR, O, d);
    EXPECT_NEAR(ray.altitude_m, 1.0, 1e-8);
    EXPECT_NEAR(ray.zenith.cos_chi, -1e-9, 1e-20);
    EXPECT_NEAR(ray.zenith.sin_chi, 1.0, 1e-16);
}

TEST(Geometry, DirectionConventions) {
    // airmass eval: zenith and azimuth from +X toward +Y
    auto d = direction_from_zenith_azimuth_deg<double>(90.0, 0.0);
    EXPECT_EQ(d.z, 0.0);
    EXPECT_NEAR(d.x, 1.0, 1e-16);
    d = direction_from_zenith_azimuth_deg<double>(90.0, 90.0);
    EXPECT_NEAR(d.y, 1.0, 1e-16);
    // Blender Sky Texture rotation: 0° → +Y, 90° → +X
    auto b = direction_from_elevation_azimuth_deg<double>(0.0, 0.0);
    EXPECT_NEAR(b.y, 1.0, 1e-16);
    EXPECT_EQ(b.z, 0.0);
    b = direction_from_elevation_azimuth_deg<double>(0.0, 90.0);
    EXPECT_NEAR(b.x, 1.0, 1e-16);
    b = direction_from_elevation_azimuth_deg<double>(90.0, 0.0);
    EXPECT_EQ(b.z, 1.0);
}

TEST(Geometry, FloatIsFiniteAndCloseToDouble) {
    for (double h0 : {0.0, 1.0, 1e3, 6e4, 1e6}) {
        for (double zen : {0.0, 45.0, 89.9, 90.0, 90.1, 95.0, 135.0, 179.9, 180.0}) {
            const PlanetRay<float> rf{float(kR), float(h0), ZenithAngle<float>::from_degrees(zen)};
            const auto rd = ray_deg(h0, zen);
            for (float a : {0.0f, 30e3f, 60e3f}) {
                const auto xf = intersect_sphere(rf, a);
                const auto xd = intersect_sphere(rd, double(a));
                EXPECT_TRUE(std::isfinite(xf.t_near) && std::isfinite(xf.t_far));
                if (xd.hit && xd.t_far - xd.t_near > 1e3) {
                    ASSERT_TRUE(xf.hit);
                    // float carries 2^-24 of the planet radius (≈ 0.4 m) in each root
                    EXPECT_NEAR(xf.t_far, xd.t_far, 2.0 + 1e-6 * std::abs(xd.t_far));
                }
            }
            const auto sf = atmosphere_segment(rf, float(kTop));
            const auto sd = atmosphere_segment(rd, kTop);
            EXPECT_EQ(sf.valid, sd.valid);
            EXPECT_TRUE(std::isfinite(sf.t_begin) && std::isfinite(sf.t_end));
            EXPECT_TRUE(std::isfinite(rf.altitude_at(1000.0f)));
            EXPECT_TRUE(std::isfinite(rf.periapsis_altitude_m()));
        }
    }
}

// Lengths whose squares leave the type's range: radius and altitude along the ray are numbers
// up to the largest length (they used to be inf and NaN from 1.3e154 m, float 1.8e19 m), and
// from_vectors takes directions and origins of any finite, non-zero size.
TEST(Geometry, HugeAndTinyLengths) {
    const PlanetRay<double> up{6360e3, 0.0, ZenithAngle<double>::from_degrees(45.0)};
    for (double t : {1e155, 1e200, 1e300, std::numeric_limits<double>::max() / 2}) {
        const double r = up.radius_at(t), h = up.altitude_at(t);
        ASSERT_TRUE(std::isfinite(r) && std::isfinite(h)) << t;
        EXPECT_NEAR(r / t, 1.0, 1e-12) << t;
        EXPECT_NEAR(h / t, 1.0, 1e-12) << t;
        EXPECT_NEAR(up.zenith_at(t).cos_chi, 1.0, 1e-12) << t;
    }
    const PlanetRay<float> upf{6360e3f, 0.0f, ZenithAngle<float>::from_degrees(45.0)};
    for (float t : {1e20f, 1e30f, std::numeric_limits<float>::max() / 4}) {
        ASSERT_TRUE(std::isfinite(upf.radius_at(t)) && std::isfinite(upf.altitude_at(t))) << t;
        EXPECT_NEAR(upf.altitude_at(t) / t, 1.0f, 1e-5f) << t;
    }
    const double R = 6360e3;
    const Vec3<double> o{0.0, 3e5, R + 1e3}, d{0.3, -0.2, 0.5};
    const auto ref = PlanetRay<double>::from_vectors(R, o, d);
    for (double k : {1e-300, 1e-200, 1e155, 1e300}) {
        const auto ray = PlanetRay<double>::from_vectors(R, o, d * k);
        EXPECT_NEAR(ray.zenith.cos_chi, ref.zenith.cos_chi, 1e-15) << k;
        EXPECT_NEAR(ray.zenith.sin_chi, ref.zenith.sin_chi, 1e-15) << k;
        EXPECT_EQ(ray.altitude_m, ref.altitude_m) << k;
    }
    for (double k : {1e160, 1e300}) {  // an origin whose squared length overflows
        const auto far = PlanetRay<double>::from_vectors(R, o * k, d);
        ASSERT_TRUE(std::isfinite(far.altitude_m)) << k;
        EXPECT_NEAR(far.altitude_m / (glm::length(o) * k), 1.0, 1e-12) << k;
        EXPECT_NEAR(far.zenith.cos_chi, ref.zenith.cos_chi, 1e-6) << k;  // the origin's direction
    }
    EXPECT_THROW(PlanetRay<double>::from_vectors(R, o, Vec3<double>(0.0)), std::invalid_argument);
    EXPECT_THROW(PlanetRay<double>::from_vectors(R, o, Vec3<double>(1.0, std::numeric_limits<double>::infinity(), 0.0)),
                 std::invalid_argument);
}

// ZenithAngle::from_cos: a cosine within a few ulps of ±1 (a dot product of unit vectors)
// is the exact end; beyond that, or NaN, it is refused by name, not turned into a sine of 0.
template <class T>
void check_from_cos() {
    constexpr T eps = std::numeric_limits<T>::epsilon();
    for (T c : {T(1) + eps, T(1) + 4 * eps, T(1) + 16 * eps, T(1)}) {
        const auto z = ZenithAngle<T>::from_cos(c);
        EXPECT_EQ(z.cos_chi, T(1));
        EXPECT_EQ(z.sin_chi, T(0));
        const auto n = ZenithAngle<T>::from_cos(-c);
        EXPECT_EQ(n.cos_chi, T(-1));
        EXPECT_EQ(n.sin_chi, T(0));
    }
    const auto h = ZenithAngle<T>::from_cos(T(0));
    EXPECT_EQ(h.sin_chi, T(1));
    for (T c : {T(1) + 17 * eps, -(T(1) + 17 * eps), T(1.001), T(2), T(-1.5), std::numeric_limits<T>::infinity(),
                -std::numeric_limits<T>::infinity(), std::numeric_limits<T>::quiet_NaN()}) {
        try {
            (void)ZenithAngle<T>::from_cos(c);
            ADD_FAILURE() << "accepted cos_chi = " << c;
        } catch (const std::invalid_argument& e) {
            EXPECT_NE(std::string(e.what()).find("cos_chi"), std::string::npos) << e.what();
            // the value in full: 1 + 17 ulps must not read as 1.000000
            if (std::abs(c) > T(1) && std::abs(c) < T(1.001)) {
                const std::string what = e.what();
                EXPECT_EQ(what.find("= 1 "), std::string::npos) << what;
                EXPECT_EQ(what.find("= 1.000000 "), std::string::npos) << what;
                EXPECT_EQ(what.find("= -1 "), std::string::npos) << what;
            }
        }
    }
}

TEST(Geometry, ZenithFromCosRefusesOutOfRange) {
    check_from_cos<double>();
    check_from_cos<float>();
}

}  // namespace
}  // namespace airmass
