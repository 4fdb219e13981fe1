// An independent Monte Carlo reference for the whole light transport of an Atmosphere:
// a backward path tracer in the spherical shell (all constituents, Lambertian ground, the
// sun a directional source reached only by next-event estimation). Slow, unbiased, used
// only to validate the multiple-scattering tables (tests, `airmass report ms`).
//
// Estimator, per wavelength λ (single-wavelength paths), from the observer along v:
//   * the segment [t_b, t_e] inside the shell has optical depth τ_e (Chapman /
//     closed-form masses, optical_depth.hpp) and T_e = e^{−τ_e};
//   * free paths are sampled analytically by inverting the CDF of σt T (Golubev 2019,
//     seed 003, Eq. 10–13): draw τ* = −ln(1 − ξ(1 − T_e)) ∈ [0, τ_e] and solve τ(t_b, t) = τ*
//     for t by safeguarded Newton on the closed-form optical depth (dτ/dt = σt(t));
//       – a ray that leaves into space is *forced* to collide: weight × (1 − T_e);
//       – a ray that ends on the ground collides with probability 1 − T_e, else reaches
//         the ground (both analog);
//   * at a collision y: weight × σs(y)/σt(y) (absorption as a weight); next-event estimate
//     weight · Σ_i (σs_i ρ_i/σs) P_i(v·s) T_sun(y) E_sun; then a constituent is picked with
//     probability σs_i ρ_i/σs and the new direction sampled from its phase function
//     (Rayleigh and Henyey–Greenstein exactly; Cornette–Shanks by Henyey–Greenstein with
//     the bounded weight CS/HG; modified Rayleigh uniformly with weight 4π P);
//   * at the ground g: weight · a/π max(n·s, 0) T_sun(g) E_sun, then weight × a and a
//     cosine-distributed direction;
//   * Russian roulette below a weight threshold (unbiased), a hard cap of 10000 events.
// Each event counts one order; orders outside [min_order, max_order] add nothing (order 1
// alone is single scattering with the directly lit ground, exactly what
// single_scattering computes; min_order = 2 is the multiple scattering only).
// The sun disc is not part of the estimate.
//
// Paths are split into fixed blocks, each with its own counter-based random stream, so the
// result does not depend on the number of threads.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "airmass/atmosphere.hpp"
#include "airmass/geometry.hpp"
#include "airmass/progress.hpp"
#include "airmass/single_scattering.hpp"

namespace airmass {

struct McSettings {
    std::uint64_t paths = 100000;  // per wavelength
    std::uint64_t seed = 1;
    int min_order = 1;
    int max_order = 0;              // 0: unlimited
    double roulette_weight = 0.05;  // Russian roulette below this path weight
    int threads = 0;                // 0: all (TBB)
    const CancelFlag* cancel = nullptr;
    std::function<void(double fraction)> progress;  // called from the calling thread
};

struct McResult {
    std::vector<double> value;           // per wavelength: the estimate
    std::vector<double> standard_error;  // per wavelength: its standard error
    std::uint64_t paths = 0;             // per wavelength
    double seconds = 0.0;
};

// Throws std::invalid_argument naming the field, value and allowed range.
void validate(const McSettings& settings);

// Radiance seen by the observer of `ray` (W m⁻² sr⁻¹ nm⁻¹ for E_sun in W m⁻² nm⁻¹).
McResult monte_carlo_radiance(const Atmosphere& atmosphere, const ViewRay& ray, const McSettings& settings);

// Energy balance of the whole planet: power leaving through the top of the atmosphere over
// the intercepted solar power π r_top² E_sun. Scattered and reflected light,
//     (2/E_sun) ∫_{−1}^{1} F_out(μs) dμs,   F_out(μs) = ∫_{μ<0} L(top, ω) |μ| dω,
// with μs uniform and ω cosine-distributed (4π L / E_sun per path), plus the sunlight that
// crosses the shell without any event (a uniform point of the disc of radius r_top: its line's
// transmittance if it misses the planet). Exactly 1 for a purely scattering atmosphere over an
// albedo-1 ground.
McResult monte_carlo_energy_balance(const Atmosphere& atmosphere, const McSettings& settings);

// The free-path inversion: the t ∈ [t_begin, t_end] at which the optical depth at
// wavelength index `w` from t_begin along `ray` reaches `tau` (clamped to the segment).
double free_path_distance(const Atmosphere& atmosphere, const PlanetRay<double>& ray, double t_begin, double t_end,
                          std::size_t w, double tau);

}  // namespace airmass
