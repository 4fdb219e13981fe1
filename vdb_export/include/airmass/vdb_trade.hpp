// The voxel-size trade (`airmass report vdb`): how much optical depth and
// transmittance a voxel size costs, against what it costs in voxels, memory, dense
// boxes, file size and build time.
//
// Accuracy: a fixed set of rays in the scene's frame (unit km) — zenith, slant (75°
// from the zenith) and horizon from the ground, the horizon from a 1.3-km hill, and the
// limb seen from orbit (tangent at 10.37 km) — all in the plane y = 0.1234 km (off the
// voxel lattice). For each voxel size the grids of a thin box
// ("slab") holding the rays are built with the exporter itself; the optical depth
// through them is the exact integral of OpenVDB's trilinear interpolant (3-point
// Gauss–Legendre between the ray's crossings of the voxel lattice planes, where the
// interpolant is a cubic), compared with the analytic reference: adaptive quadrature
// of DensityProfile::at along the same segment (profile_segment_mass_reference).
//
// Cost: per voxel size, the slab and the Earth view region of the issue (ground
// camera, +X, 60°, 640×360, 200 km) are built and written to a scratch file.
//
// The activity threshold (--tolerance): at one voxel size, the same rays and regions for
// each tolerance. What the inactive cells remove is |τ(tolerance) − τ(0)| through grids on
// the same lattice (the voxel size's own error cancels), against its bound: `tolerance`
// per constituent (VdbOptions::tolerance).
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "airmass/vdb_export.hpp"

namespace airmass {

struct VdbTradeRay {
    std::string name;
    std::array<double, 3> origin_km;  // world frame, origin on the surface, planet centre at (0, 0, −R)
    std::array<double, 3> direction;  // unit
};

// The fixed rays for a scene (its planet radius and atmosphere top).
std::vector<VdbTradeRay> vdb_trade_rays(const Scene& scene);

struct VdbTradeOptions {
    std::vector<double> voxel_sizes{0.25, 0.5, 1, 2, 4, 8};  // km
    // What the voxels hold (VdbOptions::voxel_values), each measured at every voxel size; the
    // tolerance trade uses VdbOptions' default.
    std::vector<VoxelValues> voxel_values{VoxelValues::automatic, VoxelValues::average, VoxelValues::point};
    double tolerance = VdbOptions{}.tolerance;
    bool measure_view_region = true;      // build and write the Earth view region per voxel size
    // The threshold's trade: tolerances (optical depth, ≥ 0; 0 is the baseline and is measured
    // whether listed or not), at one voxel size (km). Empty: not measured.
    std::vector<double> tolerances{1e-6, 1e-5, 1e-4, 1e-3, 1e-2};
    double tolerance_voxel_size = 1.0;
    std::filesystem::path scratch_dir;    // for the timed writes (empty: the system temp dir)
    VdbProgress progress;                  // fraction of voxel sizes done
    const CancelFlag* cancel = nullptr;
};

struct VdbTradeRayRow {
    double voxel_size = 0;  // km
    VoxelValues voxel_values = VoxelValues::average;
    std::string ray;
    std::array<double, 3> tau_ref{}, tau_vdb{};  // RGB optical depth
    double tau_rel_error_max = 0;                 // max over RGB of |τ_vdb − τ_ref| / τ_ref
    double transmittance_abs_error_max = 0;       // max over RGB of |T_vdb − T_ref|
};

struct VdbTradeCostRow {
    double voxel_size = 0;  // km
    VoxelValues voxel_values = VoxelValues::average;
    double tolerance = 0;   // VdbOptions::tolerance of the build
    std::string region;     // "slab" or "view-200km"
    bool refused = false;   // the exporter refused (limit); message in `note`
    std::string note;
    std::uint64_t active_voxels = 0, memory_bytes = 0, dense_bytes = 0, file_bytes = 0;
    std::size_t tiles = 0;
    double build_seconds = 0, write_seconds = 0;
};

struct VdbToleranceRayRow {
    double tolerance = 0;  // optical depth
    std::string ray;
    std::array<double, 3> tau_vdb{};  // RGB optical depth through the grids at this tolerance
    double tau_removed_max = 0;       // max over RGB of τ(0) − τ(tolerance): what the inactive cells remove
    double tau_rel_error_max = 0;     // against the analytic value (the voxel size's error included)
};

struct VdbTradeResult {
    std::vector<VdbTradeRayRow> rays;    // voxel-size major, rays in vdb_trade_rays order
    std::vector<VdbTradeCostRow> costs;  // voxel-size major
    // The threshold's trade at options.tolerance_voxel_size: tolerance 0 first, then ascending.
    double tolerance_voxel_size = 0;  // km
    std::size_t constituents = 0;     // with a grid: the bound is tolerance × this
    std::vector<VdbToleranceRayRow> tolerance_rays;    // tolerance major
    std::vector<VdbTradeCostRow> tolerance_costs;      // tolerance major
};

VdbTradeResult run_vdb_trade(const Scene& scene, const VdbTradeOptions& options);

// The tolerances run_vdb_trade measures: 0 (the baseline) first, then options.tolerances
// ascending, each once; none when options.tolerances is empty. (Finite values ≥ 0: the run
// refuses others before this.)
std::vector<double> vdb_trade_tolerances(const VdbTradeOptions& options);
// The steps run_vdb_trade's progress counts: one per voxel size, one per measured tolerance.
std::size_t vdb_trade_steps(const VdbTradeOptions& options);

// vdb_trade_rays.csv, vdb_trade_costs.csv and the Markdown tables of docs/vdb.md; the
// threshold's: vdb_tolerance_rays.csv, vdb_tolerance_costs.csv and their Markdown (empty when
// not measured).
std::string vdb_trade_rays_csv(const VdbTradeResult& r);
std::string vdb_trade_costs_csv(const VdbTradeResult& r);
std::string vdb_trade_markdown(const VdbTradeResult& r, const std::string& scene_name);
std::string vdb_tolerance_rays_csv(const VdbTradeResult& r);
std::string vdb_tolerance_costs_csv(const VdbTradeResult& r);
std::string vdb_tolerance_markdown(const VdbTradeResult& r, const std::string& scene_name);

}  // namespace airmass
