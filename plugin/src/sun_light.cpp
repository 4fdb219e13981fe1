#include "airmass/sun_light.hpp"

#include <algorithm>
#include <limits>
#include <vector>

#include "airmass/atmosphere.hpp"
#include "airmass/color.hpp"
#include "airmass/geometry.hpp"
#include "airmass/optical_depth.hpp"
#include "airmass/sky.hpp"

namespace airmass {

SunLight sun_light_at_observer(const Scene& scene, ChapmanMethod chapman) {
    EvalSettings settings;
    settings.chapman = chapman;
    const std::vector<double> wavelengths = basis_wavelengths_nm(scene.basis);
    const Atmosphere atmosphere = compile_atmosphere(scene, wavelengths, settings);

    // Direct sunlight at the observer: E(λ)·T(λ) with T along the ray toward the sun (0 when
    // the planet is in the way), mapped to RGB exactly as the sky's sun disc is.
    const glm::dvec3 sun = sun_direction(scene.sun.elevation_deg, scene.sun.azimuth_deg);
    const double r0 = scene.planet.radius_m + scene.observer.altitude_m;
    const auto ray =
        PlanetRay<double>::from_vectors(scene.planet.radius_m, Vec3<double>(0, 0, r0), Vec3<double>(sun.x, sun.y, sun.z));
    std::vector<double> t(wavelengths.size(), 1.0);
    const bool blocked = hits_ground(ray);
    if (blocked)
        std::fill(t.begin(), t.end(), 0.0);
    else
        transmittance(atmosphere, ray, 0.0, std::numeric_limits<double>::infinity(), t);
    std::vector<double> top(wavelengths.size()), bottom(wavelengths.size());
    for (std::size_t w = 0; w < wavelengths.size(); ++w) {
        top[w] = atmosphere.sun_irradiance[w];
        bottom[w] = top[w] * t[w];
    }
    const SpectrumToRgb to_rgb = spectrum_to_rgb(scene.basis);
    const Vec3d rgb = to_rgb.apply(bottom);
    const Vec3d rgb_top = to_rgb.apply(top);

    SunLight out;
    out.direction = sun;
    for (int c = 0; c < 3; ++c) {
        out.irradiance_rgb[c] = std::max(0.0, rgb[c]);
        out.irradiance_top_rgb[c] = std::max(0.0, rgb_top[c]);
    }
    out.angular_diameter_deg = 2.0 * scene.sun.angular_radius_deg;
    out.below_horizon = blocked;
    return out;
}

double SunLight::lamp_strength() const {
    return std::max({irradiance_rgb.x, irradiance_rgb.y, irradiance_rgb.z});
}

glm::dvec3 SunLight::lamp_colour() const {
    const double s = lamp_strength();
    return s > 0.0 ? irradiance_rgb / s : glm::dvec3(1.0);
}

}  // namespace airmass
