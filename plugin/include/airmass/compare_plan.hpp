// The plan of `airmass compare` (docs/compare.md, "The plan and the job"): the one table of
// comparison paths, which native renders, inputs and renderer steps each path needs, the job
// schema (job.json's "format" and "schema_version") and the checks of the plan's inputs.
// Values only — no processes, no files: the CLI (plugin/cli/cmd_compare.cpp) builds a Plan
// from its options, runs it (native renders, Blender / POV-Ray child processes, the report)
// and reports.
//
// The table and the schema version are data, compare/plan.json, built into this library
// (plugin/CMakeLists.txt) and read as they are by compare/job_schema.py and by the add-on's
// Paths checkboxes (the zip's compare_scripts/plan.json): one list. The table reaches the
// scripts through job.json's "plan" too (blender_render.py, report.py).
#pragma once

#include <initializer_list>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace airmass::compare {

// A plan input out of its range or not one of its allowed values; the message names the
// option ("compare: --seeds 1: must be in [2, 1000]"). The CLI exits 2 with it.
struct PlanError : std::invalid_argument {
    using std::invalid_argument::invalid_argument;
};

// job.json's schema (compare/plan.json: "job_format", "job_schema_version"). The version
// counts incompatible changes; compare/job_schema.py (read by blender_render.py and
// report.py) reads the same file and refuses a job of any other version, naming the field.
const std::string& job_format();
int job_schema_version();

enum class Renderer { blender, povray };
const char* renderer_name(Renderer r);

// One comparison path (compare/plan.json's "paths"): what renders it, against which native
// image, and what it needs.
struct PathInfo {
    std::string name;
    int addon_flag = 0;              // the add-on's Paths checkbox bit (a power of two, fixed); 0: not offered
    std::string label, description;  // the add-on's Paths checkbox
    std::string title;               // its title in the report
    std::string reference;           // the native image it is compared with (report.py)
    Renderer renderer;               // blender: compare/blender_render.py; povray: the scene of `airmass pov`
    std::string renders;             // what the renderer renders (--list-paths)
    std::vector<std::string> natives;  // the native renders it needs beyond those every run makes
    bool volume_modes = false;       // rendered once per --volume-modes entry (split / rgb / rgb_dither)
    bool ms_modes = false;           // rendered once per --ms-modes entry (dither / closures)
    bool is_default = false;         // in --paths' default
    double step_cost = 1.0;          // relative wall time of its renderer step (progress weights; a guess)
    std::string render_count;        // how many renders its step makes, in the plan's terms
};

// The comparison paths, in report order: the one list (compare/plan.json, read and checked
// once; a malformed table is a build defect: std::logic_error naming the field).
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

// Checks every input (a PlanError names the option and its range or its allowed values) and
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

namespace detail {
// The table and schema of a plan document (compare/plan.json's format), every field checked:
// std::logic_error naming the path and the field otherwise. path_table() is this of the
// built-in file; exposed for the tests of malformed documents.
struct PlanData {
    std::string job_format;
    int job_schema_version = 0;
    std::vector<PathInfo> paths;
};
PlanData parse_plan(std::string_view document);
}  // namespace detail

// `airmass compare --list-paths [--json]`.
nlohmann::json path_list_json();
std::string path_list_text();

}  // namespace airmass::compare
