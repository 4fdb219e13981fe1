// `airmass compare`: render one camera natively and in headless Blender along the three ways
// a user brings Airmass into Blender — the sky texture as World, the analytic node-tree volume
// and the VDB volume, both lit by a Sun lamp — and write a report of the differences
// (docs/compare.md). A fourth path, analytic_volume_ms, renders the analytic volume with
// Cycles' volume and diffuse bounces on: multiple scattering on both sides. Three more,
// pov_sky, pov_analytic and pov_df3, render the scenes `airmass pov` writes in headless POV-Ray
// 3.7 through the same child-process runner and report (docs/povray.md).
//
//   airmass compare (--preset NAME | SCENE.toml) -o DIR [--width W --height H --samples S
//       --seeds K --paths LIST --view-samples N --sky-oversample F --voxel-size KM
//       --voxel-values auto|average|point --step KM
//       --max-steps N --blender EXE --python EXE --scripts DIR --addon DIR --threads N
//       --timeout S --sun-elevation DEG --sun-rotation DEG --volume-modes split,rgb
//       --camera-position X,Y,Z --camera-direction X,Y,Z --camera-up X,Y,Z --fov DEG
//       --max-distance KM --progress-json FILE|-|fd:N --no-blender --quiet]
//   airmass compare --list-paths [--json]
//
// This file runs a plan (airmass/compare_plan.hpp over compare/plan.json: the path table, the
// native renders and steps each
// path needs, the job schema, the checks of the options): options → plan → run → report.
// What it does, in order (every file lands in the staging folder beside DIR, swapped in whole
// as DIR once the run completes: OutputFolder below; DIR keeps its previous set until then):
//   1. native renders (render.hpp): native_physical.exr (spectral, the scene's phase
//      functions), native_hg_spectral.exr (Henyey–Greenstein phases), native_matched.exr
//      (what Blender renders from the volume export: HG + the renderer RGB model) and, for
//      the VDB path, native_matched_box.exr (the same medium cut to the exported box), for
//      analytic_volume_ms, native_matched_ms.exr (native_matched + multiple scattering);
//   2. the inputs Blender needs: sky.exr (render_sky from the camera's altitude, no sun
//      disc, the default sky grid, ≥ --sky-oversample texels per camera pixel), analytic.json (analytic_density_json, km),
//      atmosphere.vdb (export_vdb of a box around what the camera sees, km);
//   3. job.json, then one Blender process per path running compare/blender_render.py
//      (K seeds each), its log in blender_<path>.log;
//   4. compare/report.py: report.md, PNGs and summary.json, run by default in the same Blender
//      (`blender -b --factory-startup --python report.py -- DIR`: its bundled Python with numpy,
//      images through bpy), or with --python EXE (numpy and OpenImageIO; matplotlib optional).
//      A failed report fails the run: DIR keeps its previous set.
// A path that cannot run (an export refused, Blender failing, a missing script) is recorded
// with an "error" in job.json and summary.json; the other paths and the report go on.
#include <signal.h>
#if defined(__linux__)
#include <sys/prctl.h>
#endif
#include <sys/stat.h>
#include <sys/wait.h>
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <numbers>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include "airmass/atomic_file.hpp"
#include "airmass/image_io.hpp"
#include "airmass/progress.hpp"
#include "airmass/terminal.hpp"
#include "airmass/render.hpp"
#include "airmass/scene_io.hpp"
#include "airmass/sky.hpp"
#include "airmass/vdb_export.hpp"
#include "commands.hpp"
#include "airmass/compare_plan.hpp"
#include "vdb_module.hpp"
#include "pov_scene.hpp"
#include "render_options.hpp"

namespace airmass::cli {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

struct CompareOptions {
    std::string scene_path, preset, output;
    std::optional<int> width, height;
    bool panoramic = false;
    compare::PlanInputs plan;  // what is rendered (airmass/compare_plan.hpp)
    int sky_min_width = 2048;
    int sky_max_width = 8192;
    std::optional<double> voxel_size_km;
    std::string voxel_values = "auto";
    double max_dense_mb = 600.0;
    std::string blender = "blender";
    std::string povray = "povray";
    bool pov_refine = true;  // a second render at 2x the intervals: the sampling error, measured
    std::string python;  // empty: the report runs in `blender`
    std::string scripts, addon;
    int threads = 0;
    std::optional<double> sun_elevation_deg, sun_rotation_deg;
    bool quiet = false;
    bool no_report = false;
    bool no_blender = false;
    bool list_paths = false, list_json = false;  // --list-paths [--json]: print the table, run nothing
    std::string progress_json;  // "", "-" (stderr), "fd:N" or a file: JSON-lines progress events
    render_detail::CameraOverrides camera;
};

void say(bool quiet, const std::string& msg) {
    if (!quiet) std::fprintf(stderr, "compare: %s\n", msg.c_str());
}

// --progress-json: machine-readable progress, one JSON object per line, flushed (docs/compare.md
// "Progress events"). Every step of the run — each native render, the sky texture and VDB
// inputs, each Blender path, the report — is announced by render_start {step, path, index,
// total} (path: the comparison path a Blender step renders, else null; a Blender step also
// gives `renders`, the number of Cycles renders it makes) and closed by render_done {step, path,
// index, total, ok, seconds}; native renders send progress {step, index, total, done, of};
// error {step, path, message} for a path that failed; done {ok} last (ok false: the run failed).
class ProgressEvents {
public:
    explicit ProgressEvents(const std::string& dest) {
        if (dest.empty()) return;
        if (dest == "-") {
            out_ = stderr;
        } else if (dest.rfind("fd:", 0) == 0) {
            out_ = ::fdopen(std::stoi(dest.substr(3)), "w");
            owned_ = out_ != nullptr;
        } else {
            out_ = std::fopen(dest.c_str(), "a");
            owned_ = out_ != nullptr;
        }
        if (!out_) throw CliError("compare: --progress-json " + dest + ": cannot open");
    }
    ProgressEvents(const ProgressEvents&) = delete;
    ProgressEvents& operator=(const ProgressEvents&) = delete;
    ~ProgressEvents() {
        if (owned_) std::fclose(out_);
    }
    void set_steps(std::vector<std::string> steps) { steps_ = std::move(steps); }
    int index(const std::string& step) const {
        const auto it = std::find(steps_.begin(), steps_.end(), step);
        return it == steps_.end() ? -1 : int(it - steps_.begin());
    }
    nlohmann::json event(const char* name, const std::string& step, const std::string& path = "") const {
        nlohmann::json j{{"event", name}, {"step", step}, {"index", index(step)}, {"total", steps_.size()}};
        j["path"] = path.empty() ? nlohmann::json() : nlohmann::json(path);
        return j;
    }
    void emit(const nlohmann::json& j) {
        if (!out_) return;
        std::fprintf(out_, "%s\n", j.dump().c_str());
        std::fflush(out_);
    }

private:
    std::FILE* out_ = nullptr;
    bool owned_ = false;
    std::vector<std::string> steps_;
};

void write_text(const fs::path& path, const std::string& text) { write_text_atomic(path, text); }

// compare/ beside the source tree: --scripts, $AIRMASS_COMPARE_DIR, <exe>/../../compare (a build
// directory inside the repository), <exe>/../share/airmass/compare, ./compare.
fs::path find_scripts_dir(const std::string& given) {
    std::vector<fs::path> candidates;
    if (!given.empty()) candidates.emplace_back(given);
    else {
        if (const char* env = std::getenv("AIRMASS_COMPARE_DIR")) candidates.emplace_back(env);
        std::error_code ec;
        const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
        if (!ec) {
            candidates.push_back(exe.parent_path() / ".." / ".." / "compare");
            candidates.push_back(exe.parent_path() / ".." / "share" / "airmass" / "compare");
        }
        candidates.emplace_back(fs::current_path() / "compare");
    }
    // The scripts and what they import: job_schema.py, which reads plan.json (the plan's data).
    for (const auto& c : candidates)
        if (fs::is_regular_file(c / "blender_render.py") && fs::is_regular_file(c / "report.py") &&
            fs::is_regular_file(c / "job_schema.py") && fs::is_regular_file(c / "plan.json"))
            return fs::weakly_canonical(c);
    std::string tried;
    for (const auto& c : candidates) tried += " " + c.string();
    throw CliError("compare: cannot find the compare scripts (blender_render.py, report.py, job_schema.py, "
                   "plan.json); tried" + tried +
                   " (pass --scripts DIR or set AIRMASS_COMPARE_DIR)");
}

// Runs argv with stdout and stderr appended to `log`; returns the exit status (128 + signal
// when killed). Polls `cancel` and the timeout; either kills the child's process group.
// The child leads its own process group (a terminal's Ctrl-C reaches only `airmass`, which
// cancels and then kills that group: SIGTERM, SIGKILL 3 s later), and on Linux it is killed by
// the kernel when `airmass` dies in any way, `kill -9` included (PR_SET_PDEATHSIG; it fires
// when the forking thread ends, and this runs on the main thread, which lives until exit).
// Processes Blender itself starts are not covered by the latter (they stay in the group).
int run_process(const std::vector<std::string>& argv, const fs::path& log, double timeout_s, const CancelFlag& cancel,
                bool& timed_out, const fs::path& cwd = {}) {
    timed_out = false;
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (fd < 0) throw CliError("compare: cannot open log " + log.string());
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    const pid_t parent = ::getpid();
    const pid_t pid = ::fork();
    if (pid < 0) {
        ::close(fd);
        throw CliError("compare: fork failed");
    }
    if (pid == 0) {
        ::setpgid(0, 0);
#if defined(__linux__)
        // Die with the parent (kept across execvp). The parent may have died before the prctl:
        // then this process was already re-parented, and goes now.
        if (::prctl(PR_SET_PDEATHSIG, SIGKILL) != 0 || ::getppid() != parent) ::_exit(127);
#else
        (void)parent;
#endif
        ::dup2(fd, 1);
        ::dup2(fd, 2);
        if (!cwd.empty() && ::chdir(cwd.c_str()) != 0) {
            std::fprintf(stderr, "compare: cannot enter %s\n", cwd.c_str());
            ::_exit(127);
        }
        ::execvp(args[0], args.data());
        std::fprintf(stderr, "compare: cannot run %s\n", args[0]);
        ::_exit(127);
    }
    ::close(fd);
    ::setpgid(pid, pid);
    const auto t0 = std::chrono::steady_clock::now();
    int status = 0;
    bool killed = false;
    for (;;) {
        const pid_t r = ::waitpid(pid, &status, WNOHANG);
        if (r == pid) break;
        if (r < 0) return -1;
        const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        if (!killed && (cancel.requested() || elapsed > timeout_s)) {
            timed_out = !cancel.requested();
            ::kill(-pid, SIGTERM);
            killed = true;
            for (int i = 0; i < 30 && ::waitpid(pid, &status, WNOHANG) == 0; ++i)
                std::this_thread::sleep_for(std::chrono::milliseconds(100));
            ::kill(-pid, SIGKILL);
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    if (WIFEXITED(status)) return WEXITSTATUS(status);
    if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
    return -1;
}

std::string tail_of(const fs::path& log, std::size_t lines) {
    std::ifstream in(log);
    std::vector<std::string> all;
    for (std::string l; std::getline(in, l);) all.push_back(l);
    std::string out;
    for (std::size_t i = all.size() > lines ? all.size() - lines : 0; i < all.size(); ++i) out += all[i] + "\n";
    return out;
}


json native_entry(const Scene& scene, const std::string& file, double seconds, const RenderSettings& s) {
    json j{{"file", file},
           {"seconds", seconds},
           {"renderer_matched", s.renderer_matched},
           {"color_model", s.color == ColorModel::spectral ? "spectral" : "renderer_rgb"},
           {"view_samples", s.view.view_samples},
           {"multiple_scattering", s.multiple.enabled}};
    if (s.renderer_matched) {
        // The Henyey–Greenstein g this image was rendered with (the one rule, henyey_greenstein_g):
        // the material's Volume Scatter gets the same (tests/blender/test_material_graph.py).
        json g = json::object();
        for (const auto& c : renderer_matched_scene(scene, s.matched_renderer).constituents) g[c.name] = c.phase.g;
        j["henyey_greenstein_g"] = g;
        j["matched_renderer"] = s.matched_renderer == MatchedRenderer::povray ? "povray" : "blender";
    }
    if (s.medium_box) {
        const auto& b = *s.medium_box;
        j["medium_box_km"] = {b.min_m.x / 1e3, b.min_m.y / 1e3, b.min_m.z / 1e3,
                              b.max_m.x / 1e3, b.max_m.y / 1e3, b.max_m.z / 1e3};
    }
    return j;
}

// The settings of each native render the plan names (compare::Plan::natives), from `base` (the
// camera, view samples, threads).
RenderSettings native_settings(const std::string& name, const RenderSettings& base,
                               const std::array<double, 3>& rgb_wl, const std::optional<MediumBox>& box) {
    RenderSettings s = base;
    if (name == "native_physical") return s;
    if (name == "native_physical_box") {
        // The sky texture path is rendered with Cycles' Box filter (the pixel's mean): a texture
        // of finite resolution cannot put the horizon's jump where a single ray per pixel finds
        // it, but it integrates to the right pixel mean (docs/compare.md).
        // Multiple scattering included, as in the sky texture users make (SkySettings' default).
        s.pixel_filter = PixelFilter::box;
        s.multiple.enabled = true;
        return s;
    }
    s.renderer_matched = true;
    if (name == "native_hg_spectral") return s;
    s.color = ColorModel::renderer_rgb;
    s.rgb_wavelengths_nm = rgb_wl;
    if (name == "native_matched") return s;
    if (name == "native_matched_ms") {
        s.multiple.enabled = true;  // the default tables (multiple_scattering.hpp)
        return s;
    }
    const bool boxed = name == "native_matched_box" || name == "native_povray_matched_box";
    if (boxed) {
        if (!box) throw std::logic_error("compare: " + name + " without the view box");
        s.medium_box = box;
    }
    if (name == "native_matched_box") return s;
    // POV-Ray's media: the Rayleigh phase kept (scattering type 4), the rest as the HG of the
    // one rule (type 5), three wavelengths lit by the sun's RGB irradiance (docs/povray.md).
    s.matched_renderer = MatchedRenderer::povray;
    if (name == "native_povray_matched" || name == "native_povray_matched_box") return s;
    throw std::logic_error("compare: no native render " + name);
}

// Writes the whole comparison into `dir`, the staging folder (OutputFolder): every file there,
// the paths in job.json naming it (OutputFolder::publish rebases them onto DIR).
void run_compare_steps(const CompareOptions& o, const compare::Plan& plan, ProgressEvents& events,
                       const fs::path& dir, CancelFlag& cancel) {
    using namespace render_detail;
    const Scene scene =
        load_render_scene(o.scene_path, o.preset, o.sun_elevation_deg, o.sun_rotation_deg, "compare", o.camera);
    const Projection projection = o.panoramic ? Projection::equirectangular : Projection::perspective;
    const CameraModel cam = resized_camera(scene, projection, o.width, o.height, SensorFit::automatic);
    const std::vector<std::string>& paths = plan.paths;
    auto wants = [&](std::string_view p) { return plan.wants(p); };
    const fs::path scripts = find_scripts_dir(o.scripts);
    const fs::path addon = o.addon.empty() ? scripts.parent_path() / "addon" : fs::path(o.addon);
    std::error_code ec;
    events.set_steps(plan.steps);  // every step of this run, in order (the events' index / total)

    const bool bar_on = stderr_is_terminal() && !o.quiet;
    auto check_cancel = [&] {
        if (cancel.requested()) throw Cancelled("compare: cancelled");
    };

    json job = compare::job_header(plan);
    job["scene_name"] = scene.name;
    job["scene_json"] = json::parse(scene_to_json(scene));
    job["camera"] = json::parse(camera_to_json(cam, 1000.0));
    job["camera"]["clip_start"] = 1e-4;
    job["camera"]["clip_end"] = 1e6;
    job["addon_dir"] = addon.string();
    job["blender_threads"] = o.threads;
    // analytic_volume_ms (blender_render.py): per channel one grey render of the whole medium,
    // its scatterers' phases either dithered into one closure (unbiased) or one closure each
    // (Cycles 3.4's phase-summing bias, measured).
    job["multiple"] = {{"modes", plan.ms_modes}, {"bounces", o.plan.ms_bounces}};

    // ---- native renders -------------------------------------------------------------------
    RenderSettings base;
    base.camera = cam;
    base.view.view_samples = o.plan.view_samples;
    base.threads = o.threads;
    const std::array<double, 3> rgb_wl = exporter_rgb_wavelengths(scene, "auto");
    const double R = scene.planet.radius_m;
    const ObserverFrame frame = observer_frame(R, cam.pose.position_m);
    std::optional<MediumBox> box;
    if (plan.needs_view_box()) box = view_box(scene, cam);  // `airmass pov --path df3` cuts the same

    json natives = json::object();
    auto native = [&](const std::string& name, RenderSettings s) {
        check_cancel();
        const fs::path file = dir / (name + ".exr");
        events.emit(events.event("render_start", name));
        const auto t0 = std::chrono::steady_clock::now();
        FloatImage img;
        {
            ProgressBar bar("native " + name, std::size_t(cam.height), bar_on);
            RenderHooks hooks;
            hooks.cancel = &cancel;
            std::size_t rows = 0;
            int percent = -1;
            std::mutex mutex;  // work_done comes from the worker threads
            hooks.work_done = [&](std::size_t n, std::size_t) {
                bar.advance(n);
                const std::lock_guard<std::mutex> lock(mutex);
                rows += n;
                const int pc = int(100 * rows / std::max<std::size_t>(1, std::size_t(cam.height)));
                if (pc != percent) {
                    percent = pc;
                    json e = events.event("progress", name);
                    e["done"] = rows;
                    e["of"] = cam.height;
                    events.emit(e);
                }
            };
            img = render_camera(scene, s, hooks);
        }
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        check_cancel();
        write_exr_atomic(file, img, render_metadata(scene, s), &cancel);
        natives[name] = native_entry(scene, file.filename().string(), seconds, s);
        json done = events.event("render_done", name);
        done["ok"] = true;
        done["seconds"] = seconds;
        events.emit(done);
        say(o.quiet, "native " + name + ": " + std::to_string(seconds) + " s");
    };
    for (const auto& name : plan.natives) native(name, native_settings(name, base, rgb_wl, box));
    job["native"] = natives;

    // ---- the sun lamp and the planet, km -----------------------------------------------------
    const glm::dvec3 sun = sun_direction(scene.sun.elevation_deg, scene.sun.azimuth_deg);
    const std::array<double, 3> e = sun_irradiance_rgb(scene);
    const double strength = std::max({e[0], e[1], e[2]});
    job["sun"] = {{"direction", {sun.x, sun.y, sun.z}},
                  {"irradiance_rgb", e},
                  {"strength", strength},
                  {"color", strength > 0 ? json{e[0] / strength, e[1] / strength, e[2] / strength} : json{1, 1, 1}},
                  {"angle_deg", 0.0},
                  {"elevation_deg", scene.sun.elevation_deg},
                  {"rotation_deg", scene.sun.azimuth_deg}};
    const glm::dvec3 q = cam.pose.position_m - glm::dvec3(0, 0, -R);
    const glm::dvec3 nadir = glm::normalize(q);
    job["planet"] = {{"radius", R / 1e3},
                     {"top", scene.planet.atmosphere_top_m / 1e3},
                     {"center", {0.0, 0.0, -R / 1e3}},
                     {"albedo", scene.planet.ground_albedo},
                     {"nadir", {nadir.x, nadir.y, nadir.z}}};
    job["camera_altitude_m"] = frame.altitude_m;
    job["rgb_wavelengths_nm"] = rgb_wl;
    job["ground"] = {{"ground_segments", 256}, {"ground_first_km", 1e-4}, {"ground_growth", 1.06},
                     {"ground_max_step_deg", 0.5}};
    job["volume"] = {{"step_km", o.plan.step_km}, {"max_steps", o.plan.max_steps}, {"domain_margin_km", 5.0}};

    auto step_done = [&](const std::string& step, const std::string& path, bool ok, double seconds) {
        json e = events.event("render_done", step, path);
        e["ok"] = ok;
        e["seconds"] = seconds;
        events.emit(e);
    };
    auto step_error = [&](const std::string& step, const std::string& path, const std::string& message) {
        json e = events.event("error", step, path);
        e["message"] = message;
        events.emit(e);
    };

    // ---- inputs per path ---------------------------------------------------------------------
    if (wants("sky_texture")) {
        events.emit(events.event("render_start", "sky_texture_input", "sky_texture"));
        try {
            check_cancel();
            // Texels no larger than the camera's pixels / oversample at the image centre (where a
            // perspective pixel subtends the most): width = oversample · 2π / pixel angle.
            double pixel_rad;
            if (projection == Projection::perspective) {
                const double f_px = 0.5 * cam.width / std::tan(0.5 * horizontal_fov_deg(cam) * std::numbers::pi / 180.0);
                pixel_rad = 1.0 / f_px;
            } else {
                pixel_rad = 2.0 * std::numbers::pi / cam.width;
            }
            int w = int(std::ceil(o.plan.sky_oversample * 2.0 * std::numbers::pi / pixel_rad / 4.0)) * 4;
            w = std::clamp(std::max(w, o.sky_min_width), 64, std::max(o.sky_max_width, 64));
            Scene sky_scene = scene;
            sky_scene.observer.altitude_m = frame.altitude_m;
            SkySettings ss;
            ss.width = w;
            ss.height = w / 2;
            ss.view.view_samples = o.plan.view_samples;
            ss.view.sun_disc = false;
            ss.grid = -1;  // what `airmass sky` does by default (its error: docs/sky.md)
            ss.multiple.enabled = true;  // as `airmass sky` by default, and native_physical_box
            ss.threads = o.threads;
            const auto t0 = std::chrono::steady_clock::now();
            FloatImage sky;
            {
                ProgressBar bar("sky texture " + std::to_string(w) + "x" + std::to_string(w / 2), 0, bar_on);
                const RenderHooks hooks = progress_hooks(bar, cancel);
                sky = render_sky(sky_scene, ss, hooks);
            }
            const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            write_exr_atomic(dir / "sky.exr", sky, sky_metadata(sky_scene, ss), &cancel);
            const double off_axis_m = std::hypot(cam.pose.position_m.x, cam.pose.position_m.y);
            job["sky_texture"] = {{"file", (dir / "sky.exr").string()},
                                  {"width", w},
                                  {"height", w / 2},
                                  {"seconds", seconds},
                                  {"observer_altitude_m", frame.altitude_m},
                                  {"grid", effective_sky_grid(sky_scene, ss)},
                                  {"camera_off_axis_m", off_axis_m}};
            say(o.quiet, "sky texture " + std::to_string(w) + "x" + std::to_string(w / 2) + ": " +
                             std::to_string(seconds) + " s");
            step_done("sky_texture_input", "sky_texture", true, seconds);
        } catch (const Cancelled&) {
            throw;
        } catch (const std::exception& ex) {
            job["errors"]["sky_texture"] = std::string("sky texture: ") + ex.what();
            step_error("sky_texture_input", "sky_texture", job["errors"]["sky_texture"].get<std::string>());
            step_done("sky_texture_input", "sky_texture", false, 0.0);
        }
    }
    std::vector<json> constituents;
    // (The pov media paths carry them too: the report's voxelisation estimate reads them.)
    if (plan.needs_constituents()) {
        try {
            VdbOptions vo;
            vo.unit = LengthUnit::km;
            vo.origin = PlanetOrigin::surface;
            const std::string text = analytic_density_json(scene, vo);
            write_text(dir / "analytic.json", text);
            const json a = json::parse(text);
            // Each carries g_hg, the Henyey–Greenstein g of the one rule (henyey_greenstein_g,
            // phase.hpp): what the material's Volume Scatter gets and what native_matched renders.
            for (const auto& c : a.at("constituents")) constituents.push_back(c);
            job["constituents"] = constituents;
            job["analytic_json"] = (dir / "analytic.json").string();
        } catch (const std::exception& ex) {
            for (const char* p : {"analytic_volume", "analytic_volume_ms", "vdb_volume"})
                job["errors"][p] = std::string("analytic density: ") + ex.what();
        }
    }
    if (wants("vdb_volume")) events.emit(events.event("render_start", "vdb_export", "vdb_volume"));
    if (wants("vdb_volume") && !job["errors"].contains("vdb_volume")) {
        try {
            check_cancel();
            VdbOptions vo;
            vo.region = VdbRegion::box;
            vo.unit = LengthUnit::km;
            vo.origin = PlanetOrigin::surface;
            vo.tile_voxels = -1;
            vo.max_dense_mb = o.max_dense_mb;
            vo.voxel_values = voxel_values_from_name(o.voxel_values).value();  // checked by CLI11
            vo.box = {box->min_m.x / 1e3, box->min_m.y / 1e3, box->min_m.z / 1e3,
                      box->max_m.x / 1e3, box->max_m.y / 1e3, box->max_m.z / 1e3};
            double vs = o.voxel_size_km ? *o.voxel_size_km : auto_voxel_size(scene, vo);
            if (!o.voxel_size_km) {
                // Coarsen until Blender 3.4's dense boxes (4 bytes per voxel per grid) fit the budget.
                const glm::dvec3 ext = (box->max_m - box->min_m) / 1e3;
                const double grids = std::max<double>(1.0, double(constituents.size()));
                const double budget_voxels = o.max_dense_mb * 1024.0 * 1024.0 / 4.0 / grids;
                const double need = std::cbrt(ext.x * ext.y * ext.z / budget_voxels);
                if (need > vs) vs = need * 1.05;
                if (vs > 2.0)
                    throw CliError("the camera sees " + std::to_string(int(ext.x)) + " x " + std::to_string(int(ext.y)) +
                                   " x " + std::to_string(int(ext.z)) +
                                   " km of atmosphere; a VDB of it within --max-dense-mb needs " + std::to_string(vs) +
                                   " km voxels (> 2 km, coarser than the thin layers); lower the camera's "
                                   "max_distance_km or pass --voxel-size");
            }
            vo.voxel_size = vs;
            const auto t0 = std::chrono::steady_clock::now();
            VdbRunOptions run;
            run.cancel = &cancel;
            const VdbStats stats = vdb_module().export_vdb(scene, vo, dir / "atmosphere.vdb", run);
            const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            json files = json::array();
            for (const auto& f : stats.files) files.push_back(fs::absolute(f).string());
            job["vdb"] = {{"files", files},
                          {"voxel_size", stats.voxel_size},
                          {"box_km", vo.box},
                          {"seconds", seconds},
                          {"active_voxels", stats.active_voxels},
                          {"dense_bytes", stats.dense_bytes},
                          {"half_voxel_correction", true}};
            say(o.quiet, "vdb: voxel " + std::to_string(stats.voxel_size) + " km, " + std::to_string(stats.files.size()) +
                             " file(s), " + std::to_string(seconds) + " s");
            step_done("vdb_export", "vdb_volume", true, seconds);
        } catch (const Cancelled&) {
            throw;
        } catch (const std::exception& ex) {
            job["errors"]["vdb_volume"] = std::string("VDB export: ") + ex.what();
        }
    }
    if (wants("vdb_volume") && job["errors"].contains("vdb_volume")) {
        step_error("vdb_export", "vdb_volume", job["errors"]["vdb_volume"].get<std::string>());
        step_done("vdb_export", "vdb_volume", false, 0.0);
    }
    // The POV-Ray scenes: `airmass pov`'s writer (write_pov_scene, the one code) for this camera,
    // into DIR as <path>.pov with its inputs; the POV-Ray processes to run (one per split pass,
    // and with --pov-refine the same at twice the media intervals, the sampling error measured).
    // A scene the writer refuses (a df3 box over 65535 voxels, ...) is this path's error, named,
    // before POV-Ray starts.
    job["pov"] = json::object();
    for (const auto& p : paths) {
        if (compare::path_info(p).renderer != compare::Renderer::povray) continue;
        const std::string step = "pov_scene " + p;
        events.emit(events.event("render_start", step, p));
        try {
            check_cancel();
            PovSceneOptions so;
            so.command = "compare --paths " + p;
            so.path = p.substr(4);  // pov_sky -> sky
            so.threads = o.threads;
            so.progress_bar = bar_on;
            if (so.path == "sky") {
                so.sky_oversample = o.plan.sky_oversample;
            } else {
                so.media_intervals = o.plan.pov_intervals;
                so.media_samples = o.plan.pov_samples;
            }
            if (so.path == "df3") so.voxel_size_km = o.voxel_size_km;
            const auto t0 = std::chrono::steady_clock::now();
            const PovSceneInfo info = write_pov_scene(scene, cam, so, dir / (p + ".pov"), cancel);
            const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            json runs = json::array();
            auto add_run = [&](int pass, int intervals, bool refined) {
                const std::string out = p + (refined ? "_x2" : "") + "_pass" + std::to_string(pass) + ".exr";
                std::vector<std::string> argv{o.povray, "+I" + p + ".pov", "+O" + out, "+FE",
                                              "+W" + std::to_string(cam.width), "+H" + std::to_string(cam.height),
                                              "-D", "-V"};
                for (const auto& f : info.povray_flags) argv.push_back(f);
                if (pass > 0) argv.push_back("Declare=Airmass_Pass=" + std::to_string(pass));
                if (refined) argv.push_back("Declare=Airmass_MediaIntervals=" + std::to_string(intervals));
                if (o.threads > 0) argv.push_back("+WT" + std::to_string(o.threads));
                runs.push_back({{"argv", argv}, {"output", out}, {"pass", pass}, {"intervals", intervals},
                                {"refined", refined}});
            };
            if (info.passes.empty()) {
                add_run(0, 0, false);
            } else {
                for (int k : info.passes) add_run(k, info.intervals, false);
                if (o.pov_refine)
                    for (int k : info.passes) add_run(k, 2 * info.intervals, true);
            }
            json files = json::array();
            for (const auto& f : info.written) files.push_back(fs::absolute(f).string());
            job["pov"][p] = {{"scene", (dir / (p + ".pov")).string()},
                             {"files", files},
                             {"passes", info.passes},
                             {"pass_constituents", info.pass_names},
                             {"intervals", info.intervals},
                             {"media_samples", info.media_samples},
                             {"sky_width", info.sky_width},
                             {"voxel_size_km", info.voxel_size_km},
                             {"flags", info.povray_flags},
                             {"runs", runs},
                             {"seconds", seconds}};
            if (info.medium_box_km) job["pov"][p]["medium_box_km"] = *info.medium_box_km;
            // Samples: the media intervals, or for the sky the rays per pixel (+R<n>: an n x n grid).
            int samples = info.intervals;
            for (const auto& f : info.povray_flags)
                if (f.rfind("+R", 0) == 0) samples = std::stoi(f.substr(2)) * std::stoi(f.substr(2));
            job["samples"][p] = samples;
            say(o.quiet, p + ": wrote " + p + ".pov (" + std::to_string(runs.size()) + " POV-Ray render(s) planned)");
            step_done(step, p, true, seconds);
        } catch (const Cancelled&) {
            throw;
        } catch (const std::exception& ex) {
            job["errors"][p] = std::string("POV-Ray scene: ") + ex.what();
            step_error(step, p, job["errors"][p].get<std::string>());
            step_done(step, p, false, 0.0);
        }
    }
    // The plan, for blender_render.py, report.py and the add-on: every path (the one table,
    // compare/plan.json), those requested, the steps of the progress events, and how many
    // Cycles renders each Blender path makes (and POV-Ray processes each POV-Ray path runs).
    job["plan"] = compare::plan_json(plan, job);
    write_text(dir / "job.json", job.dump(2) + "\n");
    if (o.no_blender) return;

    // ---- the renderers: Blender and POV-Ray --------------------------------------------------------
    // One loop for both (the path table's renderer): each path is a list of child processes run by
    // run_process (own process group, killed on Ctrl-C or timeout), its log <renderer>_<path>.log.
    // Blender: one process running blender_render.py, which writes blender_<path>.json. POV-Ray:
    // one process per split pass (and refined pass), from DIR (the scene's inputs are relative
    // to it); povray_<path>.json, written here, lists the images to sum and their times.
    json blender_runs = json::object();
    for (const auto& p : paths) {
        check_cancel();
        const std::string renderer = compare::renderer_name(compare::path_info(p).renderer);
        const bool pov = renderer == "povray";
        const std::string step = compare::renderer_step(p);
        const fs::path log = dir / (renderer + "_" + p + ".log");
        {
            // `log`: where the step's log is written while it runs (the staging folder).
            json e = events.event("render_start", step, p);
            e["renders"] = job["plan"][pov ? "povray_renders" : "blender_renders"].value(p, 0);
            e["log"] = log.string();
            events.emit(e);
        }
        if (job["errors"].contains(p)) {
            step_error(step, p, job["errors"][p].get<std::string>());
            step_done(step, p, false, 0.0);
            continue;
        }
        fs::remove(log, ec);
        struct Run {
            std::vector<std::string> argv;
            fs::path cwd;
        };
        std::vector<Run> runs;
        if (pov) {
            for (const auto& r : job["pov"][p]["runs"]) runs.push_back({r["argv"].get<std::vector<std::string>>(), dir});
            say(o.quiet, "povray " + p + " (" + std::to_string(runs.size()) + " render(s)) ...");
        } else {
            runs.push_back({{o.blender, "-b", "--factory-startup", "--python-exit-code", "1", "--python",
                             (scripts / "blender_render.py").string(), "--", (dir / "job.json").string(), p},
                            {}});
            say(o.quiet, "blender " + p + " (" + std::to_string(job["seeds"][p].get<int>()) + " seeds x " +
                             std::to_string(job["samples"][p].get<int>()) + " samples) ...");
        }
        const auto t0 = std::chrono::steady_clock::now();
        bool timed_out = false;
        int rc = 0;
        std::vector<double> run_seconds;
        for (const auto& r : runs) {
            const auto t1 = std::chrono::steady_clock::now();
            rc = run_process(r.argv, log, o.plan.timeout_s, cancel, timed_out, r.cwd);
            run_seconds.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count());
            check_cancel();
            if (rc != 0) break;
        }
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        blender_runs[p] = {{"exit_status", rc}, {"wall_seconds", seconds}, {"log", log.filename().string()},
                           {"renderer", renderer}};
        if (rc != 0) {
            job["errors"][p] = std::string(pov ? "POV-Ray" : "Blender") + " " + (timed_out ? "timed out" : "failed") +
                               " (exit status " + std::to_string(rc) + "); last lines of " +
                               log.filename().string() + ":\n" + tail_of(log, 12);
        } else if (pov) {
            // What report.py reads for a POV-Ray path: per mode the images of each "seed" (one:
            // POV-Ray is deterministic) to sum, the render times, and the refined renders.
            const json& pj = job["pov"][p];
            const bool media = !pj["passes"].empty();
            const std::string mode = media ? "split" : "supersampled";
            json images = json::array(), refined_images = json::array();
            std::vector<double> secs{0.0}, refined_secs{0.0};
            std::size_t i = 0;
            for (const auto& r : pj["runs"]) {
                (r["refined"].get<bool>() ? refined_images : images).push_back(r["output"]);
                (r["refined"].get<bool>() ? refined_secs : secs)[0] += run_seconds[i++];
            }
            std::string version;
            {
                std::ifstream in(log);
                // POV-Ray's banner: "Persistence of Vision(tm) Ray Tracer Version 3.7.0.10.unofficial (...".
                const std::string tag = "Ray Tracer Version ";
                for (std::string l; std::getline(in, l) && version.empty();)
                    if (const auto k = l.find(tag); k != std::string::npos) {
                        version = l.substr(k + tag.size());
                        version = version.substr(0, version.find_first_of(" \t\r("));
                    }
            }
            json info{{"renderer", "povray"},
                      {"version", version},
                      {"seeds", 1},
                      {"samples", job["samples"][p]},
                      {"modes", {mode}},
                      {"images", {{mode, json::array({images})}}},
                      {"render_seconds", {{mode, secs}}},
                      {"build_seconds", pj["seconds"]},
                      {"passes", pj["passes"]},
                      {"pass_constituents", pj["pass_constituents"]},
                      {"intervals", pj["intervals"]},
                      {"media_samples", pj["media_samples"]},
                      {"argv", pj["runs"][0]["argv"]},
                      {"deterministic", true}};
            if (!refined_images.empty())
                info["refined"] = {{"intervals", 2 * pj["intervals"].get<int>()},
                                   {"images", json::array({refined_images})},
                                   {"render_seconds", refined_secs}};
            write_text(dir / ("povray_" + p + ".json"), info.dump(2) + "\n");
        }
        say(o.quiet, step + ": " + (rc == 0 ? "ok" : "FAILED") + ", " + std::to_string(seconds) + " s");
        if (rc != 0) step_error(step, p, job["errors"][p].get<std::string>());
        step_done(step, p, rc == 0, seconds);
    }
    job["blender_runs"] = blender_runs;  // every renderer's processes (the key predates POV-Ray)
    write_text(dir / "job.json", job.dump(2) + "\n");

    // ---- report -------------------------------------------------------------------------------------
    if (o.no_report) return;
    const fs::path log = dir / "report.log";
    fs::remove(log, ec);
    const std::string report_py = (scripts / "report.py").string();
    const bool in_blender = o.python.empty();
    const std::vector<std::string> report_argv =
        in_blender ? std::vector<std::string>{o.blender, "-b", "--factory-startup", "--python-exit-code", "1",
                                              "--python", report_py, "--", dir.string()}
                   : std::vector<std::string>{o.python, report_py, dir.string()};
    const std::string runner = in_blender ? "Blender (" + o.blender + ")" : "--python " + o.python;
    say(o.quiet, "report (" + runner + ") ...");
    {
        json e = events.event("render_start", "report");
        e["log"] = log.string();
        events.emit(e);
    }
    const auto t_report = std::chrono::steady_clock::now();
    bool timed_out = false;
    const int rc = run_process(report_argv, log, o.plan.timeout_s, cancel, timed_out);
    check_cancel();
    if (rc != 0 || !fs::is_regular_file(dir / "summary.json") || !fs::is_regular_file(dir / "report.md"))
        throw CliError("compare: the report (compare/report.py in " + runner + ") " +
                       (timed_out ? "timed out" : rc != 0 ? "failed" : "wrote no report.md / summary.json") +
                       " (exit status " + std::to_string(rc) + "); last lines of report.log:\n" + tail_of(log, 20));
    if (!o.quiet) std::fprintf(stderr, "%s", tail_of(log, 40).c_str());
    step_done("report", "", true, std::chrono::duration<double>(std::chrono::steady_clock::now() - t_report).count());
}

// The output set (docs/reliability.md, "Faults"): the run writes into a staging folder beside
// DIR (atomic_file.hpp, staging_folder_for) and publish() swaps it in whole, so DIR holds the
// previous complete set (or nothing) until then. A cancel, a failure or a failing report
// removes the staging folder (the destructor); a kill -9 leaves it, and the next run removes
// it (remove_stale_staging). DIR is replaced as a whole, so it must be new, empty, an earlier
// comparison (job.json), or hold only files this command line names (the scene, the
// --progress-json file: the add-on keeps both there); those are carried into the new set
// (hard links: the progress file keeps receiving events through the open stream).
class OutputFolder {
public:
    OutputFolder(const CompareOptions& o) {
        fs::path out = fs::absolute(o.output).lexically_normal();
        if (!out.has_filename()) out = out.parent_path();  // "DIR/"
        if (out == out.root_path() || !out.has_filename() || out.filename() == "..")
            throw CliError("compare: -o " + o.output + ": not a folder that can be replaced; give a folder to create");
        dest_ = out;
        const fs::path parent = dest_.parent_path();
        std::error_code ec;
        fs::create_directories(parent, ec);
        if (!fs::is_directory(parent, ec)) throw CliError("compare: cannot create the folder " + parent.string());
        std::vector<fs::path> named;  // files the command line names, by their canonical path
        for (const std::string& f : {o.scene_path, o.progress_json})
            if (!f.empty() && f != "-" && f.rfind("fd:", 0) != 0 && fs::exists(f, ec))
                named.push_back(fs::weakly_canonical(f, ec));
        if (fs::exists(fs::symlink_status(dest_, ec))) {
            if (fs::is_symlink(fs::symlink_status(dest_, ec)))
                throw CliError("compare: -o " + dest_.string() +
                               ": is a symbolic link; the output set is swapped in by renaming, so give the folder "
                               "itself (" + fs::weakly_canonical(dest_, ec).string() + ")");
            if (!fs::is_directory(fs::symlink_status(dest_, ec)))
                throw CliError("compare: -o " + dest_.string() + ": exists and is not a folder");
            const bool earlier = fs::is_regular_file(dest_ / "job.json", ec);
            for (fs::directory_iterator it(dest_, ec), end; !ec && it != end; it.increment(ec)) {
                const fs::path c = fs::weakly_canonical(it->path(), ec);
                if (std::find(named.begin(), named.end(), c) != named.end())
                    carried_.push_back(it->path().filename());
                else if (!earlier)
                    throw CliError("compare: -o " + dest_.string() + " holds '" + it->path().filename().string() +
                                   "', which is not from airmass compare (no job.json there): the output folder is "
                                   "replaced as a whole; give a new or empty folder, or an earlier comparison's");
            }
            struct stat a{}, b{};
            if (::stat(dest_.c_str(), &a) == 0 && ::stat(parent.c_str(), &b) == 0 && a.st_dev != b.st_dev)
                throw CliError("compare: -o " + dest_.string() +
                               " is a mount point: the output set is swapped in by renaming a folder beside it; give "
                               "a folder inside it");
            // The previous set is removed from it once the new one is in place.
            if (::access(dest_.c_str(), W_OK) != 0)
                throw CliError("compare: cannot write '" + dest_.string() + "': it is not writable (" +
                               std::strerror(errno) + ")");
        }
        remove_stale_staging(dest_);
        const fs::path staging = staging_folder_for(dest_);
        if (!fs::create_directory(staging, ec) || ec)
            throw CliError("compare: cannot write beside '" + dest_.string() + "': directory '" + parent.string() +
                           "' is not writable (" + (ec ? ec.message() : std::string("exists")) + ")");
        staging_ = staging;
    }
    OutputFolder(const OutputFolder&) = delete;
    OutputFolder& operator=(const OutputFolder&) = delete;
    ~OutputFolder() {
        std::error_code ec;
        if (!staging_.empty()) fs::remove_all(staging_, ec);
    }
    const fs::path& staging() const { return staging_; }
    const fs::path& dest() const { return dest_; }
    // A message about the staging folder, about DIR instead (where the file will be).
    std::string about_dest(std::string text) const {
        const std::string from = staging_.string(), to = dest_.string();
        for (std::size_t k = 0; !from.empty() && (k = text.find(from, k)) != std::string::npos; k += to.size())
            text.replace(k, from.size(), to);
        return text;
    }

    void publish() {
        std::error_code ec;
        // The JSON files name their inputs by absolute path (job.json's sky texture, VDB, POV-Ray
        // scenes; blender_<path>.json): rebased onto DIR.
        for (fs::directory_iterator it(staging_, ec), end; !ec && it != end; it.increment(ec)) {
            if (it->path().extension() != ".json" || !it->is_regular_file()) continue;
            json j;
            try {
                std::ifstream in(it->path());
                j = json::parse(in);
            } catch (const std::exception&) {
                continue;
            }
            if (rebase(j)) write_text(it->path(), j.dump(2) + "\n");
        }
        for (const fs::path& name : carried_) {
            const fs::path from = dest_ / name, to = staging_ / name;
            if (fs::exists(to, ec)) continue;
            if (::link(from.c_str(), to.c_str()) != 0) fs::copy_file(from, to, ec);
        }
        const fs::path left = publish_folder(staging_, dest_);
        staging_.clear();
        if (!left.empty())
            std::fprintf(stderr, "compare: warning: the previous set could not be removed: it is in %s\n",
                         left.c_str());
    }

private:
    bool rebase(json& j) const {
        const std::string from = staging_.string();
        if (j.is_string()) {
            const std::string& v = j.get_ref<const std::string&>();
            if (v == from || (v.size() > from.size() && v.compare(0, from.size(), from) == 0 && v[from.size()] == '/')) {
                j = dest_.string() + v.substr(from.size());
                return true;
            }
            return false;
        }
        bool changed = false;
        if (j.is_structured())
            for (auto& v : j) changed = rebase(v) || changed;
        return changed;
    }

    fs::path dest_, staging_;
    std::vector<fs::path> carried_;
};

// Options → plan → run → report → publish. The plan's checks come first (no file is touched for
// a bad option); run_compare_steps' progress events end, on a failure, with error and done
// {ok: false}, and on success with done {ok: true} once the set is in DIR.
void run_compare(const CompareOptions& o) {
    compare::PlanInputs in = o.plan;
    in.renderers = !o.no_blender;
    in.report = !o.no_report;
    const compare::Plan plan = [&] {
        try {
            return compare::make_plan(in);
        } catch (const compare::PlanError& e) {
            throw CliError(e.what());  // exit 2, the option named
        }
    }();
    ProgressEvents events(o.progress_json);
    std::unique_ptr<OutputFolder> folder;
    try {
        folder = std::make_unique<OutputFolder>(o);
        CancelFlag cancel;
        InterruptGuard guard(cancel);
        run_compare_steps(o, plan, events, folder->staging(), cancel);
        if (cancel.requested()) throw Cancelled("compare: cancelled");
        folder->publish();
    } catch (const std::exception& ex) {
        const std::string what = folder ? folder->about_dest(ex.what()) : std::string(ex.what());
        events.emit(json{{"event", "error"}, {"step", nullptr}, {"path", nullptr}, {"message", what}});
        events.emit(json{{"event", "done"}, {"ok", false}});
        folder.reset();  // the staging folder goes; DIR holds the previous set
        if (dynamic_cast<const Cancelled*>(&ex)) throw Cancelled(what);
        throw CliError(what);
    }
    events.emit(json{{"event", "done"}, {"ok", true}});
    const fs::path dir = folder->dest();
    say(o.quiet, o.no_blender || o.no_report
                     ? "wrote " + dir.string() + (o.no_blender ? " (--no-blender)" : " (--no-report)")
                     : "wrote " + (dir / "report.md").string() + " and " + (dir / "summary.json").string());
}

}  // namespace

void add_compare_command(CLI::App& app) {
    auto* cmd = app.add_subcommand(
        "compare", "Render a camera natively and in headless Blender (sky texture, analytic and VDB volumes) or "
                   "POV-Ray (pov_sky, pov_analytic, pov_df3) and report the differences");
    auto o = std::make_shared<CompareOptions>();
    auto* scene_opt = cmd->add_option("scene", o->scene_path, "Scene file (TOML; docs/scene.md)");
    auto* preset_opt = cmd->add_option("--preset", o->preset, "Built-in scene by name");
    scene_opt->excludes(preset_opt);
    cmd->add_option("-o,--output", o->output, "Output directory (report.md, summary.json, images)");
    cmd->add_option("--width", o->width, "Image width [default: the camera's]")->check(int_in(1, 65536));
    cmd->add_option("--height", o->height, "Image height [default: keeps the camera's aspect]")->check(int_in(1, 65536));
    cmd->add_flag("--panoramic", o->panoramic, "Equirectangular panoramic camera instead of perspective");
    cmd->add_option("--samples", o->plan.samples, "Cycles samples per seed, volume paths")
        ->capture_default_str()
        ->check(int_in(1, 1 << 20));
    cmd->add_option("--seeds", o->plan.seeds, "Independent Blender renders per volume path (>= 2; noise estimate)")
        ->capture_default_str()->check(int_in(2, 1000));
    cmd->add_option("--sky-samples", o->plan.sky_samples, "Cycles samples per seed, sky texture path")
        ->capture_default_str()
        ->check(int_in(1, 1 << 20));
    cmd->add_option("--paths", o->plan.paths,
                    "Comma-separated subset of " + compare::path_names() +
                        " (analytic_volume_ms: multiple scattering, Cycles volume and diffuse bounces on; pov_*: "
                        "headless POV-Ray 3.7, docs/povray.md; --list-paths describes each)")
        ->capture_default_str();
    cmd->add_option("--volume-modes", o->plan.volume_modes,
                    "Blender volume renders: split (grey, one Volume Scatter per render, summed: unbiased in "
                    "Cycles 3.4), rgb (one chromatic render with every closure, as users render), rgb_dither (one "
                    "chromatic render, the scatterers' phases dithered into one Volume Scatter)")
        ->capture_default_str();
    cmd->add_option("--ms-modes", o->plan.ms_modes,
                    "analytic_volume_ms renders: dither (one Volume Scatter whose anisotropy is picked per point: "
                    "unbiased) and/or closures (one Volume Scatter per constituent: Cycles 3.4's phase-summing bias)")
        ->capture_default_str();
    cmd->add_option("--ms-bounces", o->plan.ms_bounces, "Cycles volume and diffuse bounces of analytic_volume_ms")
        ->capture_default_str()->check(int_in(1, 1024));
    cmd->add_option("--view-samples", o->plan.view_samples, "Native: samples per constituent along each view ray")
        ->capture_default_str()->check(int_in(1, 65536));
    cmd->add_option("--sky-oversample", o->plan.sky_oversample, "Sky texture texels per camera pixel (at the centre)")
        ->capture_default_str()->check(number_in(0.25, 16.0));
    cmd->add_option("--sky-min-width", o->sky_min_width, "Smallest sky texture width")
        ->capture_default_str()
        ->check(int_in(64, 44720));
    cmd->add_option("--sky-max-width", o->sky_max_width, "Largest sky texture width")
        ->capture_default_str()
        ->check(int_in(64, 44720));
    cmd->add_option("--voxel-size", o->voxel_size_km, "VDB voxel size, km [default: auto, within --max-dense-mb]")
        ->check(number_in(0.0, 1e6, Ends::open_low));
    cmd->add_option("--voxel-values", o->voxel_values,
                    "What the VDB's voxels hold: auto, average (the density's mean over each voxel's footprint) or "
                    "point (the density at its centre), as for airmass vdb (docs/vdb.md, Voxel values)")
        ->check(CLI::IsMember({"auto", "average", "point"}))
        ->capture_default_str();
    cmd->add_option("--max-dense-mb", o->max_dense_mb, "Budget for Blender 3.4's dense VDB boxes, MiB")
        ->capture_default_str()->check(number_in(0.0, 1e12, Ends::open_low));
    cmd->add_option("--step", o->plan.step_km, "Cycles volume step for the analytic volume, km")
        ->capture_default_str()
        ->check(number_in(1e-4, 1e3));
    cmd->add_option("--max-steps", o->plan.max_steps, "Cycles volume_max_steps")
        ->capture_default_str()
        ->check(int_in(2, 65536));
    cmd->add_option("--blender", o->blender,
                    "Blender executable: the renders, and the report (compare/report.py in its own Python, "
                    "numpy only) unless --python is given")
        ->capture_default_str();
    cmd->add_option("--povray", o->povray, "POV-Ray 3.7 executable (the pov_* paths)")->capture_default_str();
    cmd->add_option("--pov-intervals", o->plan.pov_intervals,
                    "pov_analytic / pov_df3: media intervals [default: `airmass pov`'s rule, docs/povray.md]")
        ->check(int_in(1, 100000));
    cmd->add_option("--pov-samples", o->plan.pov_samples, "pov_analytic / pov_df3: media samples (method 3) [default: 3]")
        ->check(int_in(1, 100000));
    cmd->add_option("--pov-refine", o->pov_refine,
                    "pov_analytic / pov_df3: also render at twice the intervals (POV-Ray is deterministic: this "
                    "measures its sampling error)")
        ->capture_default_str();
    cmd->add_option("--python", o->python,
                    "Run the report with this Python instead of in --blender (needs numpy and OpenImageIO; "
                    "matplotlib optional) [default: in --blender]");
    cmd->add_option("--scripts", o->scripts, "Folder with blender_render.py and report.py [default: found]");
    cmd->add_option("--addon", o->addon, "Add-on folder holding airmass_blender [default: <scripts>/../addon]");
    cmd->add_option("--threads", o->threads, "Threads for native renders and Blender (0: all)")
        ->capture_default_str()
        ->check(int_in(0, 4096));
    cmd->add_option("--timeout", o->plan.timeout_s, "Seconds allowed per Blender or POV-Ray process")
        ->capture_default_str()
        ->check(number_in(1.0, 1e6));
    render_detail::add_sun_overrides(cmd, o->sun_elevation_deg, o->sun_rotation_deg);
    cmd->add_flag("--no-report", o->no_report, "Stop after the renders (job.json, EXRs)");
    cmd->add_flag("--no-blender", o->no_blender,
                  "Stop after the native renders and Blender's inputs (job.json: the plan, the constituents and "
                  "their Henyey-Greenstein g)");
    cmd->add_option("--progress-json", o->progress_json,
                    "Write progress events as JSON lines to FILE, '-' (stderr) or fd:N (docs/compare.md)");
    cmd->add_flag("-q,--quiet", o->quiet, "No progress output");
    render_detail::add_camera_options(cmd, o->camera);
    cmd->add_flag("--list-paths", o->list_paths,
                  "Print the comparison paths (renderer, what it renders, native reference, modes, render count) "
                  "and exit");
    cmd->add_flag("--json", o->list_json, "With --list-paths: as JSON (the add-on's list of paths)");
    cmd->callback([o] {
        if (o->list_paths) {
            const std::string text =
                o->list_json ? compare::path_list_json().dump(2) + "\n" : compare::path_list_text();
            std::fwrite(text.data(), 1, text.size(), stdout);
            std::fflush(stdout);
            return;
        }
        if (o->list_json) throw CliError("compare: --json goes with --list-paths");
        if (o->output.empty()) throw CliError("compare: -o/--output DIR is required");
        run_compare(*o);
    });
}

}  // namespace airmass::cli
