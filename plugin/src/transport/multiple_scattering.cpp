// Multiple scattering: orders of scattering on a 4-D grid and Hillaire's isotropic table
// (multiple_scattering.hpp states the equations; docs/multiple_scattering.md the numerics).
//
// Stages, each parallel over threads (airmass/parallel.hpp):
//   1. Ray quadratures (order- and sun-independent): for every grid ray (altitude a, view
//      zenith b) the intervals along it, the per-interval weights
//          W_k,i(λ) = σs_i(λ) ∫_interval ρ_i T(x, y) dt = σs_i Δm_i T(x, t_k) (1 − e^{−Δτ_k})/Δτ_k
//      (exact when ρ_i/σt is constant inside the interval: the optical depth is handled
//      analytically, the quadrature only has to resolve the slowly varying source), and
//      the node coordinates of every sample for every sun node (c, d).
//   2. Order 1: J¹ evaluated exactly at the samples (phase × sun transmittance from a
//      Chapman-mass table), plus the directly lit ground.
//   3. Gather: per (altitude, sun) node, the radiance over the sphere of directions is
//      convolved with each phase function: a circular convolution in azimuth, done per
//      Fourier mode with (view × view) phase matrices integrated over the grid cells.
//   4. Transport of order k: J^k = Σ_i σs_i ρ_i G_i^k interpolated at the samples
//      ((altitude, view) corners once per sample, then (sun, azimuth) per node).
#include <algorithm>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <numbers>
#include <span>
#include <stdexcept>
#include <type_traits>
#include <vector>


#include <glm/geometric.hpp>

#include "airmass/multiple_scattering.hpp"
#include "airmass/optical_depth.hpp"
#include "airmass/parallel.hpp"
#include "airmass/phase.hpp"
#include "airmass/simd.hpp"
#include "airmass/spectral_table.hpp"
#include "airmass/spectrum.hpp"
#include "math/quadrature.hpp"
#include "airmass/large_buffer.hpp"

namespace airmass {

// The implementation, once for baseline x86-64 and once for AVX2/FMA (the orders-of-
// scattering transport loops gain ~1.4x from it, bench/portable_vs_native.sh).
#define AIRMASS_SIMD_KERNELS "transport/multiple_scattering_kernels.inc"
#include "math/simd_targets.inc"

SharedFloats::SharedFloats(std::vector<float> values) {
    auto owned = std::make_shared<const std::vector<float>>(std::move(values));
    data_ = owned->data();
    size_ = owned->size();
    owner_ = std::move(owned);
}

bool operator==(const SharedFloats& a, const SharedFloats& b) {
    return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin());
}

MultipleScattering precompute_multiple_scattering(const Atmosphere& atm, const MsSettings& requested) {
    AIRMASS_SIMD_RETURN(precompute_multiple_scattering_impl(atm, requested));
}

std::vector<double> ms_energy_balance(const MultipleScattering& ms, const Atmosphere* atm_for_direct) {
    AIRMASS_SIMD_RETURN(ms_energy_balance_impl(ms, atm_for_direct));
}

void ms_phase_radiance(const MultipleScattering& ms, std::size_t constituent, const MsPoint& pt,
                       std::span<double> out) {
    AIRMASS_SIMD_RETURN(ms_phase_radiance_impl(ms, constituent, pt, out));
}

void ms_ground_irradiance(const MultipleScattering& ms, double mu_s, std::span<double> out) {
    AIRMASS_SIMD_RETURN(ms_ground_irradiance_impl(ms, mu_s, out));
}

void multiple_scattering_radiance(const Atmosphere& atm, const MultipleScattering& ms, const ViewRay& vr,
                                  MsRadianceOut out, int samples) {
    AIRMASS_SIMD_RETURN(multiple_scattering_radiance_impl(atm, ms, vr, out, samples));
}

void multiple_scattering_radiance_row(const Atmosphere& atm, const MultipleScattering& ms, double altitude_m,
                                      std::span<const Vec3<double>> view_directions, Vec3<double> sun_direction,
                                      MsRadianceOut out, int samples) {
    AIRMASS_SIMD_RETURN(
        multiple_scattering_radiance_row_impl(atm, ms, altitude_m, view_directions, sun_direction, out, samples));
}

}  // namespace airmass
