// What `airmass sun` and `airmass sky --time-range` share: the solar-position options
// (ΔT, ΔUT1, refraction) and the CSV formatting of the angles, so the two print the same
// numbers for the same place and time.
#pragma once

#include <optional>
#include <string>

#include <CLI/CLI.hpp>

#include "airmass/solar_position.hpp"
#include "commands.hpp"

namespace airmass::cli {

struct SunCliOptions {
    std::optional<double> delta_t_s;
    std::optional<double> delta_ut1_s;
    // `airmass sun` only (the sky model bends no rays and sits at its own altitude):
    std::optional<double> site_elevation_m;
    bool refraction = false;
    std::optional<double> pressure_mbar, temperature_c;
};

// number_in (commands.hpp) whose message reads as the library's for the same value (the Solar
// Position Algorithm's): "--latitude: latitude_deg = 95: must be in [-90, 90] degrees".
CLI::Validator number_in(double lo, double hi, Ends ends, const char* field, const char* unit);

// --delta-t, --delta-ut1; with `full`, also --site-elevation, --refraction, --pressure, --temperature.
void add_sun_options(CLI::App* cmd, SunCliOptions& options, bool full);

// The SPA input for one place and time with the options applied; `what` prefixes errors
// ("sun", "sky"). Throws CliError when --pressure/--temperature are given without --refraction.
SolarPositionInput solar_input(const SunCliOptions& options, double latitude_deg, double longitude_deg,
                               const UtcTime& time, const std::string& what);

// Angles as both commands print them: fixed, 7 decimals (1e-7°, far below SPA's ±0.0003°).
std::string format_angle(double degrees);
// "elevation_deg,azimuth_deg,blender_elevation_deg,blender_rotation_deg" and its values.
inline constexpr const char* kSunAngleColumns = "elevation_deg,azimuth_deg,blender_elevation_deg,blender_rotation_deg";
std::string sun_angle_fields(const SolarPosition& p);
// Latitude/longitude echoed back (up to 10 significant digits).
std::string format_place(double degrees);

}  // namespace airmass::cli
