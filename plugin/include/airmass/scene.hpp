// The scene description: a planet's atmosphere described once, in SI units, as plain
// value types. The same structure is read from a TOML file (scene_io.hpp; field names
// and units in docs/scene.md) and built by presets (examples/*.toml, by name).
//
// Conventions
//   * lengths in metres, coefficients in m⁻¹ at density 1, wavelengths in nm, angles in degrees;
//   * altitudes are above the planet's surface (radius `planet.radius_m`);
//   * scene frame: Z up at the observer, sun azimuth in Blender's Sky Texture convention
//     (rotation 0° → sun toward +Y, 90° → toward +X), elevation above the horizon.
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "airmass/chapman.hpp"
#include "airmass/solar_position.hpp"

namespace airmass {

// Density relative to the constituent's reference density (1 at the reference).
struct DensityProfile {
    enum class Kind { exponential, tent, piecewise_linear, constant };
    Kind kind = Kind::exponential;
    // exponential: rho(h) = exp(−(h − reference_altitude_m) / scale_height_m)
    double scale_height_m = 8000.0;
    double reference_altitude_m = 0.0;
    // tent: 0 at bottom, rising linearly to 1 at peak, falling linearly to 0 at top
    double bottom_m = 0.0, peak_m = 0.0, top_m = 0.0;
    // piecewise_linear: (altitude_m, density) knots, increasing altitude; 0 outside
    std::vector<std::pair<double, double>> knots;
    // constant: rho = value between bottom_m and top_m (top_m = 0: up to the atmosphere top)
    double value = 1.0;

    // Relative density at altitude h (metres above the surface); ≥ 0, finite.
    double at(double altitude_m) const;
};

// A coefficient as a function of wavelength, in m⁻¹ at density 1.
struct SpectralCoefficient {
    enum class Law { constant, power_law, table };
    Law law = Law::constant;
    // constant: value_per_m. power_law: value_per_m · (lambda / reference_nm)^(−exponent)
    // (exponent 4 is Rayleigh's λ⁻⁴ law, Ångström's alpha otherwise).
    double value_per_m = 0.0;
    double reference_nm = 550.0;
    double exponent = 0.0;
    // table: (wavelength_nm, value_per_m), increasing wavelength, linear interpolation, clamped
    std::vector<std::pair<double, double>> table;

    double at(double wavelength_nm) const;
    bool is_zero() const;  // true when it is 0 at every wavelength
};

struct PhaseFunction {
    enum class Kind { rayleigh, rayleigh_modified, cornette_shanks, henyey_greenstein, isotropic };
    Kind kind = Kind::rayleigh;
    double g = 0.0;  // asymmetry for cornette_shanks / henyey_greenstein, in (−1, 1)
};

struct Constituent {
    std::string name;  // e.g. "rayleigh", "mie", "ozone": the VDB grid name
    DensityProfile profile;
    SpectralCoefficient scattering;
    SpectralCoefficient absorption;
    PhaseFunction phase;
};

struct Planet {
    double radius_m = 6360e3;
    double atmosphere_top_m = 6420e3;  // radius of the top of the atmosphere
    double ground_albedo = 0.1;
};

// A place on Earth and a moment the sun is computed from (solar_position.hpp; the scene file's
// [sun] latitude_deg, longitude_deg, time). Topocentric, no refraction, ΔT as given or
// Espenak–Meeus; the scene's frame has +Y north and +X east.
struct SunPlace {
    double latitude_deg = 0.0;
    double longitude_deg = 0.0;
    UtcTime time;
    std::optional<double> delta_t_s;
};

struct Sun {
    // With `place`, elevation_deg and azimuth_deg are the angles resolved from it (so
    // everything downstream reads them as before).
    std::optional<SunPlace> place;
    double elevation_deg = 45.0;     // above the observer's horizon, [−90, 90]
    double azimuth_deg = 0.0;        // Blender Sky Texture "rotation": 0 → +Y, 90 → +X
    double angular_radius_deg = 0.2667;
    // Top-of-atmosphere spectral irradiance, W m⁻² nm⁻¹; empty = constant
    // `irradiance_constant` (1 gives radiance per unit irradiance).
    std::vector<std::pair<double, double>> irradiance_table;
    double irradiance_constant = 1.0;

    double irradiance_at(double wavelength_nm) const;
};

struct Observer {
    double altitude_m = 0.0;  // above the surface; may be above the atmosphere top
};

// Optional camera, for renders and for the VDB `view` region.
struct Camera {
    double position_m[3] = {0.0, 0.0, 2.0};  // scene frame, origin on the surface below the observer
    double direction[3] = {1.0, 0.0, 0.0};   // view direction (need not be unit)
    double up[3] = {0.0, 0.0, 1.0};
    double fov_deg = 60.0;                   // along the larger image side (Blender sensor fit AUTO)
    double max_distance_m = 200e3;
    int width = 640, height = 360;
};

struct SpectralBasis {
    enum class Kind { rgb_schuler, spectral };
    Kind kind = Kind::spectral;
    // rgb_schuler: 615, 535, 445 nm with Schüler's matrix to linear sRGB (seed 001);
    // spectral: wavelengths with CIE 1931 2° CMFs → XYZ → linear Rec.709.
    std::vector<double> wavelengths_nm;
};

struct Scene {
    std::string name;
    Planet planet;
    Sun sun;
    Observer observer;
    std::optional<Camera> camera;
    SpectralBasis basis;
    std::vector<Constituent> constituents;
};

}  // namespace airmass
