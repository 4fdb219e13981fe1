// `airmass report vdb --out DIR`: the voxel-size trade of the OpenVDB export — optical
// depth and transmittance through the grids vs the analytic value along fixed rays,
// and what each voxel size costs (docs/vdb.md). Writes
//   vdb_trade_rays.csv    voxel size, ray, RGB optical depth reference / grid, errors
//   vdb_trade_costs.csv   voxel size, region, active voxels, memory, dense boxes, file, times
//   vdb_trade.md          the Markdown tables docs/vdb.md shows
//   vdb_tolerance_rays.csv, vdb_tolerance_costs.csv, vdb_tolerance.md
//                         the activity threshold (--tolerance of `airmass vdb`): optical depth the
//                         inactive cells remove, against its bound, and what each tolerance costs
// scripts/plot_vdb_trade.py turns the CSVs into vdb_trade.png.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "airmass/progress.hpp"
#include "airmass/terminal.hpp"
#include "airmass/scene_io.hpp"
#include "airmass/vdb_export.hpp"
#include "airmass/vdb_trade.hpp"
#include "commands.hpp"
#include "vdb_module.hpp"
#include "csv.hpp"

namespace airmass::cli {

namespace {

struct ReportVdbOptions {
    std::string out, scene_path, preset = "earth", sizes, tolerances;
    double tolerance_voxel = 1.0;
    bool no_view = false, no_tolerance = false, quiet = false;
};

std::vector<double> parse_sizes(const std::string& text) {
    return parse_number_list(text, "report vdb: --voxel-sizes", "a length > 0 (km)", [](double v) { return v > 0.0; });
}

std::vector<double> parse_tolerances(const std::string& text) {
    return parse_number_list(text, "report vdb: --tolerances", "an optical depth >= 0",
                             [](double v) { return std::isfinite(v) && v >= 0.0; });
}

}  // namespace

void add_report_vdb(CLI::App& report) {
    auto* cmd = report.add_subcommand("vdb", "Voxel size vs optical-depth error and cost of the OpenVDB export");
    auto o = std::make_shared<ReportVdbOptions>();
    cmd->add_option("--out", o->out, "Output directory")->required();
    auto* scene_opt = cmd->add_option("scene", o->scene_path, "Scene file (TOML) instead of the preset");
    cmd->add_option("--preset", o->preset, "Built-in scene")->capture_default_str()->excludes(scene_opt);
    cmd->add_option("--voxel-sizes", o->sizes, "Comma-separated voxel sizes in km  [default 0.25,0.5,1,2,4,8]");
    cmd->add_flag("--no-view", o->no_view, "Skip the cost of the Earth view region (faster)");
    cmd->add_option("--tolerances", o->tolerances,
                    "Comma-separated activity tolerances (optical depth) to measure; 0, the baseline, is always "
                    "measured  [default 1e-6,1e-5,1e-4,1e-3,1e-2]");
    cmd->add_option("--tolerance-voxel-size", o->tolerance_voxel, "Voxel size of the tolerance trade, km")
        ->check(number_in(1e-3, 1e3))
        ->capture_default_str();
    cmd->add_flag("--no-tolerance", o->no_tolerance, "Skip the tolerance trade");
    cmd->add_flag("-q,--quiet", o->quiet, "No progress bar");
    cmd->callback([o] {
        namespace fs = std::filesystem;
        VdbTradeOptions t;
        if (!o->sizes.empty()) t.voxel_sizes = parse_sizes(o->sizes);  // refused before --out is created
        if (!o->tolerances.empty()) t.tolerances = parse_tolerances(o->tolerances);
        if (o->no_tolerance) t.tolerances.clear();
        t.tolerance_voxel_size = o->tolerance_voxel;
        const fs::path dir(o->out);
        std::error_code ec;
        fs::create_directories(dir, ec);
        if (!fs::is_directory(dir)) throw CliError("report vdb: --out '" + o->out + "' is not a directory");
        const Scene scene = o->scene_path.empty() ? load_preset(o->preset) : load_scene_file(o->scene_path);
        t.measure_view_region = !o->no_view;
        t.scratch_dir = dir;
        CancelFlag cancel;
        InterruptGuard guard(cancel);
        t.cancel = &cancel;
        const std::size_t steps = vdb_trade_steps(t);  // the library's count: tolerances de-duplicated, 0 once
        ProgressBar bar("report vdb", steps, stderr_is_terminal() && !o->quiet);
        std::size_t shown = 0;
        t.progress = [&](double f) {
            const auto n = std::size_t(std::lround(f * double(steps)));
            if (n > shown) bar.advance(n - shown), shown = n;
        };
        const VdbTradeResult r = vdb_module().run_vdb_trade(scene, t);
        bar.finish();
        write_text_atomic(dir / "vdb_trade_rays.csv", vdb_trade_rays_csv(r));
        write_text_atomic(dir / "vdb_trade_costs.csv", vdb_trade_costs_csv(r));
        const std::string md = vdb_trade_markdown(r, scene.name);
        write_text_atomic(dir / "vdb_trade.md", md);
        std::printf("%s", md.c_str());
        if (!r.tolerance_rays.empty()) {
            write_text_atomic(dir / "vdb_tolerance_rays.csv", vdb_tolerance_rays_csv(r));
            write_text_atomic(dir / "vdb_tolerance_costs.csv", vdb_tolerance_costs_csv(r));
            const std::string tmd = vdb_tolerance_markdown(r, scene.name);
            write_text_atomic(dir / "vdb_tolerance.md", tmd);
            std::printf("\n%s", tmd.c_str());
        }
    });
}

}  // namespace airmass::cli
