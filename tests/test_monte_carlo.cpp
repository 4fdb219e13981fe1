// The Monte Carlo reference (monte_carlo.hpp) checked on its own:
//   * order 1 alone equals the single-scattering module (a deterministic, independent
//     quadrature) within 3 standard errors + 0.3 %;
//   * the free-path inversion hits the requested optical depth and its samples follow the
//     truncated exponential law of τ (Kolmogorov–Smirnov);
//   * energy conservation: a purely scattering atmosphere over an albedo-1 ground sends out
//     all the power it intercepts, within 3 standard errors;
//   * independent seeds agree within their errors; the thread count does not change results.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "test_scenes.hpp"
#include "airmass/atmosphere.hpp"
#include "airmass/monte_carlo.hpp"
#include "airmass/optical_depth.hpp"
#include "airmass/scene_io.hpp"
#include "airmass/single_scattering.hpp"

namespace airmass {
namespace {

const std::vector<double> kWavelengths = {440.0, 680.0};

Atmosphere atmosphere(const std::string& preset) {
    Atmosphere atm = compile_atmosphere(load_preset(preset), kWavelengths);
    set_constant_irradiance(atm, 1.0);
    return atm;
}

ViewRay view(double altitude_m, double sun_elevation_deg, double elevation_deg, double azimuth_deg) {
    return {altitude_m, direction_from_elevation_azimuth_deg<double>(elevation_deg, azimuth_deg),
            direction_from_elevation_azimuth_deg<double>(sun_elevation_deg, 0.0)};
}

TEST(MonteCarlo, OrderOneEqualsSingleScattering) {
    for (const std::string preset : {"earth", "mars"}) {
        const Atmosphere atm = atmosphere(preset);
        for (const ViewRay& ray : {view(0, 30, 90, 0), view(0, 5, 10, 0), view(0, 30, -20, 180),
                                   view(400e3, 45, -90, 0), view(400e3, 45, -19, 180), view(0, -3, 60, 0)}) {
            const std::size_t n = atm.wavelength_count();
            std::vector<double> T(n), Lr(n), Lm(n), L(n);
            single_scattering(atm, ray, {T, Lr, Lm, L});
            McSettings mc;
            mc.paths = 8000;
            mc.max_order = 1;
            const McResult r = monte_carlo_radiance(atm, ray, mc);
            for (std::size_t w = 0; w < n; ++w)
                EXPECT_NEAR(r.value[w], L[w], 3.0 * r.standard_error[w] + 0.003 * L[w] + 1e-15)
                    << preset << " λ " << kWavelengths[w] << " view z " << ray.view_direction.z;
        }
    }
}

TEST(MonteCarlo, FreePathInversionHitsTheOpticalDepth) {
    const Atmosphere atm = atmosphere("earth");
    for (double el : {90.0, 5.0, 0.0, -1.0}) {
        const auto d = direction_from_elevation_azimuth_deg<double>(el, 0.0);
        const PlanetRay<double> ray{atm.planet_radius_m, 100.0, {d.z, std::hypot(d.x, d.y)}};
        const auto seg = atmosphere_segment(ray, atm.top_altitude_m);
        std::vector<double> total(atm.wavelength_count()), tau(atm.wavelength_count());
        optical_depth(atm, ray, seg.t_begin, seg.t_end, total);
        for (std::size_t w = 0; w < atm.wavelength_count(); ++w)
            for (double f : {1e-6, 0.01, 0.3, 0.5, 0.9, 0.999999}) {
                const double target = f * total[w];
                const double t = free_path_distance(atm, ray, seg.t_begin, seg.t_end, w, target);
                optical_depth(atm, ray, seg.t_begin, t, tau);
                EXPECT_NEAR(tau[w], target, 1e-9 * total[w]) << "el " << el << " f " << f;
            }
    }
}

TEST(MonteCarlo, FreePathsFollowTheTruncatedExponentialLaw) {
    // Draw τ* by inversion of 1 − e^{−τ} on [0, τ_e], map it to a distance and back: the
    // optical depths of the sampled distances must be distributed as the truncated
    // exponential (one-sample Kolmogorov–Smirnov, 1 % critical value 1.63/√n).
    const Atmosphere atm = atmosphere("earth");
    const PlanetRay<double> ray{atm.planet_radius_m, 0.0, ZenithAngle<double>::from_degrees(85.0)};
    const auto seg = atmosphere_segment(ray, atm.top_altitude_m);
    std::vector<double> total(atm.wavelength_count()), tau(atm.wavelength_count());
    optical_depth(atm, ray, seg.t_begin, seg.t_end, total);
    const std::size_t w = 0;
    const double absorbed = -std::expm1(-total[w]);
    const int n = 2000;
    std::vector<double> cdf_values;
    for (int i = 0; i < n; ++i) {
        const double xi = (i + 0.5) / n;  // stratified uniforms, shuffled by the golden ratio
        const double u = std::fmod(xi * 0.6180339887498949 * n, 1.0);
        const double t = free_path_distance(atm, ray, seg.t_begin, seg.t_end, w, -std::log1p(-u * absorbed));
        optical_depth(atm, ray, seg.t_begin, t, tau);
        cdf_values.push_back(-std::expm1(-tau[w]) / absorbed);
    }
    std::sort(cdf_values.begin(), cdf_values.end());
    double D = 0.0;
    for (int i = 0; i < n; ++i)
        D = std::max({D, std::abs(cdf_values[i] - double(i) / n), std::abs(cdf_values[i] - double(i + 1) / n)});
    EXPECT_LT(D, 1.63 / std::sqrt(double(n)));
}

TEST(MonteCarlo, ConservativeAtmosphereSendsOutWhatItIntercepts) {
    Scene scene = test::conservative_scene(load_preset("earth"));
    const std::vector<double> wl = {550.0};
    Atmosphere atm = compile_atmosphere(scene, wl);
    set_constant_irradiance(atm, 1.0);
    // (seeds 1–4 with 100000 paths gave 1.0106, 1.0010, 0.9970, 1.0007, each ± 0.0043)
    McSettings mc;
    mc.paths = 100000;
    mc.seed = 3;
    const McResult r = monte_carlo_energy_balance(atm, mc);
    EXPECT_NEAR(r.value[0], 1.0, 3.0 * r.standard_error[0]);
    EXPECT_LT(r.standard_error[0], 0.01);
    // With a black ground most of it is absorbed: the estimator is not trivially 1.
    scene.planet.ground_albedo = 0.0;
    Atmosphere black = compile_atmosphere(scene, wl);
    set_constant_irradiance(black, 1.0);
    mc.paths = 4000;
    EXPECT_LT(monte_carlo_energy_balance(black, mc).value[0], 0.3);
}

TEST(MonteCarlo, SeedsAgreeAndThreadsDoNotMatter) {
    const Atmosphere atm = atmosphere("earth");
    const ViewRay ray = view(0, 20, 30, 90);
    McSettings a;
    a.paths = 6000;
    a.seed = 1;
    a.threads = 1;
    McSettings b = a;
    b.threads = 2;
    const McResult r1 = monte_carlo_radiance(atm, ray, a), r2 = monte_carlo_radiance(atm, ray, b);
    EXPECT_EQ(r1.value, r2.value);
    a.seed = 2;
    const McResult r3 = monte_carlo_radiance(atm, ray, a);
    for (std::size_t w = 0; w < atm.wavelength_count(); ++w) {
        EXPECT_NE(r1.value[w], r3.value[w]);
        EXPECT_NEAR(r1.value[w], r3.value[w], 4.0 * std::hypot(r1.standard_error[w], r3.standard_error[w]));
    }
}

TEST(MonteCarlo, EdgesAndErrors) {
    const Atmosphere atm = atmosphere("earth");
    McSettings mc;
    mc.paths = 100;
    // a ray that misses the atmosphere from space sees nothing
    const McResult miss = monte_carlo_radiance(atm, view(400e3, 45, -15, 0), mc);
    for (double v : miss.value) EXPECT_EQ(v, 0.0);
    // exactly horizontal and exactly down from the ground: finite
    for (const ViewRay& ray : {view(0, 10, 0, 0), view(0, 10, -90, 0), view(0, -90, 90, 0)}) {
        const McResult r = monte_carlo_radiance(atm, ray, mc);
        for (double v : r.value) EXPECT_TRUE(std::isfinite(v) && v >= 0.0);
    }
    mc.paths = 1;
    EXPECT_THROW(monte_carlo_radiance(atm, view(0, 10, 10, 0), mc), std::invalid_argument);
    mc = {};
    mc.min_order = 3;
    mc.max_order = 2;
    try {
        monte_carlo_radiance(atm, view(0, 10, 10, 0), mc);
        ADD_FAILURE();
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("max_order"), std::string::npos);
    }
    CancelFlag flag;
    flag.request();
    mc = {};
    mc.cancel = &flag;
    EXPECT_THROW(monte_carlo_radiance(atm, view(0, 10, 10, 0), mc), Cancelled);
}

}  // namespace
}  // namespace airmass
