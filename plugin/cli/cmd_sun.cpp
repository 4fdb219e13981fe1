// `airmass sun`: the sun's topocentric position for places and times (NREL's Solar Position
// Algorithm, solar_position.hpp; docs/sun.md).
//
//   airmass sun [ROWS.csv]                 rows latitude_deg,longitude_deg,utc (stdin without a file)
//   airmass sun --latitude D --longitude D --time 2026-06-21T12:00:00Z
//       [--delta-t S --delta-ut1 S --site-elevation M --refraction --pressure MBAR --temperature C]
//
// Writes latitude_deg,longitude_deg,utc,elevation_deg,azimuth_deg,blender_elevation_deg,
// blender_rotation_deg. Every row is computed before anything is printed, so a bad row gives
// an error naming its line and field and no output at all.
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "commands.hpp"
#include "csv.hpp"
#include "sun_options.hpp"

namespace airmass::cli {

namespace {

struct SunCommandOptions {
    std::string input;
    std::optional<double> latitude_deg, longitude_deg;
    std::string time;
    SunCliOptions sun;
};

std::string output_row(double lat, double lon, const UtcTime& t, const SolarPosition& p) {
    return format_place(lat) + "," + format_place(lon) + "," + format_utc(t) + "," + sun_angle_fields(p);
}

}  // namespace

void add_sun_command(CLI::App& app) {
    auto* cmd = app.add_subcommand(
        "sun", "The sun's topocentric elevation and azimuth (NREL SPA) for latitude,longitude,UTC rows, and the "
               "Blender Sky Texture angles for a scene with +Y north");
    auto o = std::make_shared<SunCommandOptions>();
    cmd->add_option("input", o->input, "CSV of latitude_deg,longitude_deg,utc rows  [default: standard input]");
    cmd->add_option("--latitude", o->latitude_deg, "One place: latitude in degrees, north positive")
        ->check(number_in(-90.0, 90.0, Ends::closed, "latitude_deg", "degrees"));
    cmd->add_option("--longitude", o->longitude_deg, "One place: longitude in degrees, east positive")
        ->check(number_in(-180.0, 180.0, Ends::closed, "longitude_deg", "degrees"));
    cmd->add_option("--time", o->time, "One moment: ISO 8601 UTC, e.g. 2026-06-21T12:00:00Z (or with an offset)");
    add_sun_options(cmd, o->sun, true);

    cmd->callback([o] {
        const bool single = o->latitude_deg || o->longitude_deg || !o->time.empty();
        std::vector<std::string> lines;
        if (single) {
            if (!o->input.empty())
                throw CliError("sun: give either an input file or --latitude/--longitude/--time, not both");
            if (!o->latitude_deg) throw CliError("sun: --latitude is required with --longitude/--time");
            if (!o->longitude_deg) throw CliError("sun: --longitude is required with --latitude/--time");
            if (o->time.empty()) throw CliError("sun: --time is required with --latitude/--longitude");
            try {
                const UtcTime t = parse_utc(o->time, "--time");
                const auto in = solar_input(o->sun, *o->latitude_deg, *o->longitude_deg, t, "sun");
                lines.push_back(output_row(*o->latitude_deg, *o->longitude_deg, t, solar_position(in)));
            } catch (const SolarPositionError& e) {
                throw CliError(std::string("sun: ") + e.what());
            }
        } else {
            std::ifstream file;
            if (!o->input.empty()) {
                file.open(o->input);
                if (!file) throw CliError("sun: " + o->input + ": cannot open the input file");
            }
            std::istream& in = o->input.empty() ? std::cin : file;
            const std::string where = o->input.empty() ? "sun: " : "sun: " + o->input + ": ";
            std::vector<SunRow> rows;
            try {
                rows = read_sun_rows(in);
            } catch (const CliError& e) {
                throw CliError(where + e.what());
            }
            if (in.bad()) throw CliError(where + "cannot read the input");
            for (const SunRow& row : rows) {
                try {
                    const auto input = solar_input(o->sun, row.latitude_deg, row.longitude_deg, row.time, "sun");
                    lines.push_back(output_row(row.latitude_deg, row.longitude_deg, row.time, solar_position(input)));
                } catch (const SolarPositionError& e) {
                    throw CliError(where + "line " + std::to_string(row.line) + ": " + e.what());
                }
            }
        }
        std::string out = "latitude_deg,longitude_deg,utc," + std::string(kSunAngleColumns) + "\n";
        for (const auto& l : lines) out += l + "\n";
        write_stdout(out, "sun");
    });
}

}  // namespace airmass::cli
