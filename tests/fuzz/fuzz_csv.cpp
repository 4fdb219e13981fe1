// libFuzzer target: the CSV readers on stdin of `airmass chapman` and `airmass eval`
// (plugin/cli/csv.cpp: read_chapman_rows, read_eval_rows, read_numeric_rows), called without the
// CLI. The first byte picks the reader; the rest is stdin. Rows that pass are evaluated as the
// commands do (at most 16 rows): Ch(x, chi) in float and double (ln Ch never NaN), and one earth
// view ray per eval row (transmittance and radiance finite and >= 0). Also parse_number_list
// (the --wavelengths / --box option lists).
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
            if (std::isnan(ln_ch))
                std::fprintf(stderr, "%.*s: x = %.17g, chi_deg = %.17g\n", int(m.name.size()), m.name.data(),
                             rows[k].values[0], rows[k].values[1]);
            fuzz::require(!std::isnan(ln_ch), "ln Ch is NaN");
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

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size < 1 || size > 16 * 1024) return -1;
    const uint8_t which = data[0] % 3;
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
