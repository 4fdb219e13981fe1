// `airmass eval`: radiance (single + multiple scattering) and transmittance along view rays.
//
//   airmass eval (--preset NAME | SCENE.toml) [--wavelengths 680,550,440]
//       [--solar-irradiance W_M2_NM] [--samples N] [--chapman METHOD] [--sun-disc]
//       [--no-ground] [--reference] [--threads N]
//       [--no-multiple] [--ms-mode orders|isotropic_lut] [--ms-orders K] [--ms-samples N]
//       [--ms-table A,V,S,Z] [--ms-columns]
//   in:  altitude_m,view_zenith_deg,sun_zenith_deg,azimuth_deg   (stdin; header allowed)
//   out: altitude_m,view_zenith_deg,sun_zenith_deg,azimuth_deg,wavelength_nm,
//        transmittance,radiance_rayleigh,radiance_mie,radiance    (one row per wavelength)
//        [,multiple_rayleigh,multiple_mie,multiple]              (with --ms-columns)
//
// radiance = radiance_rayleigh + radiance_mie (single-scattering in-scatter) + the directly
// lit ground + the sun disc + multiple (multiple_scattering.hpp: in-scatter of the
// multiply-scattered light over the whole view segment, plus the sky-lit ground), the last
// unless --no-multiple. The tables are precomputed once per invocation at the requested
// wavelengths. The column set is the same with and without multiple scattering, so
// existing readers keep working; --ms-columns appends the multiple-scattering parts.
//
// The observer is at altitude_m above the surface; the view direction has zenith angle
// view_zenith_deg and the sun zenith angle sun_zenith_deg, azimuth_deg apart. transmittance
// is along the view ray to space or to the ground; radiances are W m⁻² sr⁻¹ nm⁻¹ for the
// scene's top-of-atmosphere solar spectrum, or for --solar-irradiance if given (1 gives
// radiance per unit irradiance). Equations and accuracy: docs/evaluation.md.
// --reference evaluates the single scattering by brute-force nested quadrature instead (slow;
// for checks); the multiple scattering, if on, is the tables' as always.
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "airmass/evaluator.hpp"
#include "airmass/atmosphere.hpp"
#include "airmass/geometry.hpp"
#include "airmass/multiple_scattering.hpp"
#include "airmass/scene_io.hpp"
#include "airmass/single_scattering.hpp"
#include "commands.hpp"
#include "csv.hpp"
#include "ms_options.hpp"

namespace airmass::cli {

namespace {

struct EvalOptions {
    std::string scene_path, preset;
    std::string wavelengths = "680,550,440";
    std::optional<double> solar_irradiance;
    int samples = EvalSettings{}.view_samples;
    std::string chapman = std::string(chapman_method_name(EvalSettings{}.chapman));
    bool sun_disc = false;
    bool no_ground = false;
    bool reference = false;
    int threads = 0;
    bool no_multiple = false;
    MsCliOptions ms;  // --ms-samples: MultipleScatteringOptions::view_samples, as `sky` and `render`
    bool ms_columns = false;
};

std::vector<double> parse_wavelength_list(const std::string& spec) {
    return parse_number_list(spec, "eval: --wavelengths", "a wavelength in nm (a number in (0, 1e6))",
                             [](double v) { return v > 0.0 && v < 1e6; });
}

}  // namespace

void add_eval_command(CLI::App& app) {
    auto opt = std::make_shared<EvalOptions>();
    auto* cmd = app.add_subcommand(
        "eval", "Transmittance and radiance (single + multiple scattering) for altitude_m,view_zenith_deg,"
                "sun_zenith_deg,azimuth_deg rows read from stdin");
    cmd->add_option("scene", opt->scene_path, "Scene file (.toml)");
    cmd->add_option("--preset", opt->preset, "Built-in scene by name (see docs/scene.md)");
    cmd->add_option("--wavelengths", opt->wavelengths, "Comma-separated wavelengths in nm")->capture_default_str();
    cmd->add_option("--solar-irradiance", opt->solar_irradiance,
                    "Constant top-of-atmosphere irradiance in W m^-2 nm^-1 (default: the scene's spectrum)")
        ->check(number_in(0.0, 1e30));
    cmd->add_option("--samples", opt->samples, "View-ray samples per scattering constituent")
        ->check(int_in(1, 1000000))
        ->capture_default_str();
    cmd->add_option("--chapman", opt->chapman, "Chapman method (airmass chapman --list-methods)")
        ->capture_default_str();
    cmd->add_flag("--sun-disc", opt->sun_disc, "Add the solar disc to rays that look into it");
    cmd->add_flag("--no-ground", opt->no_ground, "Do not add the sunlit ground's radiance");
    cmd->add_flag("--reference", opt->reference, "Brute-force nested quadrature instead (slow)");
    cmd->add_option("--threads", opt->threads, "Worker threads (0: all cores)")
        ->check(int_in(0, 4096))
        ->capture_default_str();
    cmd->add_flag("--no-multiple", opt->no_multiple, "Single scattering only (no multiple-scattering tables)");
    add_ms_options(cmd, opt->ms, 100000);
    cmd->add_flag("--ms-columns", opt->ms_columns,
                  "Append the columns multiple_rayleigh,multiple_mie,multiple (the multiple-scattering parts)");
    cmd->callback([opt] {
        if (opt->scene_path.empty() == opt->preset.empty())
            throw CliError("eval: give exactly one of SCENE.toml or --preset NAME");
        const Scene scene = opt->preset.empty() ? load_scene_file(opt->scene_path) : load_preset(opt->preset);
        const auto method = chapman_method_from_name(opt->chapman);
        if (!method) throw CliError("eval: unknown --chapman '" + opt->chapman + "' (see airmass chapman --list-methods)");
        if (opt->samples < 1 || opt->samples > 1000000)
            throw CliError("eval: --samples " + std::to_string(opt->samples) + ": must be in [1, 1000000]");
        if (opt->threads < 0 || opt->threads > 4096) throw CliError("eval: --threads must be in [0, 4096]");
        MultipleScatteringOptions multiple;
        apply_ms_options("eval", opt->ms, multiple, 100000);
        multiple.enabled = !opt->no_multiple;
        const std::vector<double> wavelengths = parse_wavelength_list(opt->wavelengths);
        EvalSettings settings;
        settings.view_samples = opt->samples;
        settings.chapman = opt->reference ? ChapmanMethod::exact : *method;
        settings.sun_disc = opt->sun_disc;
        settings.ground = !opt->no_ground;
        Atmosphere atm = compile_atmosphere(scene, wavelengths, settings);
        if (opt->solar_irradiance) {
            if (!(std::isfinite(*opt->solar_irradiance) && *opt->solar_irradiance >= 0.0))
                throw CliError("eval: --solar-irradiance " + format_g17(*opt->solar_irradiance) +
                               ": must be finite and >= 0");
            set_constant_irradiance(atm, *opt->solar_irradiance);
        }

        const auto rows = read_eval_rows(std::cin);

        const std::size_t nw = wavelengths.size();
        const std::size_t n = rows.size() * nw;
        std::vector<double> T(n), R(n), M(n), L(n), MR(n, 0.0), MM(n, 0.0), MT(n, 0.0);
        std::optional<tbb::global_control> limit;
        if (opt->threads > 0) limit.emplace(tbb::global_control::max_allowed_parallelism, opt->threads);
        // The evaluator: the tables once for all rows (they hold light per unit irradiance:
        // independent of --solar-irradiance, which is applied per ray).
        if (rows.empty()) multiple.enabled = false;
        const Evaluator evaluator = make_evaluator(std::move(atm), multiple, opt->threads);
        const auto evaluate = [&](std::size_t k) {
            const auto& v = rows[k].values;
            const ViewRay ray{v[0], direction_from_zenith_azimuth_deg<double>(v[1], 0.0),
                              direction_from_zenith_azimuth_deg<double>(v[2], v[3])};
            const auto part = [&](std::vector<double>& x) { return std::span(x).subspan(k * nw, nw); };
            const RadianceOut out{part(T), part(R), part(M), part(L)};
            const MsRadianceOut ms_out{part(MR), part(MM), part(MT)};
            if (!opt->reference) return evaluator.radiance(ray, out, &ms_out);
            // The brute-force reference of single scattering, plus the same tables' part.
            single_scattering_reference(scene, evaluator.atmosphere(), ray, out);
            if (!evaluator.tables()) return;
            multiple_scattering_radiance(evaluator.atmosphere(), *evaluator.tables(), ray, ms_out,
                                         multiple.view_samples);
            for (std::size_t w = 0; w < nw; ++w) L[k * nw + w] += MT[k * nw + w];
        };
        tbb::parallel_for(std::size_t(0), rows.size(), evaluate);

        std::string out =
            "altitude_m,view_zenith_deg,sun_zenith_deg,azimuth_deg,wavelength_nm,transmittance,radiance_rayleigh,"
            "radiance_mie,radiance";
        out += opt->ms_columns ? ",multiple_rayleigh,multiple_mie,multiple\n" : "\n";
        for (std::size_t k = 0; k < rows.size(); ++k) {
            const auto& v = rows[k].values;
            const std::string geometry =
                format_g17(v[0]) + "," + format_g17(v[1]) + "," + format_g17(v[2]) + "," + format_g17(v[3]) + ",";
            for (std::size_t w = 0; w < nw; ++w) {
                const std::size_t i = k * nw + w;
                out += geometry + format_g17(wavelengths[w]) + "," + format_g17(T[i]) + "," + format_g17(R[i]) + "," +
                       format_g17(M[i]) + "," + format_g17(L[i]);
                if (opt->ms_columns)
                    out += "," + format_g17(MR[i]) + "," + format_g17(MM[i]) + "," + format_g17(MT[i]);
                out += "\n";
            }
        }
        write_stdout(out, "eval");
    });
}

}  // namespace airmass::cli
