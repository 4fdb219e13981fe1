// Optical depth and transmittance along straight rays (Golubev 2019 Eq. 4–5, 37).
//
// The *mass* of a profile along a segment is ∫ rho ds (metres at density 1); the
// optical depth at a wavelength is Σ_i σt_i(λ) · mass_i, and T = exp(−τ).
//
// Exponential profiles use the Chapman family through Eq. 37 — a segment is the
// difference of two semi-infinite rays — written so that only upper-hemisphere
// (cos chi ≥ 0) Chapman values are ever subtracted: a segment below the periapsis is
// evaluated reversed (τ(a→b) = τ(b→a), Golubev's trick), one that contains the
// periapsis is split there. When the difference would cancel (the segment holds less
// than a quarter of the first term's mass), the segment is integrated instead by
// 16-point Gauss–Legendre, which is exact to rounding there because the density varies
// by less than ~30 % along it.
// Piecewise-linear profiles are integrated in closed form, piece by piece, between the
// ray's crossings of the knot spheres (∫ sqrt(p² + s²) ds).
// The ground is opaque: a segment that passes below the surface has infinite optical
// depth (T = 0).
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <span>

#include "airmass/atmosphere.hpp"
#include "airmass/geometry.hpp"

namespace airmass {

// ---- one exponential layer (float and double) -----------------------------------

// Mass of rho(h) = exp(−(h − h_ref)/H) along the semi-infinite ray from altitude h in
// direction chi (no top, no ground): H · Ch_h((R + h_ref)/H, (h − h_ref)/H, chi).
template <class T>
T exponential_ray_mass(ChapmanMethod method, T planet_radius_m, T scale_height_m, T reference_altitude_m,
                       T altitude_m, ZenithAngle<T> chi);

// Mass along the segment t ∈ [t0, t1] of `ray` (t1 may be +inf), no top, no ground.
template <class T>
T exponential_segment_mass(ChapmanMethod method, const PlanetRay<T>& ray, T scale_height_m,
                           T reference_altitude_m, T t0_m, T t1_m);

// ---- any compiled profile (double) -------------------------------------------------

// Mass of `profile` along t ∈ [t0, t1] of `ray`, with the density set to zero above
// `top_altitude_m` and no ground test (the caller clips). t1 may be +inf.
double profile_segment_mass(const CompiledProfile& profile, ChapmanMethod method, const PlanetRay<double>& ray,
                            double top_altitude_m, double t0_m, double t1_m);

// ∫_{s0}^{s1} sqrt(p² + s²) ds for 0 ≤ s0 ≤ s1, without cancellation (closed form).
double integral_of_radius(double p_m, double s0_m, double s1_m);

// ---- a whole atmosphere (double) ----------------------------------------------------

// Per-constituent masses along t ∈ [t0, t1] (t1 may be +inf: to the top of the
// atmosphere). `mass.size()` = atmosphere.constituents.size(). Returns false (and
// fills +inf) when the segment passes below the ground.
bool constituent_masses(const Atmosphere& atmosphere, const PlanetRay<double>& ray, double t0_m, double t1_m,
                        std::span<double> mass);

// τ(λ) along t ∈ [t0, t1]; tau.size() = wavelength_count(). +inf through the ground.
void optical_depth(const Atmosphere& atmosphere, const PlanetRay<double>& ray, double t0_m, double t1_m,
                   std::span<double> tau);

// T(λ) = exp(−τ(λ)).
void transmittance(const Atmosphere& atmosphere, const PlanetRay<double>& ray, double t0_m, double t1_m,
                   std::span<double> transmittance_out);

// Between two planet-centred points (metres).
void transmittance_between(const Atmosphere& atmosphere, Vec3<double> from_m, Vec3<double> to_m,
                           std::span<double> transmittance_out);

// ---- toward the sun: the one sun-transmittance computation -----------------------------
//
// Every caller that needs the sunlight reaching a point (single scattering, the
// multiple-scattering tables, the native renders, the C ABI's sun lamp, the add-on) asks
// these two functions; nothing else computes a sun ray.

// Earth's shadow: a sun ray that dips more than this below the ground is blocked. A sun ray
// within rounding of tangent to the ground counts as lit (the grazing limit), so exactly
// tangent geometries are decided the same way every time.
inline constexpr double kShadowTolerance_m = 1e-6;

// Whether `sun_ray` (from a point toward the sun) passes through the planet, or starts inside it.
inline bool in_planet_shadow(const PlanetRay<double>& sun_ray) {
    return sun_ray.altitude_m < -kShadowTolerance_m ||
           (sun_ray.zenith.cos_chi < 0.0 && sun_ray.periapsis_altitude_m() < -kShadowTolerance_m);
}

// The part of a view line in Earth's shadow, [t0, t1] in metres along `view` (empty when
// t1 ≤ t0; ±inf when unbounded): behind the planet (dot(P, sun) < 0) and within R of the
// shadow's axis, |P × sun|² = |P|² − dot(P, sun)² < R², with the same tolerance as
// in_planet_shadow. origin_dot_sun_m = dot(origin, sun) (origin from the planet's centre),
// view_dot_sun = dot(view, sun). With P = O + t v: A t² + 2 B t + C < 0, A = 1 − v_s²,
// B = r0 mu − o_s v_s, C = r0² − o_s² − R² = h0 (2R + h0) − o_s².
struct ShadowSpan {
    double t0 = 0.0, t1 = 0.0;
};
inline ShadowSpan earth_shadow_span(const PlanetRay<double>& view, double origin_dot_sun_m, double view_dot_sun) {
    constexpr double inf = std::numeric_limits<double>::infinity();
    const double R = view.planet_radius_m, h0 = view.altitude_m, o_s = origin_dot_sun_m, v_s = view_dot_sun;
    const double A = (1.0 - v_s) * (1.0 + v_s);
    const double B = view.periapsis_offset_m() - o_s * v_s;
    const double C = h0 * (2.0 * R + h0) - o_s * o_s + 2.0 * R * kShadowTolerance_m;  // radius R − tol
    double c0, c1;
    if (A < 1e-15) {  // looking along the shadow axis: the distance to it is constant
        if (!(C < 0.0)) return {};
        c0 = -inf;
        c1 = inf;
    } else {
        const double disc = B * B - A * C;
        if (!(disc > 0.0)) return {};
        const double q = -(B + std::copysign(std::sqrt(disc), B));
        const double x0 = q / A, x1 = q != 0.0 ? C / q : -x0;
        c0 = std::min(x0, x1);
        c1 = std::max(x0, x1);
    }
    // half-space behind the planet: o_s + t v_s < 0
    if (v_s > 0.0) c1 = std::min(c1, -o_s / v_s);
    else if (v_s < 0.0) c0 = std::max(c0, -o_s / v_s);
    else if (!(o_s < 0.0)) return {};
    return {c0, c1};
}

// Masses of every constituent along the sun ray from a point at `altitude_m` whose sun
// zenith angle is `sun_zenith`, to the top of the atmosphere (exponential profiles: H·Ch
// at the point minus, where the top matters, the same at the ray's exit — by quadrature
// where those two cancel, close below the top; piecewise linear: the closed form). Returns
// false — the point is in the planet's shadow, or below the ground — and leaves `mass` as it
// was when the ray is blocked. mass.size() = atmosphere.constituents.size().
bool sun_masses(const Atmosphere& atmosphere, double altitude_m, ZenithAngle<double> sun_zenith,
                std::span<double> mass);

// sun_masses for n points at once (sun_masses is this for one point): the exponential
// constituents' Chapman terms in batches of the points (chapman_rescaled_batch, four points per
// AVX2 instruction). lit[k] is sun_masses' result for point k; mass[k · nc + i] its masses
// (nc = constituents.size()), left as they were where lit[k] is 0. Throws
// std::invalid_argument when the spans' sizes disagree.
void sun_masses_batch(const Atmosphere& atmosphere, std::span<const double> altitude_m,
                      std::span<const ZenithAngle<double>> sun_zenith, std::span<double> mass,
                      std::span<unsigned char> lit);

// T_sun(λ) = exp(−Σ_i σt_i(λ) m_i) for those masses; 0 in the shadow (returns false there).
bool sun_transmittance(const Atmosphere& atmosphere, double altitude_m, ZenithAngle<double> sun_zenith,
                       std::span<double> transmittance_out);

// ---- brute-force reference (tests) ----------------------------------------------------

// The same masses by adaptive quadrature (Gauss–Kronrod 61 bisected to a relative tolerance
// `rel_tol`, or an absolute one of 1e-3 rel_tol of the profile's vertical column) of
// DensityProfile::at along the segment, split at the periapsis, the top and every profile
// knot; independent of the Chapman and closed-form paths.
double profile_segment_mass_reference(const DensityProfile& profile, const PlanetRay<double>& ray,
                                      double top_altitude_m, double t0_m, double t1_m, double rel_tol = 1e-12);

}  // namespace airmass
