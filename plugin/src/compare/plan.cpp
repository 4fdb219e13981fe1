// The plan of `airmass compare`: compare_plan.hpp.
#include "compare_plan.hpp"

#include <algorithm>
#include <sstream>
#include <stdexcept>

#include "commands.hpp"

namespace airmass::cli::compare {

namespace {

using nlohmann::json;

// The native renders every run makes (the report compares each path with them too), and the
// order of all of them.
const std::vector<const char*> kAlwaysNative = {"native_physical", "native_hg_spectral", "native_matched"};
const std::vector<const char*> kNativeOrder = {"native_physical",     "native_physical_box",   "native_hg_spectral",
                                               "native_matched",      "native_matched_ms",     "native_matched_box",
                                               "native_povray_matched", "native_povray_matched_box"};

const char* const kVolumeCount = "seeds x sum over --volume-modes (split: 3 x scattering constituents; rgb, "
                                 "rgb_dither: 1)";

// A comma-separated list of names, each one of `allowed`; errors name the option.
std::vector<std::string> parse_choices(const std::string& text, const std::string& option,
                                       const std::vector<std::string>& allowed) {
    std::vector<std::string> out;
    std::stringstream ss(text);
    for (std::string v; std::getline(ss, v, ',');) {
        if (std::find(allowed.begin(), allowed.end(), v) == allowed.end()) {
            std::string list;
            for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
            throw CliError("compare: " + option + ": '" + v + "' is not one of " + list);
        }
        out.push_back(v);
    }
    if (out.empty()) throw CliError("compare: " + option + ": empty");
    return out;
}

void range(const char* option, double v, double lo, double hi) {
    if (!(v >= lo && v <= hi))
        throw CliError(std::string("compare: ") + option + " " + std::to_string(v) + ": must be in [" +
                       std::to_string(lo) + ", " + std::to_string(hi) + "]");
}

bool contains(const std::vector<std::string>& v, std::string_view s) {
    return std::find(v.begin(), v.end(), s) != v.end();
}

}  // namespace

const char* renderer_name(Renderer r) { return r == Renderer::povray ? "povray" : "blender"; }

const std::vector<PathInfo>& path_table() {
    static const std::vector<PathInfo> table = {
        {"sky_texture", "native_physical_box", "Sky texture as World background", Renderer::blender,
         "the `airmass sky` EXR as World (Environment Texture -> Background), Box pixel filter",
         {"native_physical_box"}, false, false, true, 4.0, "2 seeds (one render each)"},
        {"analytic_volume", "native_matched", "Analytic (node-tree) volume lit by a Sun lamp", Renderer::blender,
         "the add-on's analytic node-tree shell volume lit by a Sun lamp", {}, true, false, true, 10.0,
         kVolumeCount},
        {"analytic_volume_ms", "native_matched_ms",
         "Analytic volume with multiple scattering (Cycles volume and diffuse bounces)", Renderer::blender,
         "the analytic volume with Cycles' volume and diffuse bounces (--ms-bounces)", {"native_matched_ms"}, false,
         true, false, 10.0, "seeds x 3 channels x --ms-modes"},
        {"vdb_volume", "native_matched_box", "VDB volume lit by a Sun lamp", Renderer::blender,
         "the VDB of the box the camera sees, imported as a Volume object, lit by a Sun lamp",
         {"native_matched_box"}, true, false, true, 10.0, kVolumeCount},
        {"pov_sky", "native_physical_box", "POV-Ray: sky texture as sky_sphere", Renderer::povray,
         "the sky texture as POV-Ray's sky_sphere (`airmass pov --path sky`)", {"native_physical_box"}, false, false,
         false, 4.0, "1 POV-Ray process"},
        {"pov_analytic", "native_povray_matched",
         "POV-Ray: media with function-pattern densities, parallel sun light", Renderer::povray,
         "POV-Ray media with function-pattern densities, parallel sun light (`airmass pov --path analytic`)",
         {"native_povray_matched"}, false, false, false, 10.0,
         "1 POV-Ray process per split pass (x 2 with --pov-refine)"},
        {"pov_df3", "native_povray_matched_box",
         "POV-Ray: media with df3 densities (the camera's box), parallel sun light", Renderer::povray,
         "POV-Ray media with df3 densities of the camera's box, parallel sun light (`airmass pov --path df3`)",
         {"native_povray_matched", "native_povray_matched_box"}, false, false, false, 10.0,
         "1 POV-Ray process per split pass (x 2 with --pov-refine)"},
    };
    return table;
}

const PathInfo& path_info(std::string_view name) {
    for (const auto& p : path_table())
        if (name == p.name) return p;
    throw std::logic_error("compare: no path " + std::string(name));
}

std::string path_names(bool defaults_only) {
    std::string s;
    for (const auto& p : path_table())
        if (!defaults_only || p.is_default) s += (s.empty() ? "" : ",") + std::string(p.name);
    return s;
}

bool Plan::wants(std::string_view path) const { return contains(paths, path); }
bool Plan::wants_any(std::initializer_list<std::string_view> ps) const {
    return std::any_of(ps.begin(), ps.end(), [&](std::string_view p) { return wants(p); });
}
bool Plan::needs_native(std::string_view name) const { return contains(natives, name); }
bool Plan::needs_view_box() const { return wants_any({"vdb_volume", "pov_df3"}); }
bool Plan::needs_constituents() const {
    // (The pov media paths carry them too: the report's voxelisation estimate reads them.)
    return wants_any({"analytic_volume", "analytic_volume_ms", "vdb_volume", "pov_analytic", "pov_df3"});
}

std::string renderer_step(const std::string& path) {
    return std::string(renderer_name(path_info(path).renderer)) + " " + path;
}

Plan make_plan(const PlanInputs& in) {
    range("--samples", in.samples, 1, 1 << 20);
    range("--seeds", in.seeds, 2, 1000);
    range("--sky-samples", in.sky_samples, 1, 1 << 20);
    range("--view-samples", in.view_samples, 1, 65536);
    range("--sky-oversample", in.sky_oversample, 0.25, 16);
    range("--step", in.step_km, 1e-4, 1e3);
    range("--max-steps", in.max_steps, 2, 65536);
    range("--ms-bounces", in.ms_bounces, 1, 1024);
    range("--timeout", in.timeout_s, 1, 1e6);
    if (in.pov_intervals) range("--pov-intervals", *in.pov_intervals, 1, 100000);
    if (in.pov_samples) range("--pov-samples", *in.pov_samples, 1, 100000);

    Plan plan;
    std::vector<std::string> names;
    for (const auto& p : path_table()) names.emplace_back(p.name);
    plan.paths = parse_choices(in.paths, "--paths", names);
    plan.volume_modes = parse_choices(in.volume_modes, "--volume-modes", {"split", "rgb", "rgb_dither"});
    plan.ms_modes = parse_choices(in.ms_modes, "--ms-modes", {"dither", "closures"});

    for (const char* n : kNativeOrder) {
        bool need = std::find_if(kAlwaysNative.begin(), kAlwaysNative.end(),
                                 [&](const char* a) { return std::string_view(a) == n; }) != kAlwaysNative.end();
        for (const auto& p : plan.paths)
            for (const char* m : path_info(p).natives) need = need || std::string_view(m) == n;
        if (need) plan.natives.emplace_back(n);
    }
    plan.steps = plan.natives;
    if (plan.wants("sky_texture")) plan.steps.emplace_back("sky_texture_input");
    if (plan.wants("vdb_volume")) plan.steps.emplace_back("vdb_export");
    for (const auto& p : plan.paths)
        if (path_info(p).renderer == Renderer::povray) plan.steps.push_back("pov_scene " + p);
    if (in.renderers) {
        for (const auto& p : plan.paths) plan.steps.push_back(renderer_step(p));
        if (in.report) plan.steps.emplace_back("report");
    }

    // POV-Ray's media sampling is deterministic (3.7 seeds its jitter the same every run: two
    // renders are bit-identical, docs/povray.md), so a pov path is one "seed"; its samples are
    // the media intervals (set when its scene is written).
    plan.seeds = json::object();
    plan.samples = json::object();
    for (const auto& p : path_table()) {
        const std::string n = p.name;
        if (p.renderer == Renderer::povray) {
            plan.seeds[n] = 1;
            plan.samples[n] = 0;
        } else if (n == "sky_texture") {
            plan.seeds[n] = 2;
            plan.samples[n] = in.sky_samples;
        } else {
            plan.seeds[n] = in.seeds;
            plan.samples[n] = in.samples;
        }
    }
    return plan;
}

json job_header(const Plan& plan) {
    json job;
    job["format"] = kJobFormat;
    job["schema_version"] = kJobSchemaVersion;
    job["paths_requested"] = plan.paths;
    job["seeds"] = plan.seeds;
    job["samples"] = plan.samples;
    job["errors"] = json::object();
    job["volume_modes"] = plan.volume_modes;
    return job;
}

int planned_renders(const json& job, const std::string& path) {
    const PathInfo& info = path_info(path);
    if (info.renderer == Renderer::povray) return int(job["pov"][path]["runs"].size());  // POV-Ray processes
    const int seeds = job["seeds"][path].get<int>();
    if (info.ms_modes) return seeds * 3 * int(job["multiple"]["modes"].size());
    if (!info.volume_modes) return seeds;
    int scatterers = 0;
    if (job.contains("constituents"))
        for (const auto& c : job["constituents"]) {
            double m = 0.0;
            for (const auto& v : c["scattering_rgb"]) m = std::max(m, v.get<double>());
            scatterers += m > 0.0;
        }
    int per_seed = 0;
    for (const auto& m : job["volume_modes"]) per_seed += m.get<std::string>() == "split" ? 3 * scatterers : 1;
    return seeds * per_seed;
}

json plan_json(const Plan& plan, const json& job) {
    json renders = json::object(), pov_renders = json::object();
    for (const auto& p : plan.paths)
        if (!job["errors"].contains(p))
            (path_info(p).renderer == Renderer::povray ? pov_renders : renders)[p] = planned_renders(job, p);
    json table = json::array();
    for (const auto& p : path_table())
        table.push_back({{"name", p.name}, {"reference", p.reference}, {"title", p.title},
                         {"renderer", renderer_name(p.renderer)}});
    return {{"all_paths", table}, {"paths", plan.paths}, {"steps", plan.steps}, {"natives", plan.natives},
            {"blender_renders", renders}, {"povray_renders", pov_renders}};
}

json path_list_json() {
    json paths = json::array();
    for (const auto& p : path_table()) {
        json modes = json::array();
        if (p.volume_modes) modes = {"split", "rgb", "rgb_dither"};
        if (p.ms_modes) modes = {"dither", "closures"};
        json natives = json::array();
        for (const char* n : kAlwaysNative) natives.push_back(n);
        for (const char* n : p.natives) natives.push_back(n);
        paths.push_back({{"name", p.name},
                         {"renderer", renderer_name(p.renderer)},
                         {"renders", p.renders},
                         {"reference", p.reference},
                         {"title", p.title},
                         {"natives", natives},
                         {"volume_modes", p.volume_modes},
                         {"ms_modes", p.ms_modes},
                         {"modes_option", p.volume_modes ? json("--volume-modes")
                                                         : p.ms_modes ? json("--ms-modes") : json(nullptr)},
                         {"modes", modes},
                         {"default", p.is_default},
                         {"render_count", p.render_count},
                         {"step_cost", p.step_cost}});
    }
    return {{"format", "airmass-compare-paths"}, {"job_schema_version", kJobSchemaVersion}, {"paths", paths}};
}

std::string path_list_text() {
    std::string s;
    for (const auto& p : path_table()) {
        s += std::string(p.name) + (p.is_default ? " (default)" : "") + "\n";
        s += "  renderer:  " + std::string(renderer_name(p.renderer)) + ": " + p.renders + "\n";
        s += "  reference: " + std::string(p.reference) + "\n";
        if (p.volume_modes) s += "  modes:     --volume-modes split,rgb,rgb_dither\n";
        if (p.ms_modes) s += "  modes:     --ms-modes dither,closures\n";
        s += "  renders:   " + std::string(p.render_count) + "\n";
    }
    return s;
}

}  // namespace airmass::cli::compare
