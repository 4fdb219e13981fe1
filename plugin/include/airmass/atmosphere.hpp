// The evaluation-ready form of a Scene for a fixed list of wavelengths.
//
// `compile_atmosphere` keeps only the constituents that scatter or absorb at some
// requested wavelength (a scene pays only for what it declares), tabulates their
// coefficients per wavelength, and reduces every density profile to one of two forms
// that have closed-form optical depths along straight rays:
//   * exponential   rho(h) = exp(−(h − h_ref)/H)        → the Chapman function;
//   * piecewise linear in altitude, 0 outside its knots → ∫ sqrt(p² + s²) ds in closed form
//     (tent, piecewise_linear and constant profiles all become this).
// Geometry: planet centre at the origin, radii in metres. The medium is the shell
// between the ground (opaque, Lambertian) and the top of the atmosphere: every density
// is zero above `top_altitude_m` (as in a render of the same scene's volume).
#pragma once

#include <span>
#include <string>
#include <vector>

#include "airmass/chapman.hpp"
#include "airmass/scene.hpp"

namespace airmass {

// Knobs of the evaluator along each view ray (view-ray quality). Their error-vs-cost tables
// are in docs/evaluation.md. The one struct every consumer holds (SkySettings::view,
// RenderSettings::view, `airmass eval`); each consumer keeps its own defaults (the sky's
// sun disc on, a camera render's off).
struct EvalSettings {
    // Chapman method for exponential constituents (sun rays and view segments).
    ChapmanMethod chapman = ChapmanMethod::airmass;
    // Samples per scattering constituent along each view ray (Gauss–Legendre nodes in that
    // constituent's sampling variable; single_scattering.hpp). ≥ 1. After compile_atmosphere,
    // change it with set_view_samples (which checks the range).
    int view_samples = 16;
    // Add the solar disc (uniform radiance E_sun / Ω_sun, Ω_sun = 2π(1 − cos α)) to view
    // rays that point into it and reach space.
    bool sun_disc = false;
    // Shade view rays that hit the ground (Lambert, direct sun only).
    bool ground = true;
};

struct CompiledProfile {
    enum class Kind { exponential, piecewise_linear };
    Kind kind = Kind::exponential;
    // exponential
    double scale_height_m = 8000.0;
    double reference_altitude_m = 0.0;
    // True when the density at the top of the atmosphere is large enough that cutting
    // the medium at the top changes a sun ray's optical depth by more than 1e-12
    // relative to its ground column (then the top's Chapman term is subtracted).
    bool truncate_at_top = true;
    // piecewise linear: knots at increasing altitudes (metres), density 0 outside
    // [front, back]. Consecutive equal altitudes encode a jump (constant profiles).
    std::vector<double> altitude_m;
    std::vector<double> density;

    double at(double altitude_m) const;  // the profile's density, 0 above the top is NOT applied here
};

struct AtmosphereConstituent {
    std::string name;
    std::size_t scene_index = 0;  // position in Scene::constituents
    CompiledProfile profile;
    PhaseFunction phase;
    bool rayleigh_like = true;  // phase.hpp is_rayleigh_like: which radiance column it adds to
    bool scatters = false;      // σs > 0 at some wavelength: it gets view-ray samples
    // Per wavelength, m⁻¹ at density 1: scattering, absorption, and their sum.
    std::vector<double> scattering_per_m;
    std::vector<double> absorption_per_m;
    std::vector<double> extinction_per_m;
};

struct Atmosphere {
    double planet_radius_m = 6360e3;
    double top_altitude_m = 60e3;  // atmosphere_top_m − radius_m
    std::vector<double> knots_m;   // profile_knots_m(scene): where the sky grids split (sky_grid.hpp)
    double ground_albedo = 0.1;
    double sun_angular_radius_rad = 0.0;
    std::vector<double> wavelengths_nm;
    std::vector<double> sun_irradiance;  // W m⁻² nm⁻¹ at the top of the atmosphere, per wavelength
    std::vector<AtmosphereConstituent> constituents;  // active only, in scene order
    EvalSettings settings;
    // Derived by compile_atmosphere for the hot loops: extinction_per_m of every
    // constituent, wavelength-major: [w * constituents.size() + i].
    std::vector<double> extinction_matrix;
    // Derived: the Gauss–Legendre rules of 1 … 16 nodes on [0, 1] (math/quadrature.hpp
    // unit_gauss_rule_table), from which the view-ray quadrature composes the rule of each
    // piece of a ray it shares settings.view_samples nodes among (single_scattering.hpp).
    std::vector<double> gauss_rules;

    std::size_t wavelength_count() const { return wavelengths_nm.size(); }
};

// Maximum number of active constituents (the evaluator keeps per-constituent
// per-sample values on the stack).
inline constexpr std::size_t kMaxConstituents = 16;

// Throws SceneError (scene_io.hpp) for an unusable scene field and std::invalid_argument
// for bad wavelengths or settings, naming the field, value and allowed range.
Atmosphere compile_atmosphere(const Scene& scene, std::span<const double> wavelengths_nm,
                              const EvalSettings& settings = {});

// The altitudes (metres) of the knots of the scene's piecewise-linear profiles — tents,
// tables, constant layers — where the density or its slope jumps by at least
// kMinKinkStrength of the profile's mean slope (peak density / thickness; a jump of the
// density counts as infinite), the strongest kMaxProfileKinks: where the sky grids split
// (sky_grid.hpp Horizon::kinks; Atmosphere::knots_m holds the same). Profiles that are 0
// everywhere have none. SceneError for a bad profile. The second form takes the profiles
// already compiled (compile_atmosphere: every constituent's, active at its wavelengths or not,
// so that both forms agree).
inline constexpr double kMinKinkStrength = 1.0;
inline constexpr std::size_t kMaxProfileKinks = 8;
std::vector<double> profile_knots_m(const Scene& scene);
std::vector<double> profile_knots_m(std::span<const CompiledProfile> profiles);

// settings.view_samples = view_samples (in [1, 1000000], else std::invalid_argument naming it).
void set_view_samples(Atmosphere& atmosphere, int view_samples);

// Replace the sun's top-of-atmosphere irradiance by a constant (W m⁻² nm⁻¹), e.g. 1 for
// radiance per unit irradiance.
void set_constant_irradiance(Atmosphere& atmosphere, double irradiance);

}  // namespace airmass
