// The C ABI's volume functions (airmass_c.h, "Volumes"): the plan and the dense blocks of the
// OpenVDB-free volume layer (vdb_export/include/airmass/volume.hpp), which the host turns into
// OpenVDB grids and files itself. Nothing here links OpenVDB or writes a file.
#include "capi_internal.hpp"

#include <algorithm>
#include <type_traits>
#include <variant>

#include "airmass/volume.hpp"

namespace airmass::capi {
namespace {

airmass::VdbOptions vdb_options_from(const airmass_vdb_options* o) {
    require_struct(o, "vdb_options");
    airmass::VdbOptions v;
    const std::string region = o->region ? o->region : "planet";
    if (region == "planet") v.region = airmass::VdbRegion::planet;
    else if (region == "view") v.region = airmass::VdbRegion::view;
    else if (region == "box") v.region = airmass::VdbRegion::box;
    else throw AbiError(AIRMASS_INVALID_ARGUMENT, "--region = \"" + region + "\": must be planet, view or box");
    const std::string unit = o->unit ? o->unit : "km";
    if (unit == "km") v.unit = airmass::LengthUnit::km;
    else if (unit == "m") v.unit = airmass::LengthUnit::m;
    else throw AbiError(AIRMASS_INVALID_ARGUMENT, "--units = \"" + unit + "\": must be km or m");
    v.origin = o->origin_center ? airmass::PlanetOrigin::center : airmass::PlanetOrigin::surface;
    if (given(o->voxel_size) && o->voxel_size > 0.0) v.voxel_size = o->voxel_size;
    else if (given(o->voxel_size) && o->voxel_size < 0.0)
        throw airmass::VdbError("--voxel-size " + number(o->voxel_size) + ": must be > 0 (or 0 for automatic)");
    std::copy(o->box, o->box + 6, v.box.begin());
    if (given(o->tolerance)) v.tolerance = o->tolerance;
    if (given(o->max_dense_mb)) v.max_dense_mb = o->max_dense_mb;
    v.tile_voxels = o->tile_voxels;
    const std::string values = o->voxel_values ? o->voxel_values : "auto";
    if (const auto choice = airmass::voxel_values_from_name(values)) v.voxel_values = *choice;
    else throw AbiError(AIRMASS_INVALID_ARGUMENT, "--voxel-values = \"" + values + "\": must be auto, average or point");
    return v;
}

nlohmann::json ints(const std::array<std::int32_t, 3>& a) { return nlohmann::json::array({a[0], a[1], a[2]}); }

// {key: value} and {key: type} of the volume layer's typed metadata.
void put_metadata(nlohmann::json& into, const std::vector<airmass::VolumeMetadatum>& entries) {
    nlohmann::json values = nlohmann::json::object(), types = nlohmann::json::object();
    for (const auto& e : entries) {
        std::visit(
            [&](const auto& v) {
                using T = std::decay_t<decltype(v)>;
                if constexpr (std::is_same_v<T, std::array<double, 3>>) values[e.key] = {v[0], v[1], v[2]};
                else values[e.key] = v;
            },
            e.value);
        types[e.key] = std::string(airmass::volume_meta_type(e.value));
    }
    into["metadata"] = std::move(values);
    into["metadata_types"] = std::move(types);
}

std::string plan_json(const airmass::VolumePlan& plan, const std::string& stem) {
    using nlohmann::json;
    const airmass::VdbLayout& L = plan.layout;
    const airmass::VdbStats& s = plan.stats;
    const double v = L.voxel_size;
    json j;
    j["format"] = "airmass-vdb-plan";
    j["format_version"] = 2;  // 2: per-file index_offset and transform (tiles on shifted lattices)
    j["unit"] = std::string(airmass::length_unit_name(L.options.unit));
    j["region"] = std::string(airmass::region_name(L.options.region));
    j["voxel_size"] = v;
    j["voxel_size_automatic"] = L.voxel_size_automatic;
    j["transform"] = {
        {"voxel_size", {v, v, v}},
        {"translation", {0.0, 0.0, 0.0}},
        {"matrix", {{v, 0.0, 0.0, 0.0}, {0.0, v, 0.0, 0.0}, {0.0, 0.0, v, 0.0}, {0.0, 0.0, 0.0, 1.0}}},
        {"convention",
         "OpenVDB linear transform: world = translation + voxel_size * (i, j, k); the value of voxel (i, j, k) is "
         "the density at that world point, the centre of the voxel's cell [i - 1/2, i + 1/2] * voxel_size"}};
    j["grid_class"] = std::string(airmass::kVolumeGridClass);
    j["value_type"] = "float";
    j["background"] = 0.0;
    const airmass::VoxelBox rb = airmass::volume_request_bounds(L);
    j["request_bounds"] = {{"min", ints(rb.min)}, {"max", ints(rb.max)}};
    j["tile_count"] = s.tiles;
    j["tiling"] = {{"tile_voxels", plan.tiling.tile_voxels}, {"base", ints(plan.tiling.base)}};
    // Index spaces: every bbox_min/bbox_max/dense_bbox_* below and "request_bounds" are in the common
    // lattice of "transform". File t's grids are on the tile's own lattice: their voxel (i, j, k) is
    // common voxel (i, j, k) + files[t].index_offset, and their transform is files[t].transform (the
    // common one translated by index_offset voxels): the same world positions, leaves shifted
    // (docs/vdb.md "Tiling").
    j["index_space"] =
        "bboxes and request_bounds: the common lattice of transform; file t's grids: voxel (i, j, k) is common voxel "
        "(i, j, k) + files[t].index_offset, their transform files[t].transform";
    // Guards (several tiles only): each tile's grid also holds, at this value, the active voxels
    // of the other tiles within one voxel (26 neighbours) of its values (docs/vdb.md "Tiling").
    j["guard_value"] = airmass::kVolumeGuardValue;
    const std::vector<std::string> names = airmass::volume_file_names(stem, s.tiles);
    json grids = json::array();
    json files = json::array();
    for (std::size_t t = 0; t < s.tiles; ++t) {
        const airmass::VoxelCoord o = plan.index_offset(t);
        json f{{"name", names[t]},
               {"tile", t},
               {"index_offset", ints(o)},
               {"transform",
                {{"voxel_size", {v, v, v}},
                 {"translation", {o[0] * v, o[1] * v, o[2] * v}},
                 {"matrix", {{v, 0.0, 0.0, 0.0}, {0.0, v, 0.0, 0.0}, {0.0, 0.0, v, 0.0}, {o[0] * v, o[1] * v, o[2] * v, 1.0}}}}},
               {"grids", json::array()}};
        put_metadata(f, airmass::volume_file_metadata(L, t, s.tiles));
        files.push_back(std::move(f));
    }
    for (std::size_t i = 0; i < s.grids.size(); ++i) {
        const airmass::VdbGridStats& g = s.grids[i];
        json e{{"index", i},
               {"name", g.name},
               {"tile", g.tile},
               {"bbox_min", {g.bbox[0], g.bbox[1], g.bbox[2]}},
               {"bbox_max", {g.bbox[3], g.bbox[4], g.bbox[5]}},
               {"dim", {g.bbox[3] - g.bbox[0] + 1, g.bbox[4] - g.bbox[1] + 1, g.bbox[5] - g.bbox[2] + 1}},
               {"active_voxels", g.active_voxels},
               {"dense_bbox_min", {g.dense_bbox[0], g.dense_bbox[1], g.dense_bbox[2]}},
               {"dense_bbox_max", {g.dense_bbox[3], g.dense_bbox[4], g.dense_bbox[5]}},
               {"dense_voxels", g.dense_voxels},
               {"dense_bytes", g.dense_voxels * sizeof(float)},
               {"memory_bytes_estimate", g.memory_bytes}};
        e["index_offset"] = ints(plan.index_offset(g.tile));
        put_metadata(e, airmass::volume_grid_metadata(L, plan.grid_constituent[i], g.tile, s.tiles, plan.index_offset(g.tile)));
        files[g.tile]["grids"].push_back(i);
        grids.push_back(std::move(e));
    }
    j["grids"] = std::move(grids);
    j["files"] = std::move(files);
    if (s.tiles > 1)
        j["manifest"] = {{"name", names.back()}, {"text", airmass::volume_tiles_manifest(L, s, names)}};
    else
        j["manifest"] = nullptr;
    j["active_voxels"] = s.active_voxels;
    j["dense_bytes"] = s.dense_bytes;
    j["dense_bytes_untiled"] = s.dense_bytes_untiled;
    j["memory_bytes_estimate"] = s.memory_bytes;
    j["build_seconds"] = s.build_seconds;
    j["summary"] = s.summary();
    return j.dump();
}

std::string box_text(const int32_t (&a)[3]) {
    return "(" + std::to_string(a[0]) + ", " + std::to_string(a[1]) + ", " + std::to_string(a[2]) + ")";
}

// The block's box, checked against the layout: every refusal names the field and its range.
airmass::VoxelBox block_box(const airmass_vdb_block& b, const airmass::VdbLayout& layout) {
    const airmass::VoxelBox bounds = airmass::volume_request_bounds(layout);
    airmass::VoxelBox box;
    for (int a = 0; a < 3; ++a) {
        const std::string i = "[" + std::to_string(a) + "]";
        const std::string range = "must be in [" + std::to_string(bounds.min[a]) + ", " + std::to_string(bounds.max[a]) +
                                  "] (the region's index bounds, the plan's \"request_bounds\")";
        if (b.min[a] < bounds.min[a] || b.min[a] > bounds.max[a])
            throw AbiError(AIRMASS_INVALID_ARGUMENT, "block.min" + i + " = " + std::to_string(b.min[a]) + ": " + range);
        if (b.max[a] < bounds.min[a] || b.max[a] > bounds.max[a])
            throw AbiError(AIRMASS_INVALID_ARGUMENT, "block.max" + i + " = " + std::to_string(b.max[a]) + ": " + range);
        if (b.min[a] > b.max[a])
            throw AbiError(AIRMASS_INVALID_ARGUMENT, "block.min" + i + " = " + std::to_string(b.min[a]) +
                                                         " > block.max" + i + " = " + std::to_string(b.max[a]) +
                                                         ": the box must hold at least one voxel (min <= max)");
        box.min[a] = b.min[a];
        box.max[a] = b.max[a];
    }
    return box;
}

std::size_t grid_index(const char* name, const airmass::VdbLayout& layout) {
    if (!name) throw AbiError(AIRMASS_INVALID_ARGUMENT, "block.grid: NULL (a grid name of the plan)");
    std::string names;
    for (std::size_t c = 0; c < layout.constituents.size(); ++c) {
        if (layout.constituents[c].name == name) return c;
        names += (names.empty() ? "" : ", ") + ("\"" + layout.constituents[c].name + "\"");
    }
    throw AbiError(AIRMASS_INVALID_ARGUMENT, std::string("block.grid = \"") + name +
                                                 "\": not a grid of this volume (its grids: " + names + ")");
}

// The sun tables' sizes and the caller's buffer, checked before any work (a wrong buffer is refused
// at once, not after seconds of a large table): VdbError for a size outside [2, 4096] (the library's
// own check), AbiError for a NULL or wrongly sized buffer.
void check_sun_table_buffer(const char* what, int32_t mu_size, int32_t r_size, const float* values,
                            size_t float_count, std::size_t per_texel, const char* per_texel_name) {
    airmass::check_sun_table_sizes(what, mu_size, r_size);
    if (!values) throw AbiError(AIRMASS_INVALID_ARGUMENT, "values: NULL pointer");
    const std::size_t expected = std::size_t(mu_size) * std::size_t(r_size) * per_texel;
    if (float_count != expected)
        throw AbiError(AIRMASS_INVALID_ARGUMENT, "float_count = " + std::to_string(float_count) +
                                                     ": must be r_size × mu_size × " + per_texel_name + " = " +
                                                     std::to_string(expected));
}

// The plan of the sampler's layout as JSON (airmass_vdb_plan, airmass_vdb_session_plan).
void plan_into(const airmass::VolumeSampler& sampler, const char* file_stem, const airmass_job* job, char** plan_out) {
    if (!plan_out) throw AbiError(AIRMASS_INVALID_ARGUMENT, "plan_json: NULL pointer");
    const std::string stem = file_stem ? file_stem : "atmosphere";
    if (stem.empty() || stem.find_first_of("/\\") != std::string::npos)
        throw AbiError(AIRMASS_INVALID_ARGUMENT,
                       "file_stem = \"" + stem + "\": must be a non-empty file name without a folder");
    std::string text;
    run_job(job, [&](const airmass::CancelFlag& cancel, std::atomic<double>& fraction) {
        airmass::VolumeRunOptions run;
        run.cancel = &cancel;
        run.progress = [&](double f) { fraction.store(std::clamp(f, 0.0, 1.0), std::memory_order_relaxed); };
        text = plan_json(airmass::plan_volume(sampler, run), stem);
    });
    *plan_out = duplicate(text);
}

// One grid's dense block (airmass_vdb_grid_values, airmass_vdb_session_grid_values).
void grid_values_into(const airmass::VolumeSampler& sampler, const airmass_vdb_block* block, float* values,
                      size_t float_count, const airmass_job* job) {
    const airmass::VdbLayout& layout = sampler.layout();
    require_struct(block, "block");
    if (block->threads < 0)
        throw AbiError(AIRMASS_INVALID_ARGUMENT,
                       "block.threads = " + std::to_string(block->threads) + ": must be >= 0 (0: all hardware threads)");
    if (!values) throw AbiError(AIRMASS_INVALID_ARGUMENT, "values: NULL pointer");
    const std::size_t c = grid_index(block->grid, layout);
    const airmass::VoxelBox box = block_box(*block, layout);
    if (std::uint64_t(float_count) != box.volume())
        throw AbiError(AIRMASS_INVALID_ARGUMENT,
                       "float_count = " + std::to_string(float_count) + ": must be nx x ny x nz = " +
                           std::to_string(box.dim(0)) + " x " + std::to_string(box.dim(1)) + " x " +
                           std::to_string(box.dim(2)) + " = " + std::to_string(box.volume()) + " for block.min " +
                           box_text(block->min) + " to block.max " + box_text(block->max));
    run_job(job, [&](const airmass::CancelFlag& cancel, std::atomic<double>& fraction) {
        airmass::VolumeRunOptions run;
        run.cancel = &cancel;
        run.threads = block->threads;
        run.progress = [&](double f) { fraction.store(std::clamp(f, 0.0, 1.0), std::memory_order_relaxed); };
        airmass::sample_volume_box(sampler, c, box, std::span<float>(values, float_count), run);
    });
}

}  // namespace
}  // namespace airmass::capi

// A VDB session: the scene, the layout resolved from it (its constituents point into the scene)
// and the sampler (which refers to the layout): built in place, never moved. The sampler keeps
// the plan's pass's blocks (up to kKeepBytes of values, and not more than the grids' own
// --max-memory-mb) for the grids' values asked after it.
struct airmass_vdb_session {
    static constexpr std::size_t kKeepBytes = std::size_t(256) << 20;
    airmass::Scene scene;
    airmass::VdbLayout layout;
    airmass::VolumeSampler sampler;
    airmass_vdb_session(airmass::Scene s, const airmass::VdbOptions& options)
        : scene(std::move(s)),
          layout(airmass::resolve_vdb_layout(scene, options)),
          sampler(layout, std::size_t(std::clamp(options.max_memory_mb * 1048576.0, 0.0, double(kKeepBytes)))) {}
    airmass_vdb_session(const airmass_vdb_session&) = delete;
    airmass_vdb_session& operator=(const airmass_vdb_session&) = delete;
};

using namespace airmass::capi;

extern "C" {

int32_t airmass_vdb_options_init(airmass_vdb_options* options) {
    if (!init_size_ok(options)) return AIRMASS_INVALID_ARGUMENT;
    const double nan = std::numeric_limits<double>::quiet_NaN();
    *options = airmass_vdb_options{};
    options->struct_size = sizeof(airmass_vdb_options);
    options->region = "planet";
    options->unit = "km";
    options->origin_center = 0;
    options->voxel_size = nan;
    options->tolerance = nan;
    options->max_dense_mb = nan;
    options->tile_voxels = 0;
    options->voxel_values = "auto";
    return AIRMASS_OK;
}

int32_t airmass_vdb_block_init(airmass_vdb_block* block) {
    if (!init_size_ok(block)) return AIRMASS_INVALID_ARGUMENT;
    *block = airmass_vdb_block{};
    block->struct_size = sizeof(airmass_vdb_block);
    block->grid = nullptr;
    for (int a = 0; a < 3; ++a) {
        block->min[a] = 0;
        block->max[a] = -1;
    }
    block->threads = 0;
    return AIRMASS_OK;
}

int32_t airmass_vdb_plan(const airmass_scene_spec* spec, const airmass_vdb_options* options, const char* file_stem,
                         const airmass_job* job, char** plan_out, char* message, size_t message_size) {
    return guarded(message, message_size, [&] {
        const airmass::VdbOptions vdb = vdb_options_from(options);
        const Scene scene = build_scene(spec);
        const airmass::VdbLayout layout = airmass::resolve_vdb_layout(scene, vdb);
        const airmass::VolumeSampler sampler(layout);
        plan_into(sampler, file_stem, job, plan_out);
    });
}

int32_t airmass_vdb_grid_values(const airmass_scene_spec* spec, const airmass_vdb_options* options,
                                const airmass_vdb_block* block, float* values, size_t float_count,
                                const airmass_job* job, char* message, size_t message_size) {
    return guarded(message, message_size, [&] {
        const airmass::VdbOptions vdb = vdb_options_from(options);
        const Scene scene = build_scene(spec);
        const airmass::VdbLayout layout = airmass::resolve_vdb_layout(scene, vdb);
        const airmass::VolumeSampler sampler(layout);
        grid_values_into(sampler, block, values, float_count, job);
    });
}

int32_t airmass_vdb_session_create(const airmass_scene_spec* spec, const airmass_vdb_options* options,
                                   airmass_vdb_session** out, char* message, size_t message_size) {
    if (out) *out = nullptr;
    return guarded(message, message_size, [&] {
        const airmass::VdbOptions vdb = vdb_options_from(options);
        if (!out) throw AbiError(AIRMASS_INVALID_ARGUMENT, "out: NULL pointer");
        *out = new airmass_vdb_session(build_scene(spec), vdb);
    });
}

int32_t airmass_vdb_session_plan(const airmass_vdb_session* session, const char* file_stem, const airmass_job* job,
                                 char** plan_out, char* message, size_t message_size) {
    return guarded(message, message_size, [&] {
        if (!session) throw AbiError(AIRMASS_INVALID_ARGUMENT, "session: NULL pointer");
        plan_into(session->sampler, file_stem, job, plan_out);
    });
}

int32_t airmass_vdb_session_grid_values(const airmass_vdb_session* session, const airmass_vdb_block* block,
                                        float* values, size_t float_count, const airmass_job* job, char* message,
                                        size_t message_size) {
    return guarded(message, message_size, [&] {
        if (!session) throw AbiError(AIRMASS_INVALID_ARGUMENT, "session: NULL pointer");
        grid_values_into(session->sampler, block, values, float_count, job);
    });
}

void airmass_vdb_session_free(airmass_vdb_session* session) { delete session; }

int32_t airmass_analytic_density_json(const airmass_scene_spec* spec, const airmass_vdb_options* options,
                                      char** json, char* message, size_t message_size) {
    return guarded(message, message_size, [&] {
        const airmass::VdbOptions vdb = vdb_options_from(options);
        if (!json) throw AbiError(AIRMASS_INVALID_ARGUMENT, "json: NULL pointer");
        const Scene scene = build_scene(spec);
        *json = duplicate(airmass::analytic_density_json(scene, vdb));
    });
}

int32_t airmass_sun_column_table(const airmass_scene_spec* spec, const airmass_vdb_options* options,
                                 int32_t mu_size, int32_t r_size, float* values, size_t float_count, char* message,
                                 size_t message_size) {
    return guarded(message, message_size, [&] {
        const airmass::VdbOptions vdb = vdb_options_from(options);
        const Scene scene = build_scene(spec);
        const airmass::VdbLayout layout = airmass::resolve_vdb_layout(scene, vdb);  // once: the count and the table
        const std::size_t count = layout.constituents.size();
        check_sun_table_buffer("sun column table", mu_size, r_size, values, float_count, count,
                               (std::to_string(count) + " constituents").c_str());
        const airmass::SunColumnTable table = airmass::sun_column_table(scene, layout, mu_size, r_size);
        std::copy(table.mass.begin(), table.mass.end(), values);
    });
}

int32_t airmass_sun_ms_table(const airmass_scene_spec* spec, const airmass_vdb_options* options, int32_t mu_size,
                             int32_t r_size, float* values, size_t float_count, double* mu_s_min, char* message,
                             size_t message_size) {
    return guarded(message, message_size, [&] {
        const airmass::VdbOptions vdb = vdb_options_from(options);
        if (!mu_s_min) throw AbiError(AIRMASS_INVALID_ARGUMENT, "mu_s_min: NULL pointer");
        const Scene scene = build_scene(spec);
        check_sun_table_buffer("sun multiple-scattering table", mu_size, r_size, values, float_count, 3, "3");
        const airmass::SunMsTable table = airmass::sun_ms_table(scene, vdb, mu_size, r_size);
        std::copy(table.psi.begin(), table.psi.end(), values);
        *mu_s_min = table.mu_s_min;
    });
}

}  // extern "C"
