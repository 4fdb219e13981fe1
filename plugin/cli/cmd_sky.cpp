// `airmass sky`: render a scene's sky (single scattering + multiple scattering) to a 32-bit
// float EXR in Blender's equirectangular convention (docs/sky.md).
//
//   airmass sky (--preset NAME | SCENE.toml) -o sky.exr [--width W --height H --samples N
//       --chapman METHOD --sun-elevation DEG --sun-rotation DEG --altitude-km KM --no-sun-disc
//       --basis rgb|spectral --wavelengths SPEC --hemisphere full|upper --threads N --quiet
//       --no-multiple --ms-mode orders|isotropic_lut --ms-orders K --ms-samples N --ms-table A,V,S,Z]
//
// The output is written atomically; Ctrl-C stops the render and leaves no file.
//
// Sequences (docs/sun.md): --time-range START,END --fps RATE [--frames A-B] [--latitude D
// --longitude D] [--delta-t S] with -o out/sky_####.exr renders frame k (1-based) at
// START + (k − 1)/RATE, the sun from the Solar Position Algorithm at the scene's place
// ([sun] latitude_deg/longitude_deg) or the one given, and writes a CSV of the frames' sun
// angles and Sun-lamp strength/colour once every frame is written. The multiple-scattering
// tables are computed once for all frames. --frames A-B renders only those frames of the
// sequence (a shard: shards on different machines make the same files as one run).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>


#include "airmass/chapman.hpp"
#include "airmass/atomic_file.hpp"
#include "airmass/image_io.hpp"
#include "airmass/multiple_scattering.hpp"
#include "airmass/progress.hpp"
#include "airmass/terminal.hpp"
#include "airmass/scene_io.hpp"
#include "airmass/sky.hpp"
#include "airmass/solar_position.hpp"
#include "airmass/sun_light.hpp"
#include "commands.hpp"
#include "sun_options.hpp"
#include "ms_options.hpp"
#include "csv.hpp"

namespace airmass::cli {

namespace {

struct SkyOptions {
    std::string scene_path, preset, output;
    int width = 2048;
    std::optional<int> height;
    int samples = SkySettings{}.view.view_samples;
    std::string chapman = std::string(chapman_method_name(SkySettings{}.view.chapman));
    std::optional<double> sun_elevation_deg, sun_rotation_deg, altitude_km;
    bool no_sun_disc = false;
    std::string basis;  // "", "rgb", "spectral"
    std::string wavelengths;
    std::string hemisphere = "full";
    std::string exr_compression = exr_compression_name(kDefaultExrCompression);
    int threads = 0;
    int grid = -1;
    bool quiet = false;
    bool no_multiple = false;
    int ms_grid = kSkyDefaultMultipleGrid;
    bool no_refine = false;
    MsCliOptions ms;
    // sequences
    std::string time_range, fps, frames, frames_csv;
    std::optional<double> latitude_deg, longitude_deg;
    SunCliOptions sun;
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
                         const std::optional<double>& sun_rotation_deg, const std::optional<double>& altitude_km,
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
    if (altitude_km) {
        if (!(*altitude_km >= 0.0 && *altitude_km <= 1e6))
            throw CliError("sky: --altitude-km " + format_g17(*altitude_km) + ": must be in [0, 1e6] km");
        scene.observer.altitude_m = *altitude_km * 1000.0;
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

// ---- Sequences ------------------------------------------------------------------------

struct Sequence {
    UtcTime start;
    double step_s = 0.0;  // seconds between frames
    int count = 0;        // frames in the whole sequence
    int first = 1, last = 0;  // the frames this run renders (1-based, inclusive)
};

// --fps: a positive number or a fraction A/B ("1/600": one frame per ten minutes); returns
// the seconds between frames.
double parse_frame_step(const std::string& text) {
    const auto slash = text.find('/');
    double a = 0.0, b = 1.0;
    const bool ok = slash == std::string::npos
                        ? parse_finite_number(text, a)
                        : parse_finite_number(text.substr(0, slash), a) && parse_finite_number(text.substr(slash + 1), b);
    if (!ok || !(a > 0.0) || !(b > 0.0) || !(b / a <= 1e9) || !(b / a >= 1e-6))
        throw CliError("sky: --fps '" + text +
                       "': must be a positive number of frames per second of solar time, or a fraction A/B "
                       "(1/600 = one frame per 10 minutes); between 1e-9 and 1e6 frames per second");
    return b / a;
}

Sequence parse_sequence(const SkyOptions& o) {
    Sequence q;
    const auto comma = o.time_range.find(',');
    if (comma == std::string::npos)
        throw CliError("sky: --time-range '" + o.time_range + "': expected START,END (ISO 8601 UTC times)");
    UtcTime end;
    try {
        q.start = parse_utc(o.time_range.substr(0, comma), "--time-range START");
        end = parse_utc(o.time_range.substr(comma + 1), "--time-range END");
    } catch (const SolarPositionError& e) {
        throw CliError(std::string("sky: ") + e.what());
    }
    const double span = seconds_between(q.start, end);
    if (!(span >= 0.0)) throw CliError("sky: --time-range '" + o.time_range + "': END is before START");
    if (o.fps.empty()) throw CliError("sky: --time-range needs --fps (frames per second of solar time, e.g. 1/600)");
    q.step_s = parse_frame_step(o.fps);
    const double n = std::floor(span / q.step_s + 1e-9) + 1.0;
    if (n > 1e6) throw CliError("sky: --time-range with --fps " + o.fps + " makes more than 1000000 frames");
    q.count = int(n);
    q.first = 1;
    q.last = q.count;
    if (!o.frames.empty()) {
        const auto dash = o.frames.find('-');
        double a = 0, b = 0;
        const bool ok = dash == std::string::npos
                            ? parse_finite_number(o.frames, a) && (b = a, true)
                            : parse_finite_number(o.frames.substr(0, dash), a) &&
                                  parse_finite_number(o.frames.substr(dash + 1), b);
        if (!ok || a != std::floor(a) || b != std::floor(b) || a < 1 || b < a || b > q.count)
            throw CliError("sky: --frames '" + o.frames + "': expected A-B with 1 <= A <= B <= " +
                           std::to_string(q.count) + " (the sequence's frame count)");
        q.first = int(a);
        q.last = int(b);
    }
    return q;
}

// `pattern` with its run of '#' replaced by the frame number, zero-padded to the run's width.
std::string frame_path(const std::string& pattern, int frame) {
    const auto begin = pattern.find('#');
    const auto end = pattern.find_first_not_of('#', begin);
    const std::size_t width = (end == std::string::npos ? pattern.size() : end) - begin;
    std::string number = std::to_string(frame);
    if (number.size() < width) number.insert(0, width - number.size(), '0');
    return pattern.substr(0, begin) + number + (end == std::string::npos ? "" : pattern.substr(end));
}

// The CSV beside the frames: "out/sky_####.exr" → "out/sky.csv" (whole sequence) or
// "out/sky_0004-0006.csv" (a shard), so shards in one folder do not overwrite each other.
std::string default_csv_path(const std::string& pattern, const Sequence& q) {
    std::filesystem::path p(pattern);
    std::string stem = p.stem().string();
    const auto begin = stem.find('#');
    std::string base = stem;
    if (begin != std::string::npos) {
        const auto end = stem.find_first_not_of('#', begin);
        std::size_t cut = begin;
        if (cut > 0 && (stem[cut - 1] == '_' || stem[cut - 1] == '-' || stem[cut - 1] == '.')) --cut;
        base = stem.substr(0, cut) + (end == std::string::npos ? "" : stem.substr(end));
    }
    if (base.empty()) base = "frames";
    if (q.first != 1 || q.last != q.count)
        base += "_" + frame_path(std::string(4, '#'), q.first) + "-" + frame_path(std::string(4, '#'), q.last);
    return (p.parent_path() / (base + ".csv")).string();
}

void render_sequence(const SkyOptions& o, const Scene& base, const SkySettings& settings) {
    if (o.sun_elevation_deg || o.sun_rotation_deg)
        throw CliError("sky: --time-range takes the sun from the place and time; drop --sun-elevation/--sun-rotation");
    if (o.latitude_deg.has_value() != o.longitude_deg.has_value())
        throw CliError("sky: give --latitude and --longitude together");
    if (!o.latitude_deg && !base.sun.place)
        throw CliError("sky: --time-range needs a place: --latitude/--longitude, or [sun] latitude_deg/longitude_deg/"
                       "time in the scene");
    if (o.output.find('#') == std::string::npos)
        throw CliError("sky: -o '" + o.output + "': a sequence's output must contain #### for the frame number "
                       "(e.g. out/sky_####.exr)");
    const Sequence q = parse_sequence(o);
    const double lat = o.latitude_deg ? *o.latitude_deg : base.sun.place->latitude_deg;
    const double lon = o.longitude_deg ? *o.longitude_deg : base.sun.place->longitude_deg;
    SunCliOptions sun = o.sun;
    if (!sun.delta_t_s && base.sun.place && !o.latitude_deg) sun.delta_t_s = base.sun.place->delta_t_s;
    const std::string csv_path = o.frames_csv.empty() ? default_csv_path(o.output, q) : o.frames_csv;

    // Every frame's sun first: a bad place or time fails before any rendering.
    struct Frame {
        int number;
        UtcTime time;
        SolarPosition position;
        std::string path;
    };
    std::vector<Frame> frames;
    for (int k = q.first; k <= q.last; ++k) {
        const UtcTime t = add_seconds(q.start, q.step_s * double(k - 1));
        try {
            frames.push_back({k, t, solar_position(solar_input(sun, lat, lon, t, "sky")), frame_path(o.output, k)});
        } catch (const SolarPositionError& e) {
            throw CliError(std::string("sky: ") + e.what());
        }
    }
    for (const Frame& f : frames) check_exr_destination(f.path);
    check_output_destination(csv_path);  // not after every frame is rendered

    CancelFlag cancel;
    InterruptGuard guard(cancel);
    const bool show = stderr_is_terminal() && !o.quiet;
    const auto t0 = std::chrono::steady_clock::now();
    std::optional<MultipleScattering> tables;
    if (settings.multiple.enabled) {
        ProgressBar bar("sky: multiple-scattering tables", 0, show);
        const RenderHooks hooks = progress_hooks(bar, cancel);
        tables = sky_multiple_scattering(base, settings, hooks);
    }
    std::string csv = "frame,utc,latitude_deg,longitude_deg," + std::string(kSunAngleColumns) +
                      ",sun_strength,sun_color_r,sun_color_g,sun_color_b,sun_angle_deg,file\n";
    for (const Frame& f : frames) {
        Scene scene = base;
        scene.sun.elevation_deg = f.position.blender_elevation_deg;
        scene.sun.azimuth_deg = f.position.blender_rotation_deg;
        scene.sun.place = SunPlace{lat, lon, f.time, sun.delta_t_s};
        validate(scene);
        FloatImage image;
        {
            ProgressBar bar("sky frame " + std::to_string(f.number) + " (" + std::to_string(&f - frames.data() + 1) +
                                "/" + std::to_string(frames.size()) + ")",
                            0, show);
            const RenderHooks hooks = progress_hooks(bar, cancel);
            image = render_sky(scene, settings, hooks, tables ? &*tables : nullptr);
        }
        if (cancel.requested())
            throw Cancelled("sky: cancelled; frame " + std::to_string(f.number) + " and the CSV not written");
        // OpenImageIO stamps EXRs with the wall-clock DateTime unless one is given: a frame gets
        // the moment it shows instead, so the same frame is the same file on any machine (shards).
        ImageMetadata metadata = sky_metadata(scene, settings);
        const std::string shown = format_utc(f.time);  // YYYY-MM-DDThh:mm:ss[.fff]Z
        metadata.emplace_back("DateTime", shown.substr(0, 4) + ":" + shown.substr(5, 2) + ":" + shown.substr(8, 2) +
                                              " " + shown.substr(11, 8));
        write_exr_atomic(f.path, image, metadata, &cancel, exr_compression_from_name(o.exr_compression));
        const SunLight light = sun_light_at_observer(scene, settings.view.chapman);
        const glm::dvec3 colour = light.lamp_colour();
        csv += std::to_string(f.number) + "," + format_utc(f.time) + "," + format_place(lat) + "," +
               format_place(lon) + "," + sun_angle_fields(f.position) + "," + format_g17(light.lamp_strength()) +
               "," + format_g17(colour.x) + "," + format_g17(colour.y) + "," + format_g17(colour.z) + "," +
               format_g17(light.angular_diameter_deg) + "," + std::filesystem::path(f.path).filename().string() +
               "\n";
    }
    write_file_atomic(csv_path, csv, &cancel);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!o.quiet)
        std::fprintf(stderr, "sky: wrote frames %d-%d of %d (%dx%d) and %s (%.4f s, tables %s)\n", q.first, q.last,
                     q.count, settings.width, settings.height, csv_path.c_str(), seconds,
                     settings.multiple.enabled ? ("once: " + table_cache_summary(o.ms)).c_str() : "not used");
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
    cmd->add_option("--width", o->width, "Image width in pixels, 360°  [default 2048]")
        ->check(int_in(4, kSkyMaxDimension));
    cmd->add_option("--height", o->height, "Image height in pixels, 180°  [default width/2]")
        ->check(int_in(2, kSkyMaxDimension));
    cmd->add_option("--samples", o->samples, "Samples per scattering constituent along each view ray")
        ->check(int_in(1, kSkyMaxViewSamples))
        ->capture_default_str();
    cmd->add_option("--chapman", o->chapman, "Chapman method for optical depths (airmass chapman --list-methods)")
        ->capture_default_str();
    cmd->add_option("--sun-elevation", o->sun_elevation_deg, "Sun elevation above the horizon, degrees")
        ->check(number_in(-90.0, 90.0));
    cmd->add_option("--sun-rotation", o->sun_rotation_deg, "Sun rotation as Blender's Sky Texture: 0 → +Y, 90 → +X")
        ->check(number_in(-1e6, 1e6));
    cmd->add_option("--altitude-km", o->altitude_km, "Observer altitude above the surface, km (as [observer] altitude_km)")
        ->check(number_in(0.0, 1e6));
    cmd->add_flag("--no-sun-disc", o->no_sun_disc, "Leave out the solar disc");
    cmd->add_option("--basis", o->basis, "rgb (Schüler 615/535/445 nm) or spectral  [default: the scene's]")
        ->check(CLI::IsMember({"rgb", "spectral"}));
    cmd->add_option("--wavelengths", o->wavelengths,
                    "Spectral samples: N (evenly over 380-780 nm), FIRST:LAST:STEP, or a comma list (nm)");
    cmd->add_option("--hemisphere", o->hemisphere, "full, or upper: rows below the horizon are left 0, not computed")
        ->check(CLI::IsMember({"full", "upper"}))
        ->capture_default_str();
    cmd->add_option("--grid", o->grid,
                    "Sky grid: G azimuth intervals over 0-180 deg and G + 1 rows above and below the horizon (more where rays graze a profile's knots, and at the horizontal from 60 m up), pixels "
                    "interpolated, in [4, 16384] (0: every pixel, -1: auto = 40); every pixel when the grid has as many "
                    "nodes as the image has rays to evaluate")
        ->check(int_in(-1, kSkyMaxGrid))  // and not 1-3: validate(SkySettings)
        ->capture_default_str();
    cmd->add_option("--threads", o->threads, "Worker threads (0: all)")->check(int_in(0, 4096))->capture_default_str();
    cmd->add_flag("--no-multiple", o->no_multiple, "Single scattering only (no multiple-scattering tables)");
    add_ms_options(cmd, o->ms, kSkyMaxMultipleSamples);
    cmd->add_option("--ms-grid", o->ms_grid,
                    "Multiple scattering on a sun-aligned grid of this many azimuth intervals, interpolated, in "
                    "[2, 16384] (0: integrated along every ray, as when the grid has as many rays as the image evaluates)")
        ->check(int_in(0, kSkyMaxGrid))
        ->capture_default_str();
    cmd->add_flag("--no-refine", o->no_refine,
                  "Interpolate every pixel from the grids, also in their rough cells (where the light changes "
                  "faster than a cell: from orbit at twilight), which are otherwise evaluated pixel by pixel: "
                  "faster there, less accurate (docs/sky.md Rough cells)");
    cmd->add_option("--exr-compression", o->exr_compression,
                    "none, zip or piz (all lossless; none writes fastest: docs/sky.md)")
        ->check(CLI::IsMember({"none", "zip", "piz"}))
        ->capture_default_str();
    cmd->add_flag("-q,--quiet", o->quiet, "No progress bar or summary line");
    cmd->add_option("--time-range", o->time_range,
                    "Sequence: START,END in ISO 8601 UTC (with --fps); -o must contain #### (docs/sun.md)");
    cmd->add_option("--fps", o->fps, "Sequence: frames per second of solar time, or A/B (1/600 = every 10 min)");
    cmd->add_option("--frames", o->frames, "Sequence: render only frames A-B (1-based): a shard of the sequence");
    cmd->add_option("--latitude", o->latitude_deg, "Sequence: place latitude, degrees  [default: the scene's [sun]]")
        ->check(number_in(-90.0, 90.0, Ends::closed, "latitude_deg", "degrees"));
    cmd->add_option("--longitude", o->longitude_deg, "Sequence: place longitude, degrees east  [default: the scene's]")
        ->check(number_in(-180.0, 180.0, Ends::closed, "longitude_deg", "degrees"));
    cmd->add_option("--frames-csv", o->frames_csv,
                    "Sequence: the per-frame CSV  [default: beside the frames, e.g. out/sky.csv]");
    add_sun_options(cmd, o->sun, false);

    cmd->callback([o, list_presets] {
        if (*list_presets) {
            for (const auto& n : preset_names()) std::printf("%s\n", n.c_str());
            return;
        }
        if (o->scene_path.empty() == o->preset.empty())
            throw CliError("sky: give a scene file or --preset NAME (one of them)");
        if (o->output.empty()) throw CliError("sky: -o/--output is required");
        Scene scene = o->preset.empty() ? load_scene_file(o->scene_path) : load_preset(o->preset);
        apply_sky_overrides(scene, o->sun_elevation_deg, o->sun_rotation_deg, o->altitude_km, o->basis, o->wavelengths);
        if (o->sun_elevation_deg || o->sun_rotation_deg) scene.sun.place.reset();  // the angles given win

        SkySettings settings;
        settings.width = o->width;
        settings.height = o->height ? *o->height : std::max(2, o->width / 2);
        settings.view.view_samples = o->samples;
        const auto method = chapman_method_from_name(o->chapman);
        if (!method) throw CliError("sky: unknown --chapman '" + o->chapman + "' (see `airmass chapman --list-methods`)");
        settings.view.chapman = *method;
        settings.view.sun_disc = !o->no_sun_disc;
        settings.region = o->hemisphere == "upper" ? SkyRegion::upper : SkyRegion::full;
        settings.threads = o->threads;
        settings.grid = o->grid;
        settings.multiple.enabled = !o->no_multiple;
        if (o->ms_grid == 1)
            throw CliError("sky: --ms-grid 1: must be 0 (every ray) or in [2, " + std::to_string(kSkyMaxGrid) + "]");
        settings.multiple_grid = o->ms_grid;
        settings.refine_rough_cells = !o->no_refine;
        apply_ms_options("sky", o->ms, settings.multiple, kSkyMaxMultipleSamples);
        try {
            validate(settings);
        } catch (const SkyError& e) {
            throw CliError(std::string("sky: --") + e.what());
        }
        validate(scene);
        if (!o->time_range.empty()) {
            render_sequence(*o, scene, settings);
            return;
        }
        if (!o->fps.empty() || !o->frames.empty() || o->latitude_deg || o->longitude_deg || !o->frames_csv.empty() ||
            o->sun.delta_t_s || o->sun.delta_ut1_s)
            throw CliError("sky: --fps, --frames, --latitude, --longitude, --frames-csv, --delta-t and --delta-ut1 "
                           "apply to sequences (--time-range)");
        // Fail on an unwritable destination now, not after the render.
        check_exr_destination(o->output);

        CancelFlag cancel;
        InterruptGuard guard(cancel);
        const auto t0 = std::chrono::steady_clock::now();
        FloatImage image;
        {
            ProgressBar bar("sky " + std::to_string(settings.width) + "x" + std::to_string(settings.height),
                            0, stderr_is_terminal() && !o->quiet);
            const RenderHooks hooks = progress_hooks(bar, cancel);
            image = render_sky(scene, settings, hooks);
        }
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        // A cancel up to the rename keeps the previous file (write_exr_atomic discards its temporary).
        if (cancel.requested()) throw Cancelled("sky: cancelled; no file written");
        write_exr_atomic(o->output, image, sky_metadata(scene, settings), &cancel,
                         exr_compression_from_name(o->exr_compression));
        if (!o->quiet)
            std::fprintf(stderr, "sky: wrote %s (%dx%d, %s, %s, %.4f s render)\n", o->output.c_str(),
                         settings.width, settings.height,
                         scene.basis.kind == SpectralBasis::Kind::rgb_schuler
                             ? "rgb-schuler"
                             : (std::to_string(scene.basis.wavelengths_nm.size()) + " wavelengths").c_str(),
                         settings.multiple.enabled
                             ? ("single + multiple scattering, " + table_cache_summary(o->ms)).c_str()
                             : "single scattering only",
                         seconds);
    });
}

}  // namespace airmass::cli
