// Single scattering along view rays and aerial perspective (single_scattering.hpp has
// the equation and the sampling scheme), plus the brute-force nested-quadrature
// reference.
#include "airmass/single_scattering.hpp"

#include <algorithm>
#include <array>
#include <boost/math/quadrature/gauss_kronrod.hpp>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <vector>

#include <glm/geometric.hpp>

#include "airmass/optical_depth.hpp"
#include "airmass/phase.hpp"
#include "airmass/simd.hpp"
#include "airmass/spectrum.hpp"
#include "math/quadrature.hpp"

namespace airmass {

// The implementation, once for baseline x86-64 and once for AVX2/FMA (airmass/simd.hpp).
#define AIRMASS_SIMD_KERNELS "transport/single_scattering_kernels.inc"
#include "math/simd_targets.inc"

void single_scattering(const Atmosphere& atm, const ViewRay& ray, RadianceOut out) {
    AIRMASS_SIMD_RETURN(single_scattering_impl(atm, ray, out));
}

void single_scattering_batch(const Atmosphere& atm, double altitude_m, Vec3<double> sun,
                             std::span<const Vec3<double>> dirs, RadianceOut out) {
    AIRMASS_SIMD_RETURN(single_scattering_batch_impl(atm, altitude_m, sun, dirs, out));
}

void view_transmittance_batch(const Atmosphere& atm, double altitude_m, std::span<const Vec3<double>> dirs,
                              std::span<double> T_out) {
    AIRMASS_SIMD_RETURN(view_transmittance_batch_impl(atm, altitude_m, dirs, T_out));
}

void aerial_perspective(const Atmosphere& atm, Vec3<double> from, Vec3<double> to, Vec3<double> sun,
                        bool to_infinity, std::span<double> T_out, std::span<double> S_out) {
    AIRMASS_SIMD_RETURN(aerial_perspective_impl(atm, from, to, sun, to_infinity, T_out, S_out));
}

// The reference below is not a kernel: it uses the baseline helpers.
namespace {
using namespace baseline;
}  // namespace

// ---- brute-force reference ---------------------------------------------------------------

void single_scattering_reference(const Scene& scene, const Atmosphere& atm, const ViewRay& vr, RadianceOut out,
                                 double rel_tol) {
    check_out(atm, out, 1);
    using boost::math::quadrature::gauss_kronrod;
    const std::size_t nw = atm.wavelength_count(), nc = atm.constituents.size();
    const double R = atm.planet_radius_m, top = atm.top_altitude_m;
    const Vec3<double> v = glm::normalize(vr.view_direction), sun = vr.sun_direction;
    const Vec3<double> O(0.0, 0.0, R + vr.altitude_m);
    const auto ray = PlanetRay<double>::from_vectors(R, O, v);
    const auto seg = atmosphere_segment(ray, top);
    const double inner_tol = std::max(rel_tol * 1e-2, 1e-12);

    const auto mass = [&](std::size_t i, const PlanetRay<double>& r, double t0, double t1) {
        return profile_segment_mass_reference(scene.constituents[atm.constituents[i].scene_index].profile, r, top, t0,
                                              t1, inner_tol);
    };
    // sun optical depth at a point, +inf in the shadow (independent 3-D test)
    const auto sun_tau = [&](const Vec3<double>& P, std::size_t w) {
        const double along = glm::dot(P, sun);
        const double off_axis = glm::length(glm::cross(P, sun));
        if (along < 0.0 && off_axis < R - kShadowTolerance_m) return kInf;
        const auto sr = PlanetRay<double>::from_vectors(R, P, sun);
        double tau = 0.0;
        for (std::size_t i = 0; i < nc; ++i) tau += atm.constituents[i].extinction_per_m[w] * mass(i, sr, 0.0, kInf);
        return tau;
    };
    const auto view_tau = [&](double t, std::size_t w) {
        double tau = 0.0;
        for (std::size_t i = 0; i < nc; ++i)
            tau += atm.constituents[i].extinction_per_m[w] * mass(i, ray, seg.valid ? seg.t_begin : 0.0, t);
        return tau;
    };

    for (std::size_t w = 0; w < nw; ++w) {
        out.radiance_rayleigh[w] = out.radiance_mie[w] = 0.0;
        out.transmittance[w] = seg.valid ? std::exp(-view_tau(seg.t_end, w)) : 1.0;
    }
    if (seg.valid && seg.t_end > seg.t_begin) {
        // split points: periapsis, shadow boundary, every knot sphere
        std::vector<double> cuts{seg.t_begin, seg.t_end};
        const auto add = [&](double t) {
            if (t > seg.t_begin && t < seg.t_end) cuts.push_back(t);
        };
        add(-ray.periapsis_offset_m());
        const Interval sh = shadow_interval(ray, {glm::dot(O, sun), glm::dot(v, sun)});
        add(sh.a);
        add(sh.b);
        for (const auto& c : atm.constituents)
            for (double a : c.profile.altitude_m) {
                const auto x = intersect_sphere(ray, a);
                if (x.hit) {
                    add(x.t_near);
                    add(x.t_far);
                }
            }
        std::sort(cuts.begin(), cuts.end());
        for (std::size_t c = 0; c < nc; ++c) {
            const auto& con = atm.constituents[c];
            if (!con.scatters) continue;
            const DensityProfile& prof = scene.constituents[con.scene_index].profile;
            const double P = phase(con.phase, glm::dot(v, sun));
            for (std::size_t w = 0; w < nw; ++w) {
                const auto f = [&](double t) {
                    const Vec3<double> X = O + t * v;
                    const double h = glm::length(X) - R;
                    const double rho = h > top ? 0.0 : prof.at(h);
                    if (!(rho > 0.0)) return 0.0;
                    const double ts = sun_tau(X, w);
                    if (std::isinf(ts)) return 0.0;
                    return rho * std::exp(-view_tau(t, w) - ts);
                };
                double integral = 0.0;
                for (std::size_t k = 0; k + 1 < cuts.size(); ++k)
                    if (cuts[k + 1] > cuts[k])
                        integral += gauss_kronrod<double, 31>::integrate(f, cuts[k], cuts[k + 1], 15, rel_tol);
                const double L = atm.sun_irradiance[w] * con.scattering_per_m[w] * P * integral;
                (con.rayleigh_like ? out.radiance_rayleigh : out.radiance_mie)[w] += L;
            }
        }
    }
    for (std::size_t w = 0; w < nw; ++w) {
        out.radiance[w] = out.radiance_rayleigh[w] + out.radiance_mie[w];
        if (seg.valid && seg.hits_ground) {
            const Vec3<double> G = O + seg.t_end * v;
            const double mu_g = glm::dot(glm::normalize(G), sun);
            if (atm.settings.ground && mu_g > 0.0)
                out.radiance[w] += atm.ground_albedo / std::numbers::pi * atm.sun_irradiance[w] * mu_g *
                                   std::exp(-sun_tau(G * (1.0 + 1e-15), w)) * out.transmittance[w];
        } else if (atm.settings.sun_disc && atm.sun_angular_radius_rad > 0.0 &&
                   glm::dot(v, sun) >= std::cos(atm.sun_angular_radius_rad)) {
            out.radiance[w] += atm.sun_irradiance[w] /
                               (2.0 * std::numbers::pi * (1.0 - std::cos(atm.sun_angular_radius_rad))) *
                               out.transmittance[w];
        }
    }
}

}  // namespace airmass
