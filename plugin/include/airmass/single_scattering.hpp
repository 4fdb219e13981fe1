// Single scattering of sunlight along view rays, and aerial perspective.
//
// Radiance reaching the observer along a view ray, per wavelength (seed 000 §2.2,
// seed 001, seed 004 §2.1, Golubev Eq. 7 with the sun as the only source):
//
//   L(λ) = E_sun(λ) Σ_i σs_i(λ) P_i(mu) ∫ rho_i(x(t)) T(x0 → x(t)) T_sun(x(t)) dt     (in-scatter S)
//        + [ground hit]  a/π · E_sun cos θ_sun · T_sun(ground) · T(x0 → ground)
//        + [sun disc]    E_sun / Ω_sun · T(x0 → space)
//
// with mu = dot(view, sun), T_sun(x) = 0 when the sun ray from x hits the planet
// (Earth's shadow) and otherwise exp(−Σ_j σt_j m_j(x → top)), the masses m_j in O(1)
// from the Chapman family (exponential) or the closed form (piecewise linear).
// radiance_rayleigh / radiance_mie are the in-scatter sums over the Rayleigh-like /
// the other constituents (phase.hpp is_rayleigh_like); radiance = both + ground + disc.
//
// Integration: each scattering constituent i gets its own `view_samples` points,
// placed as Gauss–Legendre nodes (panels of ≤ 16 beyond 16; Atmosphere::gauss_rules; the
// midpoint rule until 2026-12-03) in a sampling variable in which rho_i(t)·T(t) is close
// to constant: an exponential in |t − t_d| around the densest point t_d of each lit part
// of the segment (the periapsis, or the end nearer it), with decay length ℓ = the
// distance over which the ray climbs one scale height from t_d, or — where that model of
// the optical depths fails — from probes of the light. The lit parts (Earth's shadow cut
// out exactly), each cut at a periapsis inside it, are the pieces the points are shared
// among, by measured estimates of each piece's light, each piece its own rule (docs/sky.md
// "Rays through a periapsis").
// T(x0 → x(t)) at each sample is exact (Eq. 37), not accumulated, so the only
// quadrature error is that of the smooth remainder. Accuracy and cost are measured
// in docs/evaluation.md.
//
// All functions are thread-safe and allocation-free: outputs go to caller spans.
#pragma once

#include <span>

#include "airmass/atmosphere.hpp"
#include "airmass/geometry.hpp"

namespace airmass {

// Outputs per wavelength (each span has atmosphere.wavelength_count() elements, or
// n_rays × wavelength_count() for the batch form, ray-major).
struct RadianceOut {
    std::span<double> transmittance;      // along the view ray to space or to the ground
    std::span<double> radiance_rayleigh;  // W m⁻² sr⁻¹ nm⁻¹ (for E_sun in W m⁻² nm⁻¹)
    std::span<double> radiance_mie;
    std::span<double> radiance;           // rayleigh + mie + ground + sun disc
};

// One view ray from an observer at `altitude_m` above the surface (may be above the
// top of the atmosphere). Directions are unit vectors in the observer's frame (Z up,
// which is also the planet frame with the observer on the +Z axis).
struct ViewRay {
    double altitude_m = 0.0;
    Vec3<double> view_direction{0.0, 0.0, 1.0};
    Vec3<double> sun_direction{0.0, 0.0, 1.0};  // toward the sun
};

void single_scattering(const Atmosphere& atmosphere, const ViewRay& ray, RadianceOut out);

// Many view directions for one observer and sun (a sky image's pixels). out spans are
// n × wavelength_count(), element [k * wavelength_count() + w].
void single_scattering_batch(const Atmosphere& atmosphere, double altitude_m, Vec3<double> sun_direction,
                             std::span<const Vec3<double>> view_directions, RadianceOut out);

// The view transmittance T(λ) of many view directions (to space or to the ground), the
// same numbers single_scattering_batch writes to out.transmittance, without the in-scatter
// (a fraction of its cost). `out`: n × wavelength_count(), element [k * wavelength_count() + w].
void view_transmittance_batch(const Atmosphere& atmosphere, double altitude_m,
                              std::span<const Vec3<double>> view_directions, std::span<double> out);

// Aerial perspective (seed 000 §2.6.2): transmittance T and in-scatter S from point
// `from_m` to point `to_m` (planet-centred metres), or, with to_infinity, from `from_m`
// along the ray through `to_m` out of the atmosphere (or to the ground). An object of
// radiance L0 at the far end is seen as L0·T + S. S includes neither ground nor disc.
// From a point inside the planet (beyond kShadowTolerance_m) T = 0 and S = 0: it is all ground.
void aerial_perspective(const Atmosphere& atmosphere, Vec3<double> from_m, Vec3<double> to_m,
                        Vec3<double> sun_direction, bool to_infinity, std::span<double> transmittance_out,
                        std::span<double> inscatter_out);

// The same integral by brute force, for tests and reports: nested adaptive quadrature
// (Boost Gauss–Kronrod along the view ray, split at the periapsis, the shadow boundary
// and the knots; the sun optical depth by adaptive quadrature of the densities, not by
// Chapman). Slow (~10–100 ms per ray). Same outputs as single_scattering.
void single_scattering_reference(const Scene& scene, const Atmosphere& atmosphere, const ViewRay& ray,
                                 RadianceOut out, double rel_tol = 1e-7);

}  // namespace airmass
