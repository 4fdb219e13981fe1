// The one view-ray march (transport/view_march.inc) through its second consumer, the medium
// cut to a box (render.hpp: box_limited_radiance, adaptive Gauss–Legendre panels, sun masses
// inside the box): a box that holds the whole atmosphere is the full shell, so its radiance
// must equal the brute-force nested quadrature of the shell (single_scattering_reference,
// independent of the march) — in the sky, at the ground, and across Earth's shadow.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "test_scenes.hpp"
#include "airmass/geometry.hpp"
#include "airmass/render.hpp"
#include "airmass/single_scattering.hpp"

namespace airmass {
namespace {

const std::vector<double> kWavelengths{680.0, 550.0, 440.0};

struct Case {
    const char* what;
    double view_zenith_deg, sun_zenith_deg, sun_azimuth_deg;
    double rel_tol;  // measured: ≤ 4e-10 lit, ≤ 6e-6 across Earth's shadow
};

TEST(ViewMarch, BoxHoldingTheAtmosphereMatchesNestedQuadrature) {
    const Scene scene = test::earth_like_scene();
    EvalSettings exact;
    exact.chapman = ChapmanMethod::exact;
    const Atmosphere atm = compile_atmosphere(scene, kWavelengths, exact);
    // Scene frame: planet centre at (0, 0, −R), so the observer 2 m up has +Z as zenith and
    // the observer-frame directions carry over. The box holds the whole shell.
    const double h = 2.0;
    const MediumBox box{{-7000e3, -7000e3, -13000e3}, {7000e3, 7000e3, 1000e3}};
    const Case cases[] = {
        {"zenith, sun 30°", 0.0, 30.0, 0.0, 1e-8},
        {"60°, sun 30° at 90° azimuth", 60.0, 30.0, 90.0, 1e-8},
        {"near the horizon, sun 85° ahead", 89.0, 85.0, 0.0, 1e-8},
        {"ground at 120°, sun 40°", 120.0, 40.0, 0.0, 1e-8},
        {"45°, sun 5° below the horizon (Earth's shadow on the ray)", 45.0, 95.0, 0.0, 2e-5},
        {"80°, sun 3° below the horizon, behind", 80.0, 93.0, 180.0, 2e-5},
    };
    for (const Case& c : cases) {
        const Vec3<double> v = direction_from_zenith_azimuth_deg<double>(c.view_zenith_deg, 0.0);
        const Vec3<double> sun = direction_from_zenith_azimuth_deg<double>(c.sun_zenith_deg, c.sun_azimuth_deg);
        double T[3], R[3], M[3], L[3];
        single_scattering_reference(scene, atm, ViewRay{h, v, sun}, {T, R, M, L}, 1e-8);
        std::vector<double> box_L(3);
        box_limited_radiance(atm, box, glm::dvec3(0.0, 0.0, h), glm::dvec3(v), glm::dvec3(sun), box_L);
        for (int w = 0; w < 3; ++w) {
            ASSERT_GT(L[w], 0.0) << c.what;
            EXPECT_NEAR(box_L[w], L[w], c.rel_tol * L[w]) << c.what << " λ=" << kWavelengths[w];
        }
    }
}

}  // namespace
}  // namespace airmass
