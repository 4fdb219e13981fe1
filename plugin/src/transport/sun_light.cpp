// sun_light_at_observer (sun_light.hpp): the evaluator's sun_light at the observer, in RGB.
#include "airmass/sun_light.hpp"

#include <algorithm>
#include <vector>

#include "airmass/atmosphere.hpp"
#include "airmass/color.hpp"
#include "airmass/evaluator.hpp"
#include "airmass/sky.hpp"

namespace airmass {

SunLight sun_light_at_observer(const Scene& scene, ChapmanMethod chapman) {
    EvalSettings settings;
    settings.chapman = chapman;
    const std::vector<double> wavelengths = basis_wavelengths_nm(scene.basis);
    const Evaluator evaluator(compile_atmosphere(scene, wavelengths, settings));

    // Direct sunlight at the observer: E(λ)·T(λ) along the ray toward the sun (0 when the
    // planet is in the way; the evaluator's one sun-ray computation), mapped to RGB exactly
    // as the sky's sun disc is.
    const glm::dvec3 sun = sun_direction(scene.sun.elevation_deg, scene.sun.azimuth_deg);
    std::vector<double> bottom(wavelengths.size());
    const bool blocked =
        !evaluator.sun_light(scene.observer.altitude_m, ZenithAngle<double>::from_cos(sun.z), bottom);
    const std::vector<double>& top = evaluator.atmosphere().sun_irradiance;
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
