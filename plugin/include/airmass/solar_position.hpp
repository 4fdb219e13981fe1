// The sun's position in the sky of a place on Earth at a moment in UTC: NREL's Solar Position
// Algorithm (SPA; I. Reda and A. Andreas, "Solar position algorithm for solar radiation
// applications", Solar Energy 76 (2004) 577–589, revised as NREL/TP-560-34302, January 2008),
// stated uncertainty ±0.0003° for the years −2000 to 6000. docs/sun.md describes the steps,
// the ΔT handling, the refraction switch and the conventions.
//
// Output angles are topocentric (seen from the observer, parallax included): elevation above
// the astronomical horizon and azimuth measured from north, clockwise (east = 90°). No
// atmospheric refraction unless `refraction` is set (the sky model bends no rays, so the
// geometric sun is the one that matches the rendered sky).
//
// Blender's Sky Texture angles for a scene whose +Y is north and +X east (airmass/sky.hpp:
// sun_direction(e, r) = (cos e sin r, cos e cos r, sin e)): the east component of a sun at
// azimuth A is cos e sin A and the north one cos e cos A, so rotation = A and
// elevation = e (tests/test_solar_position.cpp checks it through sun_direction()).
#pragma once

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

namespace airmass {

// Every problem with a solar-position input: the message names the field, the value and the
// allowed range, e.g. "latitude_deg = 91: must be in [-90, 90]".
struct SolarPositionError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// A moment on the UTC time scale, proleptic Gregorian calendar (ISO 8601): whole days since
// 1970-01-01 and seconds into that day, [0, 86400).
struct UtcTime {
    std::int64_t days = 0;
    double seconds = 0.0;
};

// Years accepted in times (SPA's validity is −2000 to 6000; ISO 8601's four-digit years
// start at 0000).
inline constexpr int kSolarMinYear = 0;
inline constexpr int kSolarMaxYear = 6000;

// ISO 8601 date-time: "YYYY-MM-DDThh:mm[:ss[.fff…]]" followed by "Z" or an offset "±hh:mm"
// (or "±hhmm", "±hh"); ' ' is accepted for 'T'. A time without zone is refused (it would be
// ambiguous). Seconds may be 60 (a leap second: taken as the next minute's start). Throws
// SolarPositionError naming `field` ("time", "utc", "line 3: utc", ...) and the text.
UtcTime parse_utc(std::string_view text, std::string_view field = "time");
// The same without throwing: nullopt and the reason in *why (e.g. "month 13 is not in [1, 12]").
std::optional<UtcTime> try_parse_utc(std::string_view text, std::string* why);
// "YYYY-MM-DDThh:mm:ssZ", with as many fractional digits as needed up to milliseconds.
std::string format_utc(const UtcTime& t);
UtcTime add_seconds(const UtcTime& t, double seconds);
// Seconds from a to b.
double seconds_between(const UtcTime& a, const UtcTime& b);
// Julian day on the UT scale (JD 2440587.5 = 1970-01-01T00:00Z).
double julian_day(const UtcTime& t);
// Decimal year of a moment (for ΔT).
double decimal_year(const UtcTime& t);

// ΔT = TT − UT1 in seconds, Espenak & Meeus's polynomials (NASA Five Millennium Canon of
// Solar Eclipses, 2006; eclipse.gsfc.nasa.gov/SEhelp/deltatpoly2004.html) at decimal year y.
double delta_t_espenak_meeus(double year);

inline constexpr double kMaxAbsDeltaT = 100000.0;   // s; Espenak–Meeus gives ~ 47000 s at −2000
inline constexpr double kMaxAbsDeltaUt1 = 1.0;      // s; UT1 − UTC is kept within 0.9 s by leap seconds

struct SolarPositionInput {
    double latitude_deg = 0.0;   // geodetic, north positive, [−90, 90]
    double longitude_deg = 0.0;  // east positive, [−180, 180]
    UtcTime time;                // UTC
    double elevation_m = 0.0;    // observer height above sea level (parallax only), [−10000, 1e7]
    // ΔT = TT − UT1, seconds; unset: delta_t_espenak_meeus(decimal_year(time)). |ΔT| <= kMaxAbsDeltaT.
    std::optional<double> delta_t_s;
    double delta_ut1_s = 0.0;  // UT1 − UTC, seconds, |value| <= 1 (IERS Bulletin A); 0 by default
    // Atmospheric refraction (SPA eq. 42): off by default. Pressure in mbar (hPa), (0, 5000];
    // temperature in °C, [−120, 1000) (eq. 42's 283 / (273 + T) diverges at −273 °C).
    bool refraction = false;
    double pressure_mbar = 1010.0;
    double temperature_c = 10.0;
};

struct SolarPosition {
    // Intermediate quantities (SPA's names), for tests and for the curious.
    double julian_day = 0.0;                // UT1
    double julian_ephemeris_day = 0.0;      // TT
    double delta_t_s = 0.0;                 // the ΔT used
    double heliocentric_longitude_deg = 0;  // L, [0, 360)
    double heliocentric_latitude_deg = 0;   // B
    double earth_radius_vector_au = 0;      // R
    double nutation_longitude_deg = 0;      // Δψ
    double nutation_obliquity_deg = 0;      // Δε
    double true_obliquity_deg = 0;          // ε
    double apparent_longitude_deg = 0;      // λ
    double apparent_sidereal_time_deg = 0;  // ν, [0, 360)
    double right_ascension_deg = 0;         // α (geocentric), [0, 360)
    double declination_deg = 0;             // δ (geocentric)
    double topocentric_hour_angle_deg = 0;  // H′
    double topocentric_declination_deg = 0; // δ′
    double refraction_deg = 0;              // Δe (0 unless refraction is on)
    // Results.
    double zenith_deg = 0.0;     // topocentric zenith angle, 90 − elevation
    double elevation_deg = 0.0;  // topocentric elevation (refracted when refraction is on)
    double azimuth_deg = 0.0;    // from north, clockwise (east = 90°), [0, 360)
    // Blender Sky Texture angles for a scene with +Y north, +X east (see the header comment).
    double blender_elevation_deg = 0.0;
    double blender_rotation_deg = 0.0;
};

// Throws SolarPositionError naming the field, the value and the allowed range.
void validate(const SolarPositionInput& input);
SolarPosition solar_position(const SolarPositionInput& input);

}  // namespace airmass
