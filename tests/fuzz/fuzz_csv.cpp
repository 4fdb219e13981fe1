// libFuzzer target: the CSV readers on stdin of `airmass chapman`, `airmass eval` and `airmass sun`
// (plugin/cli/csv.cpp: read_chapman_rows, read_eval_rows, read_sun_rows), called without the
// CLI. The first byte picks the reader (byte % 4; for sun, byte / 4 picks the options); the rest
// is stdin. Rows that pass are evaluated as the commands do (at most 16 rows): Ch(x, chi) in float
// and double (ln Ch finite), one earth view ray per eval row (transmittance and radiance finite
// and >= 0), the sun's position per sun row (solar_input + solar_position as cmd_sun.cpp: only
// SolarPositionError or CliError, else finite angles in range, and the time as printed reads
// back within 1 ms). Also parse_number_list (the --wavelengths / --box option lists).
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "airmass/atmosphere.hpp"
#include "airmass/chapman.hpp"
#include "airmass/scene_io.hpp"
#include "airmass/single_scattering.hpp"
#include "commands.hpp"
#include "csv.hpp"
#include "fuzz_common.hpp"
#include "sun_options.hpp"

namespace {

using namespace airmass;
using airmass::cli::CliError;
using airmass::cli::NumericRow;

template <class T>
void chapman_rows(const std::vector<NumericRow>& rows) {
    for (std::size_t k = 0; k < rows.size() && k < 16; ++k) {
        const T x = static_cast<T>(rows[k].values[0]);
        const auto chi = ZenithAngle<T>::from_degrees(rows[k].values[1]);
        for (const auto& m : chapman_methods()) {
            const auto s = chapman_scaled(m.method, x, chi);
            const double ln_ch = std::log(static_cast<double>(s.mantissa)) + static_cast<double>(s.log_scale);
            // The published approximations are reproduced as their authors wrote them, failures
            // included (Schüler 2012 goes negative below the horizon at small x: that is what the
            // reports measure); only UB and crashes count for them. The library's own methods,
            // `airmass` (the default) and `exact`, must give a number.
            if (m.method != ChapmanMethod::airmass && m.method != ChapmanMethod::exact) continue;
            // Ch >= 1 over the horizon and larger below: ln Ch is a finite number (the exact
            // method's Ch = 0, ln Ch = -inf, for x above 1e200 passed a NaN-only check; fix 21).
            if (!std::isfinite(ln_ch))
                std::fprintf(stderr, "%.*s: x = %.17g, chi_deg = %.17g\n", int(m.name.size()), m.name.data(),
                             rows[k].values[0], rows[k].values[1]);
            fuzz::require(std::isfinite(ln_ch), "ln Ch is not finite");
            const double ch = static_cast<double>(chapman(m.method, x, chi));
            fuzz::require(!std::isnan(ch) && ch >= 0.0, "Ch is NaN or negative");
        }
    }
}

void eval_rows(const std::vector<NumericRow>& rows) {
    static const Atmosphere atm = [] {
        const double wl[] = {680.0, 550.0, 440.0};
        EvalSettings s;
        s.view_samples = 8;
        return compile_atmosphere(load_preset("earth"), wl, s);
    }();
    for (std::size_t k = 0; k < rows.size() && k < 16; ++k) {
        const auto& v = rows[k].values;
        const ViewRay ray{v[0], direction_from_zenith_azimuth_deg<double>(v[1], 0.0),
                          direction_from_zenith_azimuth_deg<double>(v[2], v[3])};
        double T[3], R[3], M[3], L[3];
        single_scattering(atm, ray, RadianceOut{T, R, M, L});
        fuzz::require_finite_non_negative<double>(T, "transmittance");
        fuzz::require_finite_non_negative<double>(R, "radiance_rayleigh");
        fuzz::require_finite_non_negative<double>(M, "radiance_mie");
        fuzz::require_finite_non_negative<double>(L, "radiance");
    }
}

// `airmass sun`'s options from the bits of `bits` (the first byte / 4): each at a typical or an
// extreme accepted value; --pressure/--temperature without --refraction is the command's error.
cli::SunCliOptions sun_options(unsigned bits) {
    cli::SunCliOptions o;
    o.refraction = bits & 1;
    if (bits & 2) o.site_elevation_m = (bits & 32) ? 1e7 : -10000.0;
    if (bits & 4) o.delta_t_s = (bits & 32) ? kMaxAbsDeltaT : -kMaxAbsDeltaT;
    if (bits & 8) o.delta_ut1_s = (bits & 32) ? kMaxAbsDeltaUt1 : -kMaxAbsDeltaUt1;
    if (bits & 16) {
        if (bits & 8) {  // the coldest accepted air at the highest pressure: the largest correction
            o.pressure_mbar = 5000.0;
            o.temperature_c = -120.0;
        } else {  // -273: refused since fix 20 (it gave an infinite elevation)
            o.pressure_mbar = (bits & 32) ? 5000.0 : 1e-6;
            o.temperature_c = (bits & 32) ? 999.0 : -273.0;
        }
    }
    return o;
}

void sun_rows(const std::vector<cli::SunRow>& rows, const cli::SunCliOptions& options) {
    for (std::size_t k = 0; k < rows.size() && k < 16; ++k) {
        const auto& r = rows[k];
        SolarPosition p;
        try {
            p = solar_position(cli::solar_input(options, r.latitude_deg, r.longitude_deg, r.time, "sun"));
        } catch (const SolarPositionError& e) {
            fuzz::require(e.what()[0] != '\0', "SolarPositionError with an empty message");
            continue;
        }
        const double angles[] = {p.elevation_deg, p.azimuth_deg, p.blender_elevation_deg, p.blender_rotation_deg};
        for (double a : angles) fuzz::require(std::isfinite(a), "sun angle not finite");
        if (!(p.elevation_deg >= -90.0 && p.elevation_deg <= 90.0 && p.azimuth_deg >= 0.0 && p.azimuth_deg <= 360.0))
            std::fprintf(stderr, "lat %.17g lon %.17g: elevation %.17g azimuth %.17g\n", r.latitude_deg,
                         r.longitude_deg, p.elevation_deg, p.azimuth_deg);
        fuzz::require(p.elevation_deg >= -90.0 && p.elevation_deg <= 90.0, "sun elevation_deg outside [-90, 90]");
        fuzz::require(p.azimuth_deg >= 0.0 && p.azimuth_deg <= 360.0, "sun azimuth_deg outside [0, 360]");
        // The row as the command prints it; its time reads back within the printed millisecond.
        const std::string utc = format_utc(r.time);
        const std::string line = cli::format_place(r.latitude_deg) + "," + cli::format_place(r.longitude_deg) + "," +
                                 utc + "," + cli::sun_angle_fields(p);
        fuzz::require(line.find("nan") == std::string::npos && line.find("inf") == std::string::npos,
                      "sun output row with nan/inf");
        std::string why;
        const auto back = try_parse_utc(utc, &why);
        if (!back) std::fprintf(stderr, "format_utc gave '%s': %s\n", utc.c_str(), why.c_str());
        fuzz::require(back.has_value(), "the printed utc does not read back");
        fuzz::require(std::abs(seconds_between(r.time, *back)) <= 0.0005 + 1e-9, "the printed utc is off by > 0.5 ms");
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size < 1 || size > 16 * 1024) return -1;
    // byte % 4 keeps the corpus's '0', '1', '2' (48, 49, 50) on chapman, eval and lists.
    const uint8_t which = data[0] % 4;
    std::istringstream in(std::string(reinterpret_cast<const char*>(data) + 1, size - 1));
    try {
        if (which == 0) {
            const auto rows = cli::read_chapman_rows(in);
            chapman_rows<double>(rows);
            in.clear();
            in.seekg(0);
            chapman_rows<float>(cli::read_chapman_rows(in, true));  // --precision float
        } else if (which == 1) {
            eval_rows(cli::read_eval_rows(in));
        } else if (which == 3) {
            const auto options = sun_options(data[0] / 4u);
            sun_rows(cli::read_sun_rows(in), options);
        } else {
            const auto values = cli::parse_number_list(in.str(), "fuzz: --list", "a finite number");
            fuzz::require(!values.empty(), "empty list accepted");
            for (double v : values) fuzz::require(std::isfinite(v), "non-finite list value");
        }
    } catch (const CliError& e) {
        fuzz::require(e.what()[0] != '\0', "CliError with an empty message");
    }
    return 0;
}
