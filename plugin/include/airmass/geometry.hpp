// Ray geometry in a spherically symmetric atmosphere.
//
// A straight ray from a point at altitude h0 (radius r0 = R + h0, R the planet radius)
// with direction zenith angle chi is, by spherical symmetry, fully described by
// (R, h0, cos chi, sin chi). Everything here works in the ray's own 1-D coordinates:
//
//   t  distance along the ray from its origin (metres; the ray is the set t ≥ 0,
//      but t < 0 is meaningful for the full line);
//   s  signed distance from the periapsis, the point of the line closest to the
//      planet centre (Schüler 2012 §2.3, Golubev 2019 Eqs. 31–32):
//          s = s0 + t,   s0 = r0 cos chi,
//      with periapsis radius p = r0 sin chi, so that r(s) = sqrt(p² + s²).
//
// Numerical care (the planet is ~1e6 times the interesting lengths):
//   * radii are never subtracted: altitudes along the ray come from
//         h(t) = h0 + t (2 s0 + t) / (r0 + r(t))                      (exact identity)
//     and the periapsis altitude from h_p = h0 − r0 cos²chi / (1 + sin chi);
//   * a sphere of altitude a is crossed where (s² = (R + a)² − p²)
//         t = −s0 ± sqrt(D),   D = (a − h0)(2R + a + h0) + s0²,
//     and the two roots are formed with the stable quadratic (q = −(s0 + sign(s0) √D),
//     roots q and c/q with c = (h0 − a)(2R + h0 + a)), so neither root cancels;
//   * a tangent ray (D = 0 exactly) gives a double root, never a NaN;
//   * cos and sin of the zenith angle travel together (ZenithAngle, chapman.hpp), so a
//     ray at exactly 90° has cos = 0 and sin = 1.
// All functions are templates instantiated for float and double.
#pragma once

#include <glm/vec3.hpp>

#include "airmass/chapman.hpp"

namespace airmass {

template <class T>
using Vec3 = glm::vec<3, T, glm::defaultp>;

// A ray (origin and direction) reduced to its spherically symmetric invariants.
template <class T>
struct PlanetRay {
    T planet_radius_m;     // R
    T altitude_m;          // h0 of the origin above the planet surface (≥ 0 for physical rays)
    ZenithAngle<T> zenith;  // of the direction, at the origin

    // From a planet-centred origin (metres) and a direction (need not be unit; finite and non-zero,
    // else std::invalid_argument).
    static PlanetRay from_vectors(T planet_radius_m, Vec3<T> origin_m, Vec3<T> direction);

    T radius_m() const { return planet_radius_m + altitude_m; }              // r0
    T periapsis_offset_m() const { return radius_m() * zenith.cos_chi; }     // s0: origin's s
    T periapsis_radius_m() const { return radius_m() * zenith.sin_chi; }     // p
    T periapsis_altitude_m() const;                                           // h_p = p − R, no cancellation
    T radius_at(T t_m) const;                                                 // r(t) = hypot(p, s0 + t)
    T altitude_at(T t_m) const;                                               // h(t), see above
    ZenithAngle<T> zenith_at(T t_m) const;                                    // (s/r, p/r) at t
};

// The two parameters t where the full line crosses the sphere of altitude `a` (radius
// R + a); t_near ≤ t_far. `hit` is false when the line misses (D < 0); a tangent line
// has t_near == t_far.
template <class T>
struct SphereCrossing {
    bool hit = false;
    T t_near = T(0);
    T t_far = T(0);
};

template <class T>
SphereCrossing<T> intersect_sphere(const PlanetRay<T>& ray, T sphere_altitude_m);

// True when the ray (t > 0) is blocked by the ground: it heads down (s0 < 0) and the
// line dips below the surface (D > 0). A ray exactly tangent to the ground is not blocked.
template <class T>
bool hits_ground(const PlanetRay<T>& ray);

// Distance to the ground along the ray (valid when hits_ground(ray)): the near root,
// 0 for an observer on the ground looking down.
template <class T>
T ground_distance_m(const PlanetRay<T>& ray);

// The part of the ray inside the atmosphere shell [ground, top]: t in [t_begin, t_end].
// For an observer inside, t_begin = 0; from space, t_begin is the entry into the top
// sphere. t_end is the ground hit or the exit through the top. `valid` is false when
// the ray never enters the shell (misses it, or points away from it from space).
template <class T>
struct AtmosphereSegment {
    bool valid = false;
    bool hits_ground = false;
    T t_begin = T(0);
    T t_end = T(0);
};

template <class T>
AtmosphereSegment<T> atmosphere_segment(const PlanetRay<T>& ray, T top_altitude_m);

// Unit direction for an elevation above the horizon and a Blender Sky Texture azimuth
// ("rotation": 0° → +Y, 90° → +X), in the observer's frame (Z up).
template <class T>
Vec3<T> direction_from_elevation_azimuth_deg(double elevation_deg, double azimuth_deg);

// Unit direction for a zenith angle and an azimuth measured from +X toward +Y (the
// `airmass eval` convention: the view lies in the XZ plane at azimuth 0).
template <class T>
Vec3<T> direction_from_zenith_azimuth_deg(double zenith_deg, double azimuth_deg);

}  // namespace airmass
