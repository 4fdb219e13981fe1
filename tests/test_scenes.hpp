// Scenes the tests build themselves, independent of the presets and of scene_io, so that
// a mistake in a preset file cannot hide behind a test that reads the same file.
#pragma once

#include <vector>

#include "airmass/scene.hpp"

namespace airmass::test {

inline constexpr double kEarthRadius_m = 6360e3;
inline constexpr double kEarthAtmosphereThickness_m = 60e3;

inline DensityProfile exponential_profile(double scale_height_m, double reference_altitude_m = 0.0) {
    DensityProfile p;
    p.kind = DensityProfile::Kind::exponential;
    p.scale_height_m = scale_height_m;
    p.reference_altitude_m = reference_altitude_m;
    return p;
}

inline DensityProfile tent_profile(double bottom_m, double peak_m, double top_m) {
    DensityProfile p;
    p.kind = DensityProfile::Kind::tent;
    p.bottom_m = bottom_m;
    p.peak_m = peak_m;
    p.top_m = top_m;
    return p;
}

// Earth-like: Bruneton's demo Rayleigh (1.24062e-6 (λ/µm)^-4 m^-1, H = 8 km) and Mie
// (scattering 3.996e-6, absorption 4.44e-7 m^-1, H = 1.2 km, Cornette–Shanks g = 0.8), an
// ozone tent 10-25-40 km with a 3-wavelength absorption table, ground albedo 0.1, the
// sun's angular radius 0.2678578°.
inline Scene earth_like_scene() {
    Scene s;
    s.planet = {kEarthRadius_m, kEarthRadius_m + kEarthAtmosphereThickness_m, 0.1};
    Constituent ray;
    ray.name = "rayleigh";
    ray.profile = exponential_profile(8000.0);
    ray.scattering.law = SpectralCoefficient::Law::power_law;
    ray.scattering.value_per_m = 1.24062e-6;
    ray.scattering.reference_nm = 1000.0;
    ray.scattering.exponent = 4.0;
    ray.phase.kind = PhaseFunction::Kind::rayleigh;
    Constituent mie;
    mie.name = "mie";
    mie.profile = exponential_profile(1200.0);
    mie.scattering.value_per_m = 3.996e-6;
    mie.absorption.value_per_m = 4.44e-7;
    mie.phase = {PhaseFunction::Kind::cornette_shanks, 0.8};
    Constituent oz;
    oz.name = "ozone";
    oz.profile = tent_profile(10e3, 25e3, 40e3);
    oz.absorption.law = SpectralCoefficient::Law::table;
    oz.absorption.table = {{440.0, 8.5e-8}, {550.0, 1.88e-6}, {680.0, 6.5e-7}};
    s.constituents = {ray, mie, oz};
    s.sun.angular_radius_deg = 0.2678578;
    return s;
}

// The scene made conservative, for energy-balance checks: every absorption removed, the
// constituents that do not scatter dropped, a white ground (albedo 1). All light the
// atmosphere intercepts must then leave it again.
inline Scene conservative_scene(Scene s) {
    s.planet.ground_albedo = 1.0;
    std::vector<Constituent> keep;
    for (Constituent c : s.constituents) {
        c.absorption = SpectralCoefficient{};
        if (!c.scattering.is_zero()) keep.push_back(c);
    }
    s.constituents = keep;
    return s;
}

}  // namespace airmass::test
