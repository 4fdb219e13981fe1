// The plan of `airmass compare` (docs/compare.md): the one table of comparison paths, which
// native renders, inputs and renderer steps each path needs, the job schema (job.json's
// "format" and "schema_version") and the checks of the plan's inputs. Values only — no
// processes, no files: cmd_compare.cpp builds a Plan from its options, runs it (native
// renders, Blender / POV-Ray child processes, the report) and reports.
//
// The table reaches everything else through the CLI: job.json's "plan" (blender_render.py,
// report.py) and `airmass compare --list-paths --json` (the add-on's list of paths).
#pragma once

#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace airmass::cli::compare {

// job.json's schema. "schema_version" counts incompatible changes; compare/job_schema.py
// (read by blender_render.py and report.py) holds the version it understands and refuses any
// other, naming the field (tests/python/test_compare_plan.py checks the two agree).
inline constexpr const char* kJobFormat = "airmass-compare-job";
inline constexpr int kJobSchemaVersion = 2;

enum class Renderer { blender, povray };
const char* renderer_name(Renderer r);

// One comparison path: what renders it, against which native image, and what it needs.
struct PathInfo {
    const char* name;
    const char* reference;  // the native image it is compared with (report.py)
    const char* title;      // its title in the report
    Renderer renderer;      // blender: compare/blender_render.py; povray: the scene of `airmass pov`
    const char* renders;    // what the renderer renders (--list-paths)
    std::vector<const char*> natives;  // the native renders it needs beyond kAlwaysNative
    bool volume_modes;      // rendered once per --volume-modes entry (split / rgb / rgb_dither)
    bool ms_modes;          // rendered once per --ms-modes entry (dither / closures)
    bool is_default;        // in --paths' default
    double step_cost;       // relative wall time of its renderer step (progress weights; a guess)
    const char* render_count;  // how many renders its step makes, in the plan's terms
};

// The comparison paths, in report order: the one list.
const std::vector<PathInfo>& path_table();
// The entry of `name`; std::logic_error when there is none (names come from the table).
const PathInfo& path_info(std::string_view name);
// "sky_texture,analytic_volume,...": every name, comma-separated (help texts, errors).
std::string path_names(bool defaults_only = false);

// The inputs of a plan: the options of `airmass compare` that decide what is rendered.
struct PlanInputs {
    std::string paths = path_names(true);
    std::string volume_modes = "split,rgb,rgb_dither";
    std::string ms_modes = "dither,closures";
    int samples = 64;        // Cycles samples per seed for the volume paths
    int seeds = 4;           // independent Blender renders per volume path (noise estimate)
    int sky_samples = 64;    // per seed for the sky texture path
    int ms_bounces = 64;     // Cycles volume and diffuse bounces of analytic_volume_ms
    int view_samples = 64;   // native: samples per constituent along each view ray
    double sky_oversample = 4.0;
    double step_km = 1.0;
    int max_steps = 1024;
    double timeout_s = 3600.0;
    std::optional<int> pov_intervals, pov_samples;
    bool renderers = true;   // false: --no-blender (native renders and inputs only)
    bool report = true;      // false: --no-report
};

// What a run does, in order.
struct Plan {
    std::vector<std::string> paths;         // requested, in the order given
    std::vector<std::string> volume_modes;  // --volume-modes
    std::vector<std::string> ms_modes;      // --ms-modes
    std::vector<std::string> natives;       // the native renders, in order
    std::vector<std::string> steps;         // every step (the progress events' index / total)
    nlohmann::json seeds, samples;          // per path (every path of the table), as job.json holds them

    bool wants(std::string_view path) const;
    bool wants_any(std::initializer_list<std::string_view> paths) const;
    bool needs_native(std::string_view name) const;
    bool needs_view_box() const;  // vdb_volume or pov_df3: the box the camera sees
    bool needs_constituents() const;  // a volume path: analytic.json
};

// Checks every input (a CliError names the option and its range or its allowed values) and
// lays out the run.
Plan make_plan(const PlanInputs& in);

// The step of a path's renderer ("blender analytic_volume", "povray pov_df3").
std::string renderer_step(const std::string& path);

// job.json's header: format, schema_version and the plan's choices (paths_requested, seeds,
// samples, volume_modes, multiple, errors: empty).
nlohmann::json job_header(const Plan& plan);

// The renders a path's step makes for this job: Cycles renders of blender_render.py's
// render_seeds, or POV-Ray processes (job["pov"][path]["runs"]).
int planned_renders(const nlohmann::json& job, const std::string& path);

// job.json's "plan": the table, the requested paths, the steps and the renders per path.
nlohmann::json plan_json(const Plan& plan, const nlohmann::json& job);

// `airmass compare --list-paths [--json]`.
nlohmann::json path_list_json();
std::string path_list_text();

}  // namespace airmass::cli::compare
