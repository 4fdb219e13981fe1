// Ray–sphere geometry relative to the periapsis (geometry.hpp explains the forms).
#include "airmass/geometry.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <numbers>

#include <glm/geometric.hpp>

namespace airmass {

template <class T>
PlanetRay<T> PlanetRay<T>::from_vectors(T planet_radius_m, Vec3<T> origin_m, Vec3<T> direction) {
    // Both vectors divided by their largest component first: lengths, dot and cross products of
    // components from 1e-300 to 1e300 (float: 1e-37 to 1e37) then neither over- nor underflow.
    const auto largest = [](const Vec3<T>& v) { return std::max({std::abs(v.x), std::abs(v.y), std::abs(v.z)}); };
    const T dm = largest(direction);
    if (!(dm > T(0)) || !(dm <= std::numeric_limits<T>::max()))
        throw std::invalid_argument("PlanetRay::from_vectors: the direction must be a finite, non-zero vector");
    const Vec3<T> dn = direction / dm;
    const Vec3<T> d = dn / glm::length(dn);
    const T om = largest(origin_m);
    if (!(om > T(0))) return {planet_radius_m, -planet_radius_m, {T(1), T(0)}};  // at the centre: any zenith
    const Vec3<T> o = origin_m / om;  // |o| in [1, √3]
    const T lo = glm::length(o);
    const T r0 = om * lo;
    // sin from the cross product keeps full relative accuracy near the horizon, where
    // sqrt(1 − cos²) would not; cos from the dot product likewise near the zenith.
    const T c = std::clamp(glm::dot(o, d) / lo, T(-1), T(1));
    const T s = std::min(glm::length(glm::cross(o, d)) / lo, T(1));
    return {planet_radius_m, r0 - planet_radius_m, {c, s}};
}

template <class T>
T PlanetRay<T>::periapsis_altitude_m() const {
    // p − R = h0 − r0 (1 − sin chi) = h0 − r0 cos²chi / (1 + sin chi): no cancellation
    // near the horizon, where p ≈ r0.
    const T c = zenith.cos_chi;
    return altitude_m - radius_m() * c * c / (T(1) + zenith.sin_chi);
}

template <class T>
T PlanetRay<T>::radius_at(T t_m) const {
    const T p = periapsis_radius_m();
    const T s = periapsis_offset_m() + t_m;
    const T r2 = p * p + s * s;
    // hypot only where the squares leave T's normal range (beyond 1.3e154 m or below 1e-154 m;
    // float: 1.8e19, 1e-19): it costs several times the square root.
    if (r2 <= std::numeric_limits<T>::max() && !(r2 < std::numeric_limits<T>::min())) [[likely]]
        return std::sqrt(r2);
    // in double also for float: hypotf's only x86-64 version is GLIBC_2.35, above official
    // Blender's 2.28 baseline (hypot's old version is kept by plugin/capi/glibc_compat.cpp)
    return static_cast<T>(std::hypot(double(p), double(s)));
}

template <class T>
T PlanetRay<T>::altitude_at(T t_m) const {
    // r(t)² − r0² = t (2 s0 + t), so h(t) − h0 = t (2 s0 + t) / (r(t) + r0): the
    // altitude change is computed directly, never as a difference of two radii.
    const T r0 = radius_m();
    // The quotient first: |2 s0 + t| ≤ r(t) + r0, so it is ≤ 1 and t (2 s0 + t) cannot overflow.
    return altitude_m + t_m * ((T(2) * periapsis_offset_m() + t_m) / (radius_at(t_m) + r0));
}

template <class T>
ZenithAngle<T> PlanetRay<T>::zenith_at(T t_m) const {
    const T r = radius_at(t_m);
    if (!(r > T(0))) return {T(1), T(0)};
    const T c = std::clamp((periapsis_offset_m() + t_m) / r, T(-1), T(1));
    const T s = std::min(periapsis_radius_m() / r, T(1));
    return {c, s};
}

namespace {

// Discriminant D = (R + a)² − p² = (a − h0)(2R + a + h0) + s0² and the constant term
// c = r0² − (R + a)² of t² + 2 s0 t + c = 0.
template <class T>
void sphere_quadratic(const PlanetRay<T>& ray, T a, T& D, T& c) {
    const T R = ray.planet_radius_m, h0 = ray.altitude_m, s0 = ray.periapsis_offset_m();
    D = (a - h0) * (T(2) * R + a + h0) + s0 * s0;
    c = (h0 - a) * (T(2) * R + h0 + a);
}

}  // namespace

template <class T>
SphereCrossing<T> intersect_sphere(const PlanetRay<T>& ray, T a) {
    T D, c;
    sphere_quadratic(ray, a, D, c);
    if (!(D >= T(0))) return {};
    const T s0 = ray.periapsis_offset_m();
    const T q = -(s0 + std::copysign(std::sqrt(D), s0));  // no cancellation: same signs
    T t1, t2;
    if (q != T(0)) {
        t1 = q;
        t2 = c / q;
    } else {  // s0 = 0 and D = 0: the origin is the tangent point
        t1 = t2 = T(0);
    }
    return {true, std::min(t1, t2), std::max(t1, t2)};
}

template <class T>
bool hits_ground(const PlanetRay<T>& ray) {
    if (!(ray.zenith.cos_chi < T(0))) return false;
    T D, c;
    sphere_quadratic(ray, T(0), D, c);
    return D > T(0);
}

template <class T>
T ground_distance_m(const PlanetRay<T>& ray) {
    const auto x = intersect_sphere(ray, T(0));
    return std::max(x.t_near, T(0));
}

template <class T>
AtmosphereSegment<T> atmosphere_segment(const PlanetRay<T>& ray, T top_altitude_m) {
    AtmosphereSegment<T> seg;
    const bool ground = hits_ground(ray);
    if (ray.altitude_m <= top_altitude_m) {
        seg.valid = true;
        seg.t_begin = T(0);
        if (ground) {
            seg.hits_ground = true;
            seg.t_end = ground_distance_m(ray);
        } else {
            seg.t_end = std::max(intersect_sphere(ray, top_altitude_m).t_far, T(0));
        }
        return seg;
    }
    const auto top = intersect_sphere(ray, top_altitude_m);
    if (!top.hit || !(top.t_far > T(0))) return seg;  // misses the atmosphere or points away
    seg.valid = true;
    seg.t_begin = std::max(top.t_near, T(0));
    if (ground) {
        seg.hits_ground = true;
        seg.t_end = std::max(ground_distance_m(ray), seg.t_begin);
    } else {
        seg.t_end = top.t_far;
    }
    return seg;
}

template <class T>
Vec3<T> direction_from_elevation_azimuth_deg(double elevation_deg, double azimuth_deg) {
    const auto z = ZenithAngle<double>::from_degrees(90.0 - elevation_deg);
    const double a = azimuth_deg * std::numbers::pi / 180.0;
    return Vec3<T>(T(z.sin_chi * std::sin(a)), T(z.sin_chi * std::cos(a)), T(z.cos_chi));
}

template <class T>
Vec3<T> direction_from_zenith_azimuth_deg(double zenith_deg, double azimuth_deg) {
    const auto z = ZenithAngle<double>::from_degrees(zenith_deg);
    const double a = azimuth_deg * std::numbers::pi / 180.0;
    return Vec3<T>(T(z.sin_chi * std::cos(a)), T(z.sin_chi * std::sin(a)), T(z.cos_chi));
}

#define AIRMASS_INSTANTIATE(T)                                                                     \
    template struct PlanetRay<T>;                                                                  \
    template SphereCrossing<T> intersect_sphere<T>(const PlanetRay<T>&, T);                        \
    template bool hits_ground<T>(const PlanetRay<T>&);                                             \
    template T ground_distance_m<T>(const PlanetRay<T>&);                                          \
    template AtmosphereSegment<T> atmosphere_segment<T>(const PlanetRay<T>&, T);                   \
    template Vec3<T> direction_from_elevation_azimuth_deg<T>(double, double);                      \
    template Vec3<T> direction_from_zenith_azimuth_deg<T>(double, double);
AIRMASS_INSTANTIATE(float)
AIRMASS_INSTANTIATE(double)
#undef AIRMASS_INSTANTIATE

}  // namespace airmass
