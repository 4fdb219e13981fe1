// `airmass render`: the native image of a scene's camera (render.hpp), as a 32-bit float EXR
// in linear Rec.709 — the reference a Blender render of the same camera is compared with
// (docs/compare.md).
//
//   airmass render (--preset NAME | SCENE.toml) -o native.exr [--width W --height H
//       --samples N --chapman METHOD --renderer-matched --rgb-model spectral|renderer
//       --rgb-wavelengths auto|bruneton|schuler|R,G,B --panoramic --sensor-fit auto|horizontal|vertical
//       --sun-disc --no-ground --multiple [--ms-mode --ms-orders --ms-samples --ms-table]
//       --box X0,Y0,Z0,X1,Y1,Z1 --sun-elevation DEG
//       --sun-rotation DEG --threads N --quiet]
//
//       --camera-position X,Y,Z --camera-direction X,Y,Z --camera-up X,Y,Z --fov DEG --max-distance KM
//
// A scene without [camera] gets the default camera of docs/scene.md (2 m above the ground,
// looking along +X at the horizon, 60°, 640×360). Written atomically; Ctrl-C leaves no file.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <glm/common.hpp>
#include <nlohmann/json.hpp>

#include "airmass/image_io.hpp"
#include "airmass/progress.hpp"
#include "airmass/terminal.hpp"
#include "airmass/render.hpp"
#include "airmass/scene_io.hpp"
#include "airmass/vdb_export.hpp"
#include "commands.hpp"
#include "csv.hpp"
#include "ms_options.hpp"
#include "render_options.hpp"

namespace airmass::cli {

namespace {

struct RenderOptions {
    std::string scene_path, preset, output;
    std::optional<int> width, height;
    int samples = RenderSettings{}.view.view_samples;
    std::string chapman = std::string(chapman_method_name(RenderSettings{}.view.chapman));
    bool renderer_matched = false;
    std::string matched_renderer = "blender";
    std::string rgb_model = "spectral";
    std::string pixel_filter = "centre";
    std::string rgb_wavelengths = "auto";
    bool panoramic = false;
    std::string sensor_fit = "auto";
    bool sun_disc = false, no_ground = false, multiple = false;
    MsCliOptions ms;
    std::string box;
    std::optional<double> sun_elevation_deg, sun_rotation_deg;
    int threads = 0;
    bool quiet = false;
    std::string exr_compression = exr_compression_name(kDefaultExrCompression);
    render_detail::CameraOverrides camera;
};

std::vector<double> parse_numbers(const std::string& text, std::size_t count, const std::string& option) {
    std::vector<double> out = parse_number_list(text, "render: " + option, "a finite number");
    if (out.size() != count)
        throw CliError("render: " + option + " '" + text + "': expected " + std::to_string(count) +
                       " comma-separated numbers");
    return out;
}

}  // namespace

}  // namespace airmass::cli

namespace airmass::cli::render_detail {

void add_camera_options(CLI::App* cmd, CameraOverrides& c) {
    cmd->add_option("--camera-position-km", c.position_km, "Camera position X,Y,Z in km (scene frame), each in [-1e7, 1e7]");
    cmd->add_option("--camera-direction", c.direction, "Camera view direction X,Y,Z");
    cmd->add_option("--camera-up", c.up, "Camera up vector X,Y,Z");
    // Below 1e-6 degrees the focal length overflows (camera.focal_length_mm = inf).
    cmd->add_option("--fov", c.fov_deg, "Field of view along the fitted (larger) side, degrees")
        ->check(number_in(1e-6, 180.0, Ends::open_high));
    cmd->add_option("--max-distance", c.max_distance_km, "Camera max distance (VDB region), km")
        ->check(number_in(0.0, 1e300, Ends::open_low));
}

void add_scene_and_size_options(CLI::App* cmd, std::string& scene_path, std::string& preset, std::optional<int>& width,
                                std::optional<int>& height) {
    auto* scene_opt = cmd->add_option("scene", scene_path, "Scene file (TOML; docs/scene.md)");
    auto* preset_opt = cmd->add_option("--preset", preset, "Built-in scene by name");
    scene_opt->excludes(preset_opt);
    cmd->add_option("--width", width, "Image width in pixels [default: the camera's]")->check(int_in(1, 65536));
    cmd->add_option("--height", height, "Image height in pixels [default: keeps the camera's aspect]")
        ->check(int_in(1, 65536));
}

void add_sun_overrides(CLI::App* cmd, std::optional<double>& elevation_deg, std::optional<double>& rotation_deg) {
    cmd->add_option("--sun-elevation", elevation_deg, "Override the sun elevation, degrees")
        ->check(number_in(-90.0, 90.0));
    cmd->add_option("--sun-rotation", rotation_deg, "Override the sun rotation (Blender: 0 -> +Y, 90 -> +X)")
        ->check(number_in(-1e6, 1e6));
}

void apply_camera_overrides(Scene& scene, const CameraOverrides& o, const char* command) {
    Camera& c = *scene.camera;
    auto vec = [&](const std::string& text, double* out, const char* opt) {
        if (text.empty()) return;
        const std::vector<double> v = parse_numbers(text, 3, opt);
        for (int i = 0; i < 3; ++i) out[i] = v[i];
    };
    vec(o.position_km, c.position_m, "--camera-position-km");
    if (!o.position_km.empty()) {
        for (double& x : c.position_m) {
            if (!(std::isfinite(x) && std::abs(x) <= 1e7))
                throw CliError(std::string(command) + ": --camera-position-km: each component must be in [-1e7, 1e7] km");
            x *= 1000.0;
        }
    }
    vec(o.direction, c.direction, "--camera-direction");
    vec(o.up, c.up, "--camera-up");
    if (o.fov_deg) {
        if (!(*o.fov_deg >= 1e-6 && *o.fov_deg < 180.0))
            throw CliError(std::string(command) + ": --fov " + format_g17(*o.fov_deg) + ": must be in [1e-6, 180) degrees");
        c.fov_deg = *o.fov_deg;
    }
    if (o.max_distance_km) {
        if (!(*o.max_distance_km > 0.0 && std::isfinite(*o.max_distance_km)))
            throw CliError(std::string(command) + ": --max-distance: must be > 0 km");
        c.max_distance_m = *o.max_distance_km * 1000.0;
    }
}

// Shared with cmd_compare.cpp (declared there): the scene a command line names, with the
// default camera when it has none and the sun overrides applied.
Scene load_render_scene(const std::string& scene_path, const std::string& preset,
                        const std::optional<double>& sun_elevation_deg, const std::optional<double>& sun_rotation_deg,
                        const char* command, const CameraOverrides& camera) {
    if (scene_path.empty() == preset.empty())
        throw CliError(std::string(command) + ": give a scene file or --preset NAME (one of them)");
    Scene scene = preset.empty() ? load_scene_file(scene_path) : load_preset(preset);
    if (!scene.camera) scene.camera = Camera{};
    apply_camera_overrides(scene, camera, command);
    if (sun_elevation_deg) {
        if (!(*sun_elevation_deg >= -90.0 && *sun_elevation_deg <= 90.0))
            throw CliError(std::string(command) + ": --sun-elevation " + std::to_string(*sun_elevation_deg) +
                           ": must be in [-90, 90] degrees");
        scene.sun.elevation_deg = *sun_elevation_deg;
    }
    if (sun_rotation_deg) {
        if (!std::isfinite(*sun_rotation_deg) || std::abs(*sun_rotation_deg) > 1e6)
            throw CliError(std::string(command) + ": --sun-rotation: must be finite, |value| <= 1e6");
        // An angle: any number of turns is the same direction (as `airmass sky`; the scene's
        // sun.azimuth_deg is kept in [-360, 360]).
        scene.sun.azimuth_deg = std::fmod(*sun_rotation_deg, 360.0);
    }
    validate(scene);
    return scene;
}

// The exporter's RGB wavelengths for a scene (vdb_export.hpp RgbWavelengths), read from its
// analytic description so that the native renderer-RGB model uses exactly the same three.
std::array<double, 3> exporter_rgb_wavelengths(const Scene& scene, const std::string& which) {
    if (which.find(',') != std::string::npos) {
        const std::vector<double> v = parse_numbers(which, 3, "--rgb-wavelengths");
        return {v[0], v[1], v[2]};
    }
    VdbOptions o;
    if (which == "auto") o.rgb = RgbWavelengths::automatic;
    else if (which == "bruneton") o.rgb = RgbWavelengths::bruneton;
    else if (which == "schuler") o.rgb = RgbWavelengths::schuler;
    else throw CliError("render: --rgb-wavelengths '" + which + "': must be auto, bruneton, schuler or R,G,B (nm)");
    const auto j = nlohmann::json::parse(analytic_density_json(scene, o));
    const auto& w = j.at("rgb_wavelengths_nm");
    return {w.at(0).get<double>(), w.at(1).get<double>(), w.at(2).get<double>()};
}

// A camera model from the scene's [camera], resized: both sizes given → them; one → the
// other keeps the aspect ratio (panoramic: height = width / 2 unless given).
CameraModel resized_camera(const Scene& scene, Projection projection, const std::optional<int>& width,
                           const std::optional<int>& height, SensorFit fit) {
    Scene s = scene;
    Camera& c = *s.camera;
    const double aspect = double(c.height) / c.width;
    if (projection == Projection::equirectangular) {
        const int w = width ? *width : (height ? 2 * *height : c.width);
        c.width = w;
        c.height = height ? *height : std::max(1, w / 2);
    } else if (width && height) {
        c.width = *width, c.height = *height;
    } else if (width) {
        c.width = *width, c.height = std::max(1, int(std::lround(*width * aspect)));
    } else if (height) {
        c.height = *height, c.width = std::max(1, int(std::lround(*height / aspect)));
    }
    CameraModel m = camera_from_scene(s, projection);
    if (fit != SensorFit::automatic) {
        // fov_deg is the field of view along the fitted dimension (docs/compare.md).
        m.sensor_fit = fit;
        m.focal_length_mm = focal_length_mm_from_fov(c.fov_deg, fitted_sensor_mm(m));
    }
    validate(m);
    return m;
}

MediumBox parse_box_km(const std::string& text) {
    const std::vector<double> v = parse_numbers(text, 6, "--box");
    for (int i = 0; i < 3; ++i)
        if (!(std::abs(v[i]) <= 1e7 && std::abs(v[i + 3]) <= 1e7 && v[i] < v[i + 3]))
            throw CliError("render: --box '" + text + "': each corner in [-1e7, 1e7] km, with X0 < X1, Y0 < Y1, Z0 < Z1");
    MediumBox b{glm::dvec3(v[0], v[1], v[2]) * 1000.0, glm::dvec3(v[3], v[4], v[5]) * 1000.0};
    return b;
}

// The box of the scene frame (metres) holding what the camera sees up to its max distance,
// within the atmosphere: the bounding box of the camera and of points at max distance along
// a 17 × 17 grid of pixel directions, cut to the shell's height range.
MediumBox view_box(const Scene& scene, const CameraModel& cam) {
    const double D = scene.camera->max_distance_m;
    glm::dvec3 lo = cam.pose.position_m, hi = cam.pose.position_m;
    constexpr int n = 16;
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
            const glm::dvec3 d = camera_ray_direction(cam, cam.width * double(i) / n, cam.height * double(j) / n);
            const glm::dvec3 p = cam.pose.position_m + D * d;
            lo = glm::min(lo, p);
            hi = glm::max(hi, p);
        }
    const double R = scene.planet.radius_m, top = scene.planet.atmosphere_top_m - R;
    // The medium spans altitudes [0, top]; below the ground nothing is seen, above the top
    // nothing scatters. z of the ground at horizontal distance ρ from the axis: −ρ²/(R + sqrt(R² − ρ²)).
    const double rho = std::min(std::max({std::abs(lo.x), std::abs(hi.x), std::abs(lo.y), std::abs(hi.y)}), R);
    const double z_ground = -rho * rho / (R + std::sqrt(std::max(R * R - rho * rho, 0.0)));
    lo.z = std::max(lo.z, z_ground - 1.0);
    hi.z = std::min(hi.z, top);
    // A box that is flat (camera above the top looking up, say) holds no medium.
    if (!(hi.z > lo.z)) hi.z = lo.z + 1.0;
    // Pad by a metre so the camera is strictly inside when it sits on a face.
    return {lo - glm::dvec3(1.0), hi + glm::dvec3(1.0)};
}

SensorFit parse_sensor_fit(const std::string& s) {
    if (s == "auto") return SensorFit::automatic;
    if (s == "horizontal") return SensorFit::horizontal;
    if (s == "vertical") return SensorFit::vertical;
    throw CliError("render: --sensor-fit '" + s + "': must be auto, horizontal or vertical");
}

}  // namespace airmass::cli::render_detail

namespace airmass::cli {

void add_render_command(CLI::App& app) {
    using namespace render_detail;
    auto* cmd = app.add_subcommand("render", "Render a scene's camera natively to a 32-bit float EXR (linear Rec.709)");
    auto o = std::make_shared<RenderOptions>();
    add_scene_and_size_options(cmd, o->scene_path, o->preset, o->width, o->height);
    cmd->add_option("-o,--output", o->output, "Output EXR path (written atomically)");
    cmd->add_option("--samples", o->samples, "Samples per scattering constituent along each view ray")
        ->check(int_in(1, 65536))
        ->capture_default_str();
    cmd->add_option("--chapman", o->chapman, "Chapman method (airmass chapman --list-methods)")->capture_default_str();
    cmd->add_flag("--renderer-matched", o->renderer_matched,
                  "Henyey-Greenstein phase functions with the same g (Rayleigh: g = 0), as Blender 3.4 renders");
    cmd->add_option("--matched-renderer", o->matched_renderer,
                    "with --renderer-matched: blender (HG only) or povray (Rayleigh kept, the rest HG)")
        ->check(CLI::IsMember({"blender", "povray"}))
        ->capture_default_str();
    cmd->add_option("--rgb-model", o->rgb_model,
                    "spectral (the scene's basis -> Rec.709) or renderer (3 wavelengths as R, G, B with the "
                    "sun lamp's RGB irradiance, what Blender renders from the volume export)")
        ->check(CLI::IsMember({"spectral", "renderer"}))
        ->capture_default_str();
    cmd->add_option("--rgb-wavelengths", o->rgb_wavelengths,
                    "renderer model: auto (the exporter's), bruneton (680,550,440), schuler (615,535,445) or R,G,B nm")
        ->capture_default_str();
    cmd->add_flag("--panoramic", o->panoramic, "Equirectangular panorama (Cycles' convention) instead of perspective");
    cmd->add_option("--sensor-fit", o->sensor_fit, "auto, horizontal or vertical (fov_deg applies to the fitted side)")
        ->capture_default_str();
    cmd->add_option("--pixel-filter", o->pixel_filter,
                    "centre (one ray per pixel centre) or box (the pixel's mean, Cycles' Box filter)")
        ->check(CLI::IsMember({"centre", "box"}))
        ->capture_default_str();
    cmd->add_flag("--sun-disc", o->sun_disc, "Add the solar disc (point-sampled at pixel centres)");
    cmd->add_flag("--no-ground", o->no_ground, "Leave the ground unlit (black)");
    cmd->add_flag("--multiple", o->multiple, "Add multiple scattering (multiple_scattering.hpp tables)");
    add_ms_options(cmd, o->ms, 65536);
    cmd->add_option("--box", o->box,
                    "Cut the medium to this box of the scene frame, km: X0,Y0,Z0,X1,Y1,Z1, each in [-1e7, 1e7] "
                    "(a VDB 'box' export)");
    add_sun_overrides(cmd, o->sun_elevation_deg, o->sun_rotation_deg);
    cmd->add_option("--threads", o->threads, "Worker threads (0: all)")->check(int_in(0, 4096))->capture_default_str();
    cmd->add_option("--exr-compression", o->exr_compression,
                    "none, zip or piz (all lossless; none writes fastest: docs/sky.md)")
        ->check(CLI::IsMember({"none", "zip", "piz"}))
        ->capture_default_str();
    cmd->add_flag("-q,--quiet", o->quiet, "No progress bar or summary line");
    add_camera_options(cmd, o->camera);

    cmd->callback([o] {
        if (o->output.empty()) throw CliError("render: -o/--output is required");
        const Scene scene =
            load_render_scene(o->scene_path, o->preset, o->sun_elevation_deg, o->sun_rotation_deg, "render", o->camera);
        RenderSettings settings;
        settings.projection = o->panoramic ? Projection::equirectangular : Projection::perspective;
        settings.camera = resized_camera(scene, settings.projection, o->width, o->height, parse_sensor_fit(o->sensor_fit));
        settings.view.view_samples = o->samples;
        const auto method = chapman_method_from_name(o->chapman);
        if (!method) throw CliError("render: unknown --chapman '" + o->chapman + "'");
        settings.view.chapman = *method;
        settings.renderer_matched = o->renderer_matched;
        settings.matched_renderer = o->matched_renderer == "povray" ? MatchedRenderer::povray : MatchedRenderer::blender;
        settings.color = o->rgb_model == "renderer" ? ColorModel::renderer_rgb : ColorModel::spectral;
        settings.pixel_filter = o->pixel_filter == "box" ? PixelFilter::box : PixelFilter::centre;
        if (settings.color == ColorModel::renderer_rgb)
            settings.rgb_wavelengths_nm = exporter_rgb_wavelengths(scene, o->rgb_wavelengths);
        settings.view.sun_disc = o->sun_disc;
        settings.view.ground = !o->no_ground;
        settings.multiple.enabled = o->multiple;
        apply_ms_options("render", o->ms, settings.multiple, 65536);  // as add_ms_options
        if (!o->box.empty()) settings.medium_box = parse_box_km(o->box);
        settings.threads = o->threads;
        try {
            validate(settings);
        } catch (const RenderError& e) {
            throw CliError(std::string("render: ") + e.what());
        }
        check_exr_destination(o->output);

        CancelFlag cancel;
        InterruptGuard guard(cancel);
        const auto t0 = std::chrono::steady_clock::now();
        FloatImage image;
        {
            ProgressBar bar("render", std::size_t(settings.camera->height), stderr_is_terminal() && !o->quiet);
            const RenderHooks hooks = progress_hooks(bar, cancel);
            image = render_camera(scene, settings, hooks);
        }
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        if (cancel.requested()) throw Cancelled("render: cancelled; no file written");
        ImageMetadata meta = render_metadata(scene, settings);
        meta.emplace_back("airmass:render_seconds", std::to_string(seconds));
        // Ctrl-C until the rename: no file.
        write_exr_atomic(o->output, image, meta, &cancel, exr_compression_from_name(o->exr_compression));
        if (!o->quiet)
            std::fprintf(stderr, "render: wrote %s (%dx%d, %s, %.3f s)\n", o->output.c_str(), image.width, image.height,
                         settings.color == ColorModel::spectral ? "spectral" : "renderer RGB", seconds);
    });
}

}  // namespace airmass::cli
