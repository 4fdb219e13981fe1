// The direct sunlight at the observer, for a Sun lamp beside a sky texture: what the C ABI's
// airmass_sun_light_at_observer returns to the Blender add-on and `airmass sky` sequences
// write per frame (Evaluator::sun_light at the observer, evaluator.hpp, mapped to RGB).
#pragma once

#include <glm/vec3.hpp>

#include "airmass/chapman.hpp"
#include "airmass/atmosphere.hpp"
#include "airmass/scene.hpp"

namespace airmass {

struct SunLight {
    glm::dvec3 direction{0.0, 0.0, 1.0};  // unit vector toward the sun, scene frame (Z up)
    // Transmitted direct sun E(λ)·T(λ), linear Rec.709 in the sky texture's units (Σ·CMF·Δλ,
    // no 683 lm/W), negative channels clipped to 0; T = 0 when the planet is in the way.
    glm::dvec3 irradiance_rgb{0.0};
    glm::dvec3 irradiance_top_rgb{0.0};  // the same at the top of the atmosphere
    double angular_diameter_deg = 0.0;
    bool below_horizon = false;
    // A Sun lamp emits strength × colour (the add-on's sun.py): strength = the largest
    // channel, colour = rgb / strength (each <= 1; white when the strength is 0).
    double lamp_strength() const;
    glm::dvec3 lamp_colour() const;
};

// `scene` as validated by validate(scene); chapman: the method for the optical depth.
SunLight sun_light_at_observer(const Scene& scene, ChapmanMethod chapman = EvalSettings{}.chapman);

}  // namespace airmass
