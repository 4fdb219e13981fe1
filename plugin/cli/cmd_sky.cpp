// `airmass sky`: render a scene's sky (single scattering + multiple scattering) to a 32-bit
// float EXR in Blender's equirectangular convention (docs/sky.md).
//
//   airmass sky (--preset NAME | SCENE.toml) -o sky.exr [--width W --height H --samples N
//       --chapman METHOD --sun-elevation DEG --sun-rotation DEG --altitude M --no-sun-disc
//       --basis rgb|spectral --wavelengths SPEC --hemisphere full|upper --threads N --quiet
//       --no-multiple --ms-mode orders|isotropic_lut --ms-orders K --ms-samples N --ms-table A,V,S,Z]
//
// The output is written atomically; Ctrl-C stops the render and leaves no file.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "airmass/chapman.hpp"
#include "airmass/image_io.hpp"
#include "airmass/multiple_scattering.hpp"
#include "airmass/progress.hpp"
#include "airmass/terminal.hpp"
#include "airmass/scene_io.hpp"
#include "airmass/sky.hpp"
#include "commands.hpp"
#include "ms_options.hpp"
#include "csv.hpp"

namespace airmass::cli {

namespace {

struct SkyOptions {
    std::string scene_path, preset, output;
    int width = 2048;
    std::optional<int> height;
    int samples = SkySettings{}.view_samples;
    std::string chapman = std::string(chapman_method_name(SkySettings{}.chapman));
    std::optional<double> sun_elevation_deg, sun_rotation_deg, altitude_m;
    bool no_sun_disc = false;
    std::string basis;  // "", "rgb", "spectral"
    std::string wavelengths;
    std::string hemisphere = "full";
    int threads = 0;
    int grid = -1;
    bool quiet = false;
    bool no_multiple = false;
    MsCliOptions ms;
};

double parse_number(const std::string& text, const std::string& what) {
    std::size_t used = 0;
    double v = 0;
    try {
        v = std::stod(text, &used);
    } catch (const std::exception&) {
        used = 0;
    }
    if (used != text.size() || !std::isfinite(v))
        throw CliError("sky: --wavelengths: '" + text + "' is not a number (" + what + ")");
    return v;
}

// --wavelengths: "N" (N samples evenly over 380–780 nm, Blender's range; 21 is Blender's grid),
// "FIRST:LAST:STEP" (nm), or a comma-separated list of nm. Strictly increasing, within
// [360, 830] nm (the CIE 1931 table).
std::vector<double> parse_wavelengths(const std::string& spec) {
    std::vector<double> out;
    if (spec.find(':') != std::string::npos) {
        std::vector<double> v;
        std::stringstream ss(spec);
        std::string part;
        while (std::getline(ss, part, ':')) v.push_back(parse_number(part, "FIRST:LAST:STEP"));
        if (v.size() != 3 || !(v[2] > 0) || !(v[1] >= v[0]))
            throw CliError("sky: --wavelengths '" + spec + "': expected FIRST:LAST:STEP with LAST >= FIRST, STEP > 0");
        const long n = std::lround(std::floor((v[1] - v[0]) / v[2] + 1e-9)) + 1;
        if (n > 100000) throw CliError("sky: --wavelengths '" + spec + "': more than 100000 samples");
        for (long i = 0; i < n; ++i) out.push_back(v[0] + v[2] * double(i));
    } else if (spec.find(',') != std::string::npos) {
        std::stringstream ss(spec);
        std::string part;
        while (std::getline(ss, part, ',')) out.push_back(parse_number(part, "a list of nm"));
    } else {
        const double n = parse_number(spec, "a count");
        if (n != std::floor(n) || n < 1 || n >= 360)
            throw CliError("sky: --wavelengths " + spec +
                           ": a bare number is a count of samples over 380-780 nm, an integer in [1, 359] (one "
                           "wavelength is written '" + spec + ",'; finer grids as FIRST:LAST:STEP)");
        if (n == 1) return {550.0};
        for (int i = 0; i < int(n); ++i) out.push_back(380.0 + 400.0 * i / (n - 1));
    }
    for (std::size_t i = 0; i < out.size(); ++i) {
        if (out[i] < 360.0 || out[i] > 830.0)
            throw CliError("sky: --wavelengths: " + format_g17(out[i]) + " nm is outside [360, 830] nm");
        if (i > 0 && !(out[i] > out[i - 1]))
            throw CliError("sky: --wavelengths: must be strictly increasing (" + format_g17(out[i - 1]) + ", " +
                           format_g17(out[i]) + ")");
    }
    return out;
}

// The scene and settings an `airmass sky`-style command line asks for.
void apply_sky_overrides(Scene& scene, const std::optional<double>& sun_elevation_deg,
                         const std::optional<double>& sun_rotation_deg, const std::optional<double>& altitude_m,
                         const std::string& basis, const std::string& wavelengths) {
    if (sun_elevation_deg) {
        if (!(*sun_elevation_deg >= -90.0 && *sun_elevation_deg <= 90.0))
            throw CliError("sky: --sun-elevation " + format_g17(*sun_elevation_deg) + ": must be in [-90, 90] degrees");
        scene.sun.elevation_deg = *sun_elevation_deg;
    }
    if (sun_rotation_deg) {
        if (!std::isfinite(*sun_rotation_deg) || std::abs(*sun_rotation_deg) > 1e6)
            throw CliError("sky: --sun-rotation " + format_g17(*sun_rotation_deg) + ": must be finite, |value| <= 1e6");
        // An angle: any number of turns means the same direction (as in Blender's node).
        scene.sun.azimuth_deg = std::fmod(*sun_rotation_deg, 360.0);
    }
    if (altitude_m) {
        if (!(*altitude_m >= 0.0 && *altitude_m <= 1e9))
            throw CliError("sky: --altitude " + format_g17(*altitude_m) + ": must be in [0, 1e9] metres");
        scene.observer.altitude_m = *altitude_m;
    }
    if (basis == "rgb") {
        if (!wavelengths.empty())
            throw CliError("sky: --wavelengths applies to --basis spectral, not rgb (615/535/445 nm fixed)");
        scene.basis.kind = SpectralBasis::Kind::rgb_schuler;
        scene.basis.wavelengths_nm.clear();
    } else if (basis == "spectral" || !wavelengths.empty()) {
        const bool was_spectral =
            scene.basis.kind == SpectralBasis::Kind::spectral && !scene.basis.wavelengths_nm.empty();
        scene.basis.kind = SpectralBasis::Kind::spectral;
        if (!wavelengths.empty()) scene.basis.wavelengths_nm = parse_wavelengths(wavelengths);
        else if (!was_spectral) scene.basis.wavelengths_nm = parse_wavelengths("360:830:10");  // Bruneton's 48
    }
}

}  // namespace

void add_sky_command(CLI::App& app) {
    auto* cmd = app.add_subcommand(
        "sky", "Render the sky (single + multiple scattering) to a 32-bit float EXR (Blender equirectangular, "
               "Nishita units)");
    auto o = std::make_shared<SkyOptions>();
    auto* scene_opt = cmd->add_option("scene", o->scene_path, "Scene file (TOML; docs/scene.md)");
    auto* preset_opt = cmd->add_option("--preset", o->preset, "Built-in scene by name (see `airmass sky --list-presets`)");
    scene_opt->excludes(preset_opt);
    auto list_presets = std::make_shared<bool>(false);
    cmd->add_flag("--list-presets", *list_presets, "Print the preset names and exit");
    cmd->add_option("-o,--output", o->output, "Output EXR path (written atomically)");
    cmd->add_option("--width", o->width, "Image width in pixels, 360°  [default 2048]");
    cmd->add_option("--height", o->height, "Image height in pixels, 180°  [default width/2]");
    cmd->add_option("--samples", o->samples, "Samples per scattering constituent along each view ray")
        ->capture_default_str();
    cmd->add_option("--chapman", o->chapman, "Chapman method for optical depths (airmass chapman --list-methods)")
        ->capture_default_str();
    cmd->add_option("--sun-elevation", o->sun_elevation_deg, "Sun elevation above the horizon, degrees [-90, 90]");
    cmd->add_option("--sun-rotation", o->sun_rotation_deg, "Sun rotation as Blender's Sky Texture: 0 → +Y, 90 → +X");
    cmd->add_option("--altitude", o->altitude_m, "Observer altitude above the surface, metres");
    cmd->add_flag("--no-sun-disc", o->no_sun_disc, "Leave out the solar disc");
    cmd->add_option("--basis", o->basis, "rgb (Schüler 615/535/445 nm) or spectral  [default: the scene's]")
        ->check(CLI::IsMember({"rgb", "spectral"}));
    cmd->add_option("--wavelengths", o->wavelengths,
                    "Spectral samples: N (evenly over 380-780 nm), FIRST:LAST:STEP, or a comma list (nm)");
    cmd->add_option("--hemisphere", o->hemisphere, "full, or upper: rows below the horizon are left 0, not computed")
        ->check(CLI::IsMember({"full", "upper"}))
        ->capture_default_str();
    cmd->add_option("--grid", o->grid,
                    "Sky grid: azimuth intervals over 0-180 deg, pixels interpolated (0: every pixel, -1: auto)")
        ->capture_default_str();
    cmd->add_option("--threads", o->threads, "Worker threads (0: all)")->capture_default_str();
    cmd->add_flag("--no-multiple", o->no_multiple, "Single scattering only (no multiple-scattering tables)");
    add_ms_options(cmd, o->ms);
    cmd->add_flag("-q,--quiet", o->quiet, "No progress bar or summary line");

    cmd->callback([o, list_presets] {
        if (*list_presets) {
            for (const auto& n : preset_names()) std::printf("%s\n", n.c_str());
            return;
        }
        if (o->scene_path.empty() == o->preset.empty())
            throw CliError("sky: give a scene file or --preset NAME (one of them)");
        if (o->output.empty()) throw CliError("sky: -o/--output is required");
        Scene scene = o->preset.empty() ? load_scene_file(o->scene_path) : load_preset(o->preset);
        apply_sky_overrides(scene, o->sun_elevation_deg, o->sun_rotation_deg, o->altitude_m, o->basis, o->wavelengths);

        SkySettings settings;
        settings.width = o->width;
        settings.height = o->height ? *o->height : std::max(2, o->width / 2);
        settings.view_samples = o->samples;
        const auto method = chapman_method_from_name(o->chapman);
        if (!method) throw CliError("sky: unknown --chapman '" + o->chapman + "' (see `airmass chapman --list-methods`)");
        settings.chapman = *method;
        settings.sun_disc = !o->no_sun_disc;
        settings.region = o->hemisphere == "upper" ? SkyRegion::upper : SkyRegion::full;
        settings.threads = o->threads;
        settings.grid = o->grid;
        settings.multiple_scattering = !o->no_multiple;
        apply_ms_options("sky", o->ms, settings.multiple, settings.multiple_samples, kSkyMaxMultipleSamples);
        try {
            validate(settings);
        } catch (const SkyError& e) {
            throw CliError(std::string("sky: --") + e.what());
        }
        validate(scene);
        // Fail on an unwritable destination now, not after the render.
        check_exr_destination(o->output);

        CancelFlag cancel;
        InterruptGuard guard(cancel);
        const auto t0 = std::chrono::steady_clock::now();
        FloatImage image;
        {
            ProgressBar bar("sky " + std::to_string(settings.width) + "x" + std::to_string(settings.height),
                            0, stderr_is_terminal() && !o->quiet);
            RenderHooks hooks;
            hooks.cancel = &cancel;
            hooks.work_done = [&bar](std::size_t n, std::size_t total) {
                bar.set_total(total);
                bar.advance(n);
            };
            image = render_sky(scene, settings, hooks);
        }
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        // Past this point the file is either not started or complete: a cancel that arrives
        // during the (short) write is honoured only before it begins.
        if (cancel.requested()) throw Cancelled("sky: cancelled; no file written");
        write_exr_atomic(o->output, image, sky_metadata(scene, settings));
        if (!o->quiet)
            std::fprintf(stderr, "sky: wrote %s (%dx%d, %s, %s, %.4f s render)\n", o->output.c_str(),
                         settings.width, settings.height,
                         scene.basis.kind == SpectralBasis::Kind::rgb_schuler
                             ? "rgb-schuler"
                             : (std::to_string(scene.basis.wavelengths_nm.size()) + " wavelengths").c_str(),
                         settings.multiple_scattering ? "single + multiple scattering" : "single scattering only",
                         seconds);
    });
}

}  // namespace airmass::cli
