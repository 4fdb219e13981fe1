#include "sun_options.hpp"

#include <cmath>
#include <cstdio>

#include "commands.hpp"

namespace airmass::cli {

void add_sun_options(CLI::App* cmd, SunCliOptions& o, bool full) {
    cmd->add_option("--delta-t", o.delta_t_s,
                    "ΔT = TT - UT1 in seconds  [default: Espenak-Meeus polynomial for the date; docs/sun.md]")
        ->check(number_in(-kMaxAbsDeltaT, kMaxAbsDeltaT));
    cmd->add_option("--delta-ut1", o.delta_ut1_s, "UT1 - UTC in seconds  [default 0]")
        ->check(number_in(-kMaxAbsDeltaUt1, kMaxAbsDeltaUt1));
    if (!full) return;
    cmd->add_option("--site-elevation", o.site_elevation_m,
                    "Observer height above sea level in metres (parallax only)  [default 0]")
        ->check(number_in(-10000.0, 1e7));
    cmd->add_flag("--refraction", o.refraction,
                  "Add atmospheric refraction (SPA's formula) to the elevation; off by default");
    cmd->add_option("--pressure", o.pressure_mbar, "Air pressure for --refraction, mbar  [default 1010]")
        ->check(number_in(0.0, 5000.0, Ends::open_low));
    cmd->add_option("--temperature", o.temperature_c, "Air temperature for --refraction, °C  [default 10]")
        ->check(number_in(-120.0, 1000.0, Ends::open_high));
}

SolarPositionInput solar_input(const SunCliOptions& o, double latitude_deg, double longitude_deg, const UtcTime& time,
                               const std::string& what) {
    if (!o.refraction && (o.pressure_mbar || o.temperature_c))
        throw CliError(what + ": --pressure and --temperature apply with --refraction only");
    SolarPositionInput in;
    in.latitude_deg = latitude_deg;
    in.longitude_deg = longitude_deg;
    in.time = time;
    in.delta_t_s = o.delta_t_s;
    if (o.delta_ut1_s) in.delta_ut1_s = *o.delta_ut1_s;
    if (o.site_elevation_m) in.elevation_m = *o.site_elevation_m;
    in.refraction = o.refraction;
    if (o.pressure_mbar) in.pressure_mbar = *o.pressure_mbar;
    if (o.temperature_c) in.temperature_c = *o.temperature_c;
    return in;
}

std::string format_angle(double degrees) {
    if (std::abs(degrees) < 5e-8) degrees = 0.0;  // no "-0.0000000"
    char buf[48];
    std::snprintf(buf, sizeof buf, "%.7f", degrees);
    return buf;
}

std::string format_place(double degrees) {
    char buf[48];
    std::snprintf(buf, sizeof buf, "%.10g", degrees);
    return buf;
}

std::string sun_angle_fields(const SolarPosition& p) {
    // Azimuths are in [0, 360): one that rounds to 360 prints as 0.
    const auto azimuth = [](double a) {
        const std::string s = format_angle(a);
        return s == "360.0000000" ? format_angle(0.0) : s;
    };
    return format_angle(p.elevation_deg) + "," + azimuth(p.azimuth_deg) + "," + format_angle(p.blender_elevation_deg) +
           "," + azimuth(p.blender_rotation_deg);
}

}  // namespace airmass::cli
