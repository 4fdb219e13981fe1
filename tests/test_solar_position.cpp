// The Solar Position Algorithm (solar_position.hpp) against the worked example of Reda &
// Andreas (NREL/TP-560-34302, Table A5.1 inputs, §A5 results), its conventions (through
// sky.hpp's sun_direction), ΔT, time parsing and every error path; the scene's [sun]
// place/time form; the `airmass sun` command line. Independent values over many places and
// dates: tests/python/test_sun.py (PyEphem).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>

#include <glm/geometric.hpp>

#include "airmass/scene_io.hpp"
#include "airmass/sky.hpp"
#include "airmass/solar_position.hpp"
#include "airmass/sun_light.hpp"
#include "test_cli.hpp"

namespace {

using namespace airmass;

// The paper's example: 17 October 2003, 12:30:30 local time at UT−7 (19:30:30 UT), Golden,
// Colorado; ΔT = 67 s, elevation 1830.14 m, 820 mbar, 11 °C, refraction on.
SolarPositionInput paper_input() {
    SolarPositionInput in;
    in.latitude_deg = 39.742476;
    in.longitude_deg = -105.1786;
    in.elevation_m = 1830.14;
    in.time = parse_utc("2003-10-17T12:30:30-07:00");
    in.delta_t_s = 67.0;
    in.refraction = true;
    in.pressure_mbar = 820.0;
    in.temperature_c = 11.0;
    return in;
}

template <class F>
std::string error_of(F&& f) {
    try {
        f();
    } catch (const std::exception& e) {
        return e.what();
    }
    return "(no error)";
}

TEST(SolarPosition, PaperExampleResults) {
    const SolarPosition p = solar_position(paper_input());
    // The published results: topocentric zenith 50.11162°, azimuth 194.34024° (the report
    // prints five decimals). The task's bar is 0.001°; this holds them to 2e-5°.
    EXPECT_NEAR(p.zenith_deg, 50.11162, 2e-5);
    EXPECT_NEAR(p.azimuth_deg, 194.34024, 2e-5);
    EXPECT_NEAR(p.elevation_deg, 90.0 - 50.11162, 2e-5);
    // The refraction step on its own: e0 = 39.872046° without it, Δe = 0.016332°.
    EXPECT_NEAR(p.elevation_deg - p.refraction_deg, 39.872046, 2e-6);
    EXPECT_NEAR(p.refraction_deg, 0.016332, 2e-6);
}

TEST(SolarPosition, PaperExampleIntermediates) {
    const SolarPosition p = solar_position(paper_input());
    EXPECT_NEAR(p.julian_day, 2452930.312847, 1e-6);
    EXPECT_NEAR(p.julian_ephemeris_day, 2452930.312847 + 67.0 / 86400.0, 1e-6);
    // L and R: the report's values carry 10 decimals; the truncated series it prints gives
    // them to 2e-6° and 2e-7 AU (the same difference other implementations of the
    // published tables show), far below the ±0.0003° of the method.
    EXPECT_NEAR(p.heliocentric_longitude_deg, 24.0182616917, 5e-6);
    EXPECT_NEAR(p.heliocentric_latitude_deg, -0.0001011219, 1e-9);
    EXPECT_NEAR(p.earth_radius_vector_au, 0.9965422974, 5e-7);
    EXPECT_NEAR(p.nutation_longitude_deg, -0.00399840, 1e-8);
    EXPECT_NEAR(p.nutation_obliquity_deg, 0.00166657, 1e-8);
    EXPECT_NEAR(p.true_obliquity_deg, 23.440465, 1e-6);
    EXPECT_NEAR(p.apparent_longitude_deg, 204.0085519281, 5e-6);
    EXPECT_NEAR(p.apparent_sidereal_time_deg, 318.5119, 1e-4);
    EXPECT_NEAR(p.right_ascension_deg, 202.22741, 1e-5);
    EXPECT_NEAR(p.declination_deg, -9.31434, 1e-5);
    EXPECT_NEAR(p.topocentric_declination_deg, -9.316179, 1e-6);
}

TEST(SolarPosition, RefractionIsASwitchAndOffByDefault) {
    SolarPositionInput in = paper_input();
    in.refraction = false;
    const SolarPosition p = solar_position(in);
    EXPECT_EQ(p.refraction_deg, 0.0);
    EXPECT_NEAR(p.elevation_deg, 39.872046, 2e-6);
    EXPECT_EQ(SolarPositionInput{}.refraction, false);
    // Below the horizon (past the sun's lower limit) SPA adds no refraction.
    in.refraction = true;
    in.time = parse_utc("2003-10-17T23:30:00-07:00");
    const SolarPosition night = solar_position(in);
    EXPECT_LT(night.elevation_deg, -10.0);
    EXPECT_EQ(night.refraction_deg, 0.0);
}

// +Y north, +X east: the Blender angles put the sun where the azimuth says, through the
// repo's own sun_direction().
TEST(SolarPosition, BlenderAnglesThroughSunDirection) {
    for (const char* t : {"2026-03-20T07:00:00Z", "2026-06-21T12:00:00Z", "2026-09-23T16:30:00Z",
                          "2026-12-21T09:15:00Z"}) {
        for (double lat : {-60.0, -10.0, 0.0, 35.0, 78.0}) {
            SolarPositionInput in;
            in.latitude_deg = lat;
            in.longitude_deg = 0.0;
            in.time = parse_utc(t);
            const SolarPosition p = solar_position(in);
            const double e = p.elevation_deg * std::numbers::pi / 180.0, a = p.azimuth_deg * std::numbers::pi / 180.0;
            const glm::dvec3 east_north_up(std::cos(e) * std::sin(a), std::cos(e) * std::cos(a), std::sin(e));
            const glm::dvec3 s = sun_direction(p.blender_elevation_deg, p.blender_rotation_deg);
            EXPECT_NEAR(glm::length(s - east_north_up), 0.0, 1e-12) << t << " lat " << lat;
        }
    }
    // A concrete case: the equinox morning at the equator has the sun just north of due east,
    // low: +X (east) dominates, +Z small and positive.
    SolarPositionInput in;
    in.time = parse_utc("2026-03-20T07:00:00Z");
    const SolarPosition p = solar_position(in);
    EXPECT_NEAR(p.azimuth_deg, 90.0, 1.0);
    // 07:00 UT at longitude 0 is 06:52 local solar time (equation of time −7.5 min): 52 min
    // after sunrise at 15°/h, 13°.
    EXPECT_NEAR(p.elevation_deg, 13.1, 0.3);
    const glm::dvec3 s = sun_direction(p.blender_elevation_deg, p.blender_rotation_deg);
    EXPECT_GT(s.x, 0.95);
    EXPECT_LT(std::abs(s.y), 0.03);
    // Afternoon: the west (−X). Southern midsummer noon at 45° S: the sun in the north (+Y).
    in.time = parse_utc("2026-03-20T17:00:00Z");
    EXPECT_LT(sun_direction(solar_position(in).blender_elevation_deg, solar_position(in).blender_rotation_deg).x, -0.95);
    in.latitude_deg = -45.0;
    in.time = parse_utc("2026-12-21T12:00:00Z");
    const SolarPosition south = solar_position(in);
    EXPECT_NEAR(south.azimuth_deg < 180.0 ? south.azimuth_deg : south.azimuth_deg - 360.0, 0.0, 2.0);
    EXPECT_NEAR(south.elevation_deg, 90.0 - 45.0 + 23.44, 0.3);
}

TEST(SolarPosition, DeltaTPolynomialsAreContinuousAndMatchTheirAnchors) {
    EXPECT_NEAR(delta_t_espenak_meeus(2000.0), 63.86, 1e-9);
    EXPECT_NEAR(delta_t_espenak_meeus(1950.0), 29.07, 1e-9);
    EXPECT_NEAR(delta_t_espenak_meeus(1900.0), -2.79, 1e-9);
    EXPECT_NEAR(delta_t_espenak_meeus(1975.0), 45.45, 1e-9);
    // Observed ΔT (IERS): 1990.0 56.86 s, 2003.8 64.5 s, 2010.0 66.07 s — the polynomials
    // follow them to about a second until 2005 and drift after (the 2005–2050 piece is an
    // extrapolation: 2020.0 gives 71.6 s for an observed 69.4 s).
    EXPECT_NEAR(delta_t_espenak_meeus(1990.0), 56.86, 0.5);
    EXPECT_NEAR(delta_t_espenak_meeus(2003.8), 64.5, 0.5);
    EXPECT_NEAR(delta_t_espenak_meeus(2010.0), 66.07, 1.0);
    EXPECT_NEAR(delta_t_espenak_meeus(2020.0), 69.4, 3.0);
    // Each piece meets the next (a mistyped coefficient would break this).
    for (double b : {-500.0, 500.0, 1600.0, 1700.0, 1800.0, 1860.0, 1900.0, 1920.0, 1941.0, 1961.0, 1986.0, 2005.0,
                     2050.0, 2150.0})
        EXPECT_NEAR(delta_t_espenak_meeus(b - 1e-9), delta_t_espenak_meeus(b + 1e-9), 1.0) << "year " << b;
    // Where the sun is barely depends on ΔT (it moves the ephemeris time, not the Earth's
    // rotation): 10 s moves it by < 0.0002°.
    SolarPositionInput in = paper_input();
    const SolarPosition a = solar_position(in);
    in.delta_t_s = 77.0;
    const SolarPosition b = solar_position(in);
    EXPECT_LT(std::abs(a.zenith_deg - b.zenith_deg) + std::abs(a.azimuth_deg - b.azimuth_deg), 2e-4);
    EXPECT_GT(std::abs(a.zenith_deg - b.zenith_deg) + std::abs(a.azimuth_deg - b.azimuth_deg), 1e-6);
    // The default ΔT is the polynomial's at the date.
    in.delta_t_s.reset();
    EXPECT_NEAR(solar_position(in).delta_t_s, delta_t_espenak_meeus(decimal_year(in.time)), 1e-12);
    EXPECT_NEAR(decimal_year(parse_utc("2003-10-17T19:30:30Z")), 2003.0 + (289.0 + 19.5 / 24 + 30.0 / 86400) / 365.0,
                1e-9);
}

TEST(SolarPosition, TimeParsing) {
    EXPECT_EQ(format_utc(parse_utc("2026-06-21T12:00:00Z")), "2026-06-21T12:00:00Z");
    EXPECT_EQ(format_utc(parse_utc("2026-06-21 12:00Z")), "2026-06-21T12:00:00Z");
    EXPECT_EQ(format_utc(parse_utc("2003-10-17T12:30:30-07:00")), "2003-10-17T19:30:30Z");
    EXPECT_EQ(format_utc(parse_utc("2026-01-01T01:00:00+02:00")), "2025-12-31T23:00:00Z");
    EXPECT_EQ(format_utc(parse_utc("2024-02-29T23:59:59.25+0000")), "2024-02-29T23:59:59.25Z");
    EXPECT_EQ(format_utc(parse_utc("1999-12-31T23:59:60Z")), "2000-01-01T00:00:00Z");  // a leap second
    EXPECT_NEAR(julian_day(parse_utc("2000-01-01T12:00:00Z")), 2451545.0, 1e-9);
    EXPECT_NEAR(julian_day(parse_utc("1970-01-01T00:00:00Z")), 2440587.5, 1e-9);
    EXPECT_EQ(format_utc(add_seconds(parse_utc("2026-06-21T23:50:00Z"), 1200.0)), "2026-06-22T00:10:00Z");
    EXPECT_DOUBLE_EQ(seconds_between(parse_utc("2026-06-21T23:50:00Z"), parse_utc("2026-06-22T00:10:00Z")), 1200.0);

    EXPECT_EQ(error_of([] { parse_utc("2026-13-01T00:00:00Z"); }),
              "time '2026-13-01T00:00:00Z': month 13 is not in [1, 12]");
    EXPECT_EQ(error_of([] { parse_utc("2026-02-29T00:00:00Z", "utc"); }),
              "utc '2026-02-29T00:00:00Z': day 29 does not exist in that month");
    EXPECT_NE(error_of([] { parse_utc("2026-06-21T12:00:00"); }).find("no time zone"), std::string::npos);
    EXPECT_NE(error_of([] { parse_utc("noon"); }).find("expected an ISO 8601 time"), std::string::npos);
    EXPECT_NE(error_of([] { parse_utc("2026-06-21T24:00:00Z"); }).find("hour 24 is not in [0, 23]"), std::string::npos);
    EXPECT_NE(error_of([] { parse_utc("7000-01-01T00:00:00Z"); }).find("year 7000 is outside [0, 6000]"),
              std::string::npos);
    EXPECT_NE(error_of([] { parse_utc("2026-06-21T12:00:00Zjunk"); }).find("expected"), std::string::npos);
}

TEST(SolarPosition, ErrorsNameFieldValueAndRange) {
    SolarPositionInput in;
    in.time = parse_utc("2026-06-21T12:00:00Z");
    in.latitude_deg = 91.0;
    EXPECT_EQ(error_of([&] { solar_position(in); }), "latitude_deg = 91: must be in [-90, 90] degrees");
    in.latitude_deg = 0.0;
    in.longitude_deg = -180.5;
    EXPECT_EQ(error_of([&] { solar_position(in); }),
              "longitude_deg = -180.5: must be in [-180, 180] degrees (east positive)");
    in.longitude_deg = NAN;
    EXPECT_NE(error_of([&] { solar_position(in); }).find("longitude_deg = nan"), std::string::npos);
    in.longitude_deg = 0.0;
    in.delta_t_s = 2e5;
    EXPECT_EQ(error_of([&] { solar_position(in); }),
              "delta_t_s = 200000: must be in [-100000, 100000] seconds (TT - UT1)");
    in.delta_t_s.reset();
    in.delta_ut1_s = 1.5;
    EXPECT_EQ(error_of([&] { solar_position(in); }), "delta_ut1_s = 1.5: must be in [-1, 1] seconds (UT1 - UTC)");
    in.delta_ut1_s = 0.0;
    in.refraction = true;
    in.pressure_mbar = -1.0;
    EXPECT_EQ(error_of([&] { solar_position(in); }), "pressure_mbar = -1: must be in (0, 5000] mbar");
    // fuzz_csv: eq. 42's 283 / (273 + T) is infinite at T = -273 (elevation inf) and flips sign below
    // (elevations of thousands of degrees near it): temperatures start at -120 °C.
    in.pressure_mbar = 1010.0;
    for (const double t : {-273.0, -272.9, -273.1, -120.0000001})
        EXPECT_EQ(error_of([&] {
                      in.temperature_c = t;
                      solar_position(in);
                  }).rfind("temperature_c = ", 0),
                  0u)
            << t;
    EXPECT_NE(error_of([&] { solar_position(in); }).find("must be in [-120, 1000) degrees Celsius"), std::string::npos);
    // At the bound with the highest pressure, the sun at the horizon's edge of the correction
    // (e0 = -0.83°, where it is largest): finite, a few degrees, the elevation within [-90, 90].
    {
        SolarPositionInput cold;
        cold.refraction = true;
        cold.pressure_mbar = 5000.0;
        cold.temperature_c = -120.0;
        for (int minute = 0; minute < 24 * 60; minute += 1) {
            cold.latitude_deg = 45.0;
            cold.longitude_deg = 10.0;
            cold.time = add_seconds(parse_utc("2026-06-21T00:00:00Z"), 60.0 * minute);
            const SolarPosition p = solar_position(cold);
            ASSERT_TRUE(std::isfinite(p.elevation_deg)) << minute;
            EXPECT_GE(p.elevation_deg, -90.0) << minute;
            EXPECT_LE(p.elevation_deg, 90.0) << minute;
            EXPECT_LE(p.refraction_deg, 6.0) << minute;
            EXPECT_GE(p.refraction_deg, -1e-3) << minute;
        }
    }
    // The poles and the date line are valid places.
    in = SolarPositionInput{};
    in.time = parse_utc("2026-06-21T12:00:00Z");
    in.latitude_deg = 90.0;
    in.longitude_deg = 180.0;
    const SolarPosition pole = solar_position(in);
    // At the pole the elevation is the topocentric declination: 3.6 h after the 2026 solstice,
    // the true obliquity (23.4379° with nutation) less the parallax in elevation, 0.0022°.
    // PyEphem gives 23.43565° for this place and time.
    EXPECT_NEAR(pole.elevation_deg, 23.43565, 0.0005);
}

// ---- Scene TOML: [sun] latitude_deg, longitude_deg, time ---------------------------------

// Over the earth preset (whose [sun] gives angles), as a user's file would be.
std::string scene_error(const std::string& text) {
    return error_of([&] { parse_scene_toml("preset = \"earth\"\n" + text, "t.toml"); });
}

TEST(SolarPositionScene, PlaceAndTimeResolveToTheAngles) {
    const Scene s = parse_scene_toml(
        "preset = \"earth\"\n[sun]\nlatitude_deg = 39.742476\nlongitude_deg = -105.1786\n"
        "time = \"2003-10-17T12:30:30-07:00\"\ndelta_t_s = 67\n",
        "t.toml");
    SolarPositionInput in = paper_input();
    in.refraction = false;
    in.elevation_m = 0.0;
    const SolarPosition p = solar_position(in);
    EXPECT_DOUBLE_EQ(s.sun.elevation_deg, p.elevation_deg);
    EXPECT_DOUBLE_EQ(s.sun.azimuth_deg, p.azimuth_deg);
    ASSERT_TRUE(s.sun.place.has_value());
    EXPECT_EQ(format_utc(s.sun.place->time), "2003-10-17T19:30:30Z");
    EXPECT_NEAR(s.sun.elevation_deg, 39.872, 0.001);  // the paper's e0 (elevation 0 m moves it < 1e-5°)
    // The preset's other [sun] fields are kept.
    EXPECT_DOUBLE_EQ(s.sun.angular_radius_deg, load_preset("earth").sun.angular_radius_deg);
    EXPECT_NE(scene_to_json(s).find("\"time\":\"2003-10-17T19:30:30Z\""), std::string::npos);
}

TEST(SolarPositionScene, BothFormsOrAnIncompletePlaceAreRefused) {
    const std::string both = scene_error(
        "[sun]\nelevation_deg = 10\nlatitude_deg = 10\nlongitude_deg = 0\ntime = \"2026-06-21T12:00:00Z\"\n");
    EXPECT_NE(both.find("sun.latitude_deg"), std::string::npos) << both;
    EXPECT_NE(both.find("sun.elevation_deg"), std::string::npos) << both;
    EXPECT_NE(both.find("not both"), std::string::npos) << both;
    const std::string incomplete = scene_error("[sun]\nlatitude_deg = 10\ntime = \"2026-06-21T12:00:00Z\"\n");
    EXPECT_NE(incomplete.find("sun.longitude_deg: missing"), std::string::npos) << incomplete;
    EXPECT_NE(incomplete.find("sun.latitude_deg is set"), std::string::npos) << incomplete;
    const std::string no_time = scene_error("[sun]\nlatitude_deg = 10\nlongitude_deg = 0\n");
    EXPECT_NE(no_time.find("sun.time: missing"), std::string::npos) << no_time;
    const std::string bad_lat =
        scene_error("[sun]\nlatitude_deg = 91\nlongitude_deg = 0\ntime = \"2026-06-21T12:00:00Z\"\n");
    EXPECT_NE(bad_lat.find("t.toml:3"), std::string::npos) << bad_lat;
    EXPECT_NE(bad_lat.find("sun.latitude_deg = 91: must be in [-90, 90]"), std::string::npos) << bad_lat;
    const std::string bad_time = scene_error("[sun]\nlatitude_deg = 1\nlongitude_deg = 0\ntime = \"2026-06-31T12Z\"\n");
    EXPECT_NE(bad_time.find("sun.time = \"2026-06-31T12Z\": expected an ISO 8601 time"), std::string::npos)
        << bad_time;
    const std::string bad_day =
        scene_error("[sun]\nlatitude_deg = 1\nlongitude_deg = 0\ntime = \"2026-06-31T12:00Z\"\n");
    EXPECT_NE(bad_day.find("sun.time = \"2026-06-31T12:00Z\": day 31 does not exist"), std::string::npos) << bad_day;
    const std::string not_string = scene_error("[sun]\nlatitude_deg = 1\nlongitude_deg = 0\ntime = 12\n");
    EXPECT_NE(not_string.find("sun.time = 12: must be a string"), std::string::npos) << not_string;
    // The angle form is unchanged.
    const Scene s = parse_scene_toml("preset = \"earth\"\n[sun]\nelevation_deg = 10\nazimuth_deg = 20\n", "t.toml");
    EXPECT_EQ(s.sun.elevation_deg, 10.0);
    EXPECT_EQ(s.sun.azimuth_deg, 20.0);
    EXPECT_FALSE(s.sun.place.has_value());
}

// ---- The lamp light the sequences' CSV carries ------------------------------------------

TEST(SolarPositionLamp, StrengthAndColourFollowTheSunlight) {
    Scene s = load_preset("earth");
    s.sun.elevation_deg = 30.0;
    const SunLight high = sun_light_at_observer(s);
    s.sun.elevation_deg = 3.0;
    const SunLight low = sun_light_at_observer(s);
    s.sun.elevation_deg = -5.0;
    const SunLight night = sun_light_at_observer(s);
    EXPECT_FALSE(high.below_horizon);
    EXPECT_TRUE(night.below_horizon);
    EXPECT_EQ(night.lamp_strength(), 0.0);
    EXPECT_GT(high.lamp_strength(), low.lamp_strength());
    // Strength × colour is the sunlight; the colour's largest channel is 1; the low sun is redder.
    const glm::dvec3 c = high.lamp_colour();
    EXPECT_NEAR(glm::length(c * high.lamp_strength() - high.irradiance_rgb), 0.0, 1e-12);
    EXPECT_DOUBLE_EQ(std::max({c.x, c.y, c.z}), 1.0);
    EXPECT_LT(low.lamp_colour().z / low.lamp_colour().x, c.z / c.x);
    // Transmitted <= top of the atmosphere, channel by channel.
    for (int k = 0; k < 3; ++k) EXPECT_LE(high.irradiance_rgb[k], high.irradiance_top_rgb[k]);
}

// ---- `airmass sun` -----------------------------------------------------------------------

using airmass::test::run_command;

TEST(SolarPositionCli, OnePointEqualsTheLibrary) {
    int status = 0;
    const std::string out = run_command(std::string(AIRMASS_CLI) +
                                            " sun --latitude 39.742476 --longitude -105.1786 --time "
                                            "2003-10-17T12:30:30-07:00 --delta-t 67 --site-elevation 1830.14 "
                                            "--refraction --pressure 820 --temperature 11",
                                        status);
    EXPECT_EQ(status, 0);
    const SolarPosition p = solar_position(paper_input());
    char expect[256];
    std::snprintf(expect, sizeof expect, "39.742476,-105.1786,2003-10-17T19:30:30Z,%.7f,%.7f,%.7f,%.7f\n",
                  p.elevation_deg, p.azimuth_deg, p.elevation_deg, p.azimuth_deg);
    EXPECT_EQ(out, std::string("latitude_deg,longitude_deg,utc,elevation_deg,azimuth_deg,blender_elevation_deg,"
                               "blender_rotation_deg\n") +
                       expect);
    EXPECT_NE(out.find(",39.88837"), std::string::npos);  // the paper's 90 − 50.11162
}

TEST(SolarPositionCli, RowsFromStandardInput) {
    int status = 0;
    const std::string out = run_command(
        "printf 'latitude_deg,longitude_deg,utc\\n# a comment\\n\\n0,0,2026-03-20T07:00:00Z\\n-45, 0 ,"
        "2026-12-21T12:00:00Z\\n' | " AIRMASS_CLI " sun",
        status);
    EXPECT_EQ(status, 0);
    ASSERT_EQ(std::count(out.begin(), out.end(), '\n'), 3) << out;
    EXPECT_EQ(out.substr(out.find('\n') + 1, 25), "0,0,2026-03-20T07:00:00Z,");
    EXPECT_NE(out.find("\n-45,0,2026-12-21T12:00:00Z,"), std::string::npos) << out;
}

TEST(SolarPositionCli, BadRowsAreNamedAndNothingIsPrinted) {
    int status = 0;
    std::string out = run_command("printf '0,0,2026-03-20T07:00:00Z\\n91,0,2026-03-20T07:00:00Z\\n' | " AIRMASS_CLI
                                  " sun 2>&1",
                                  status);
    EXPECT_NE(status, 0);
    EXPECT_EQ(out, "airmass: sun: line 2: latitude_deg = 91: must be in [-90, 90] degrees\n");
    out = run_command("printf '0,0,2026-03-20T07:00:00Z\\n0,0,2026-03-20T25:00:00Z\\n' | " AIRMASS_CLI " sun 2>&1",
                      status);
    EXPECT_NE(status, 0);
    EXPECT_EQ(out, "airmass: sun: line 2: utc '2026-03-20T25:00:00Z': hour 25 is not in [0, 23]\n");
    out = run_command("printf '0,x,2026-03-20T07:00:00Z\\n' | " AIRMASS_CLI " sun 2>&1", status);
    EXPECT_NE(status, 0);
    EXPECT_EQ(out, "airmass: sun: line 1: longitude_deg is not a finite number: 'x'\n");
    out = run_command("printf '0,0\\n' | " AIRMASS_CLI " sun 2>&1", status);
    EXPECT_NE(status, 0);
    EXPECT_NE(out.find("line 1: expected 3 comma-separated values (latitude_deg,longitude_deg,utc), got 2"),
              std::string::npos)
        << out;
    // Standard output stays empty on error (no partial rows).
    out = run_command("printf '0,0,2026-03-20T07:00:00Z\\n0,200,2026-03-20T07:00:00Z\\n' | " AIRMASS_CLI
                      " sun 2>/dev/null",
                      status);
    EXPECT_NE(status, 0);
    EXPECT_EQ(out, "");
    out = run_command(std::string(AIRMASS_CLI) + " sun --latitude 0 --longitude 0 --time 2026-06-21T12:00:00 2>&1",
                      status);
    EXPECT_NE(status, 0);
    EXPECT_NE(out.find("airmass: sun: --time '2026-06-21T12:00:00': no time zone"), std::string::npos) << out;
    out = run_command(std::string(AIRMASS_CLI) + " sun --latitude -95 --longitude 0 --time 2026-06-21T12:00Z 2>&1",
                      status);
    EXPECT_NE(status, 0);
    // Refused while the command line is read (plugin/cli/option_checks.cpp, the CLI sweep of
    // issue 17): the option is named in front of the library's words for its field.
    EXPECT_EQ(out, "airmass: sun: --latitude: latitude_deg = -95: must be in [-90, 90] degrees\n(`airmass sun --help` lists the options)\n");
    out = run_command(std::string(AIRMASS_CLI) + " sun --latitude 0 --longitude 0 --time 2026-06-21T12:00Z "
                                                 "--pressure 900 2>&1",
                      status);
    EXPECT_NE(status, 0);
    EXPECT_EQ(out, "airmass: sun: --pressure and --temperature apply with --refraction only\n");
}

}  // namespace
