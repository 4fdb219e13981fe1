// `airmass vdb`: the scene's atmosphere as sparse OpenVDB grids (one float grid per
// constituent) and/or as analytic densities (JSON, POV-Ray include, df3); docs/vdb.md.
//
//   airmass vdb (--preset NAME | SCENE.toml) -o atmosphere.vdb [--region planet|view|box
//       --voxel-size L --units km|m --origin surface|center --box X0,Y0,Z0,X1,Y1,Z1
//       --tolerance TAU --max-dense-mb N --max-memory-mb N --tile-voxels N --max-tiles N
//       --rgb auto|bruneton|schuler --voxel-values auto|average|point --default-camera --analytic F.json --pov F.inc
//       --df3 STEM --dry-run --json --threads N --quiet]
//
// Before writing it prints what Blender 3.4 will pay (active voxels, memory, dense
// boxes); outputs are written atomically and Ctrl-C leaves no file.
#include <tbb/global_control.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "airmass/atomic_file.hpp"
#include "airmass/progress.hpp"
#include "airmass/terminal.hpp"
#include "airmass/scene_io.hpp"
#include "airmass/vdb_export.hpp"
#include "commands.hpp"
#include "vdb_module.hpp"

namespace airmass::cli {

namespace {

struct VdbCliOptions {
    std::string scene_path, preset, output, region = "planet", units = "km", origin = "surface", box, rgb = "auto",
                voxel_values = "auto";
    std::optional<double> voxel_size;
    double tolerance = VdbOptions{}.tolerance;
    double max_dense_mb = VdbOptions{}.max_dense_mb;
    double max_memory_mb = VdbOptions{}.max_memory_mb;
    int tile_voxels = VdbOptions{}.tile_voxels;
    int max_tiles = VdbOptions{}.max_tiles;
    std::string analytic, pov, df3;
    bool default_camera = false, dry_run = false, json = false, quiet = false;
    int threads = 0;
};

std::array<double, 6> parse_box(const std::string& text) {
    std::vector<std::string> parts;
    std::stringstream ss(text);
    for (std::string part; std::getline(ss, part, ',');) parts.push_back(part);
    if (parts.size() != 6 || text.empty() || text.back() == ',')
        throw CliError("vdb: --box '" + text + "': expected 6 numbers xmin,ymin,zmin,xmax,ymax,zmax");
    std::array<double, 6> b{};
    for (int i = 0; i < 6; ++i) {
        std::size_t used = 0;
        try {
            b[i] = std::stod(parts[i], &used);
        } catch (const std::exception&) {
            used = 0;
        }
        if (used != parts[i].size() || !std::isfinite(b[i]))
            throw CliError("vdb: --box: '" + parts[i] + "' is not a finite number (expected xmin,ymin,zmin,xmax,ymax,zmax)");
    }
    return b;
}

std::string stats_json(const VdbStats& s) {
    using nlohmann::json;
    json grids = json::array();
    for (const auto& g : s.grids)
        grids.push_back(json{{"name", g.name},
                             {"tile", g.tile},
                             {"active_voxels", g.active_voxels},
                             {"dense_voxels", g.dense_voxels},
                             {"memory_bytes", g.memory_bytes},
                             {"bbox_min", {g.bbox[0], g.bbox[1], g.bbox[2]}},
                             {"bbox_max", {g.bbox[3], g.bbox[4], g.bbox[5]}}});
    json files = json::array();
    for (const auto& f : s.files) files.push_back(f.string());
    return json{{"voxel_size", s.voxel_size},
                {"length_unit", std::string(length_unit_name(s.unit))},
                {"tiles", s.tiles},
                {"active_voxels", s.active_voxels},
                {"memory_bytes", s.memory_bytes},
                {"dense_bytes", s.dense_bytes},
                {"dense_bytes_untiled", s.dense_bytes_untiled},
                {"build_seconds", s.build_seconds},
                {"write_seconds", s.write_seconds},
                {"file_bytes", s.file_bytes},
                {"files", files},
                {"grids", grids}}
               .dump(2);
}

}  // namespace

void add_vdb_command(CLI::App& app) {
    auto* cmd = app.add_subcommand(
        "vdb", "Export the atmosphere as sparse OpenVDB grids (one per constituent) and/or analytic densities");
    auto o = std::make_shared<VdbCliOptions>();
    auto* scene_opt = cmd->add_option("scene", o->scene_path, "Scene file (TOML; docs/scene.md)");
    auto* preset_opt = cmd->add_option("--preset", o->preset, "Built-in scene by name (earth, mars, ...)");
    scene_opt->excludes(preset_opt);
    cmd->add_option("-o,--output", o->output, "Output .vdb (tiled: <stem>.NNN.tile.vdb + <stem>.tiles.json)");
    cmd->add_option("--region", o->region, "planet (whole shell), view (what [camera] sees) or box")
        ->check(CLI::IsMember({"planet", "view", "box"}))
        ->capture_default_str();
    cmd->add_option("--voxel-size", o->voxel_size, "Voxel edge in --units  [default: automatic, docs/vdb.md]")
        ->check(number_in(0.0, 1e6, Ends::open_low));
    cmd->add_option("--units", o->units, "Length unit of the world: km (1 BU = 1 km) or m")
        ->check(CLI::IsMember({"km", "m"}))
        ->capture_default_str();
    cmd->add_option("--origin", o->origin, "World origin: surface (planet centre at (0,0,-R)) or center")
        ->check(CLI::IsMember({"surface", "center"}))
        ->capture_default_str();
    cmd->add_option("--box", o->box, "--region box: xmin,ymin,zmin,xmax,ymax,zmax in --units");
    cmd->add_option("--tolerance", o->tolerance,
                    "Optical depth the inactive cells of a constituent may remove from any ray")
        ->check(number_in(0.0, 1e300))
        ->capture_default_str();
    cmd->add_option("--max-dense-mb", o->max_dense_mb, "Refuse when Blender 3.4's dense boxes exceed this (MiB)")
        ->check(number_in(0.0, 1e12, Ends::open_low))
        ->capture_default_str();
    cmd->add_option("--max-memory-mb", o->max_memory_mb, "Refuse before building grids larger than this (MiB)")
        ->check(number_in(0.0, 1e12, Ends::open_low))
        ->capture_default_str();
    cmd->add_option("--tile-voxels", o->tile_voxels, "Tile edge in voxels, a multiple of 8 in [8, 65536]; 0 automatic, -1 one tile (below 24, Cycles before Blender 5.0 can still drop a tile where two tiles' mesh offsets coincide: docs/vdb.md, Tiling)")
        ->check(int_in(-1, 65536))  // and a multiple of 8: check_options (vdb_export)
        ->capture_default_str();
    cmd->add_option("--max-tiles", o->max_tiles, "Most tiles automatic tiling may use")
        ->check(int_in(1, 100000))
        ->capture_default_str();
    cmd->add_option("--rgb", o->rgb, "RGB wavelengths: auto, bruneton (680/550/440 nm), schuler (615/535/445 nm)")
        ->check(CLI::IsMember({"auto", "bruneton", "schuler"}))
        ->capture_default_str();
    cmd->add_option("--voxel-values", o->voxel_values,
                    "average: each voxel the density's mean over its trilinear footprint (rays across a layer keep "
                    "its mass at any voxel size); point: the density at its centre (exact at the ground); auto: "
                    "average for a constituent whose thinnest layer is under two voxels and which the camera looks "
                    "across (from above it; always for planet and box), else point (docs/vdb.md, Voxel values)")
        ->check(CLI::IsMember({"auto", "average", "point"}))
        ->capture_default_str();
    cmd->add_flag("--default-camera", o->default_camera,
                  "--region view on a scene without [camera]: use the default one (ground, +X, 60 deg, 200 km)");
    cmd->add_option("--analytic", o->analytic, "Also write the analytic density description (JSON)");
    cmd->add_option("--pov", o->pov, "Also write a POV-Ray include with the density functions");
    cmd->add_option("--df3", o->df3, "Also write POV-Ray density files <STEM>.<grid>.df3 + <STEM>.df3.inc");
    cmd->add_flag("--dry-run", o->dry_run, "Build and report, write no grid");
    cmd->add_flag("--json", o->json, "Print the report as JSON on stdout");
    cmd->add_option("--threads", o->threads, "Worker threads (0: all)")->check(int_in(0, 4096))->capture_default_str();
    cmd->add_flag("-q,--quiet", o->quiet, "No progress bar or report");

    cmd->callback([o] {
        if (o->scene_path.empty() == o->preset.empty())
            throw CliError("vdb: give a scene file or --preset NAME (one of them)");
        if (o->output.empty() && !o->dry_run && o->analytic.empty() && o->pov.empty() && o->df3.empty())
            throw CliError("vdb: nothing to write: give -o FILE.vdb (or --analytic, --pov, --df3, --dry-run)");
        if (o->threads < 0) throw CliError("vdb: --threads " + std::to_string(o->threads) + ": must be >= 0");
        Scene scene = o->preset.empty() ? load_scene_file(o->scene_path) : load_preset(o->preset);
        if (o->default_camera && !scene.camera) scene.camera = Camera{};

        VdbOptions opt;
        opt.region = o->region == "view" ? VdbRegion::view : o->region == "box" ? VdbRegion::box : VdbRegion::planet;
        opt.unit = o->units == "m" ? LengthUnit::m : LengthUnit::km;
        opt.origin = o->origin == "center" ? PlanetOrigin::center : PlanetOrigin::surface;
        opt.voxel_size = o->voxel_size;
        if (opt.region == VdbRegion::box) {
            if (o->box.empty()) throw CliError("vdb: --region box needs --box xmin,ymin,zmin,xmax,ymax,zmax");
            opt.box = parse_box(o->box);
        } else if (!o->box.empty()) {
            throw CliError("vdb: --box applies to --region box only");
        }
        opt.tolerance = o->tolerance;
        opt.max_dense_mb = o->max_dense_mb;
        opt.max_memory_mb = o->max_memory_mb;
        opt.tile_voxels = o->tile_voxels;
        opt.max_tiles = o->max_tiles;
        opt.rgb = o->rgb == "bruneton"  ? RgbWavelengths::bruneton
                  : o->rgb == "schuler" ? RgbWavelengths::schuler
                                        : RgbWavelengths::automatic;
        opt.voxel_values = voxel_values_from_name(o->voxel_values).value();  // checked by CLI11

        std::optional<tbb::global_control> threads;
        if (o->threads > 0) threads.emplace(tbb::global_control::max_allowed_parallelism, std::size_t(o->threads));
        // Every destination checked before the expensive part (a second output's folder that
        // cannot be written must not cost a finished .vdb first).
        try {
            for (const std::string* f : {&o->analytic, &o->pov})
                if (!f->empty()) check_output_destination(*f);
            if (!o->df3.empty()) check_output_destination(o->df3 + ".df3.inc");
        } catch (const FileWriteError& e) {
            throw CliError(std::string("vdb: ") + e.what());
        }
        CancelFlag cancel;
        InterruptGuard guard(cancel);

        if (!o->output.empty() || o->dry_run) {
            ProgressBar bar("vdb " + o->region, 1000, stderr_is_terminal() && !o->quiet);
            VdbRunOptions run;
            run.cancel = &cancel;
            run.dry_run = o->dry_run;
            std::size_t shown = 0;
            run.progress = [&](double f) {
                const auto n = std::size_t(f * 1000.0);
                if (n > shown) bar.advance(n - shown), shown = n;
            };
            run.before_write = [&](const VdbStats& s) {
                bar.finish();
                if (!o->quiet && !o->json)
                    std::printf("vdb: %s region, %s", o->region.c_str(), s.summary().c_str());
                std::fflush(stdout);
            };
            const VdbStats stats = vdb_module().export_vdb(scene, opt, o->output.empty() ? "-.vdb" : o->output, run);
            if (o->json) {
                std::printf("%s\n", stats_json(stats).c_str());
            } else if (!o->quiet && !o->dry_run) {
                for (const auto& f : stats.files) std::printf("vdb: wrote %s\n", f.string().c_str());
                std::printf("vdb: %llu active voxels built in %.3f s and written in %.3f s (%.3g voxels/s), %.1f MiB\n",
                            (unsigned long long)stats.active_voxels, stats.build_seconds, stats.write_seconds,
                            double(stats.active_voxels) / (stats.build_seconds + stats.write_seconds),
                            double(stats.file_bytes) / 1048576.0);
            }
        }
        if (!o->analytic.empty()) {
            write_text_atomic(o->analytic, analytic_density_json(scene, opt), &cancel);
            if (!o->quiet) std::printf("vdb: wrote %s\n", o->analytic.c_str());
        }
        if (!o->pov.empty()) {
            write_text_atomic(o->pov, pov_include(scene, opt), &cancel);
            if (!o->quiet) std::printf("vdb: wrote %s\n", o->pov.c_str());
        }
        if (!o->df3.empty()) {
            VdbRunOptions run;
            run.cancel = &cancel;
            for (const auto& f : vdb_module().export_df3(scene, opt, o->df3, run))
                if (!o->quiet) std::printf("vdb: wrote %s\n", f.string().c_str());
        }
    });
}

}  // namespace airmass::cli
