// The atmosphere as volumes a renderer can read: sparse OpenVDB grids of each
// constituent's relative density, and the same densities as closed-form expressions
// (JSON for the Blender add-on's node tree, a POV-Ray include of function patterns).
//
// Everything a reader needs is in docs/vdb.md: grid names and values, the metadata
// keys, length units, regions, tiling and the voxel-size trade table.
//
// Frame. The scene frame of scene.hpp (Z up, origin on the surface below the
// observer), scaled to the chosen length unit: with `PlanetOrigin::surface` (the
// default) the planet centre is at (0, 0, −R); with `PlanetOrigin::center` the whole
// frame is shifted by +R in z so that the centre is at the origin. Voxel (i, j, k) of
// every grid holds the density at the world point voxel_size · (i, j, k) (OpenVDB's
// convention: values at index points; a pure scale transform, shared by all grids and
// tiles).
//
// This header is free of OpenVDB; airmass/vdb_grids.hpp exposes the grids in memory.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "airmass/scene.hpp"

namespace airmass {

class CancelFlag;

// Every problem with an export request or its output: the message names the option
// (CLI spelling), the value and what is allowed, and suggests a fix where one exists.
struct VdbError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

enum class LengthUnit { km, m };
enum class VdbRegion { planet, view, box };
enum class PlanetOrigin { surface, center };
// The three wavelengths at which each SpectralCoefficient is evaluated to give the
// renderer's R, G, B coefficients.
enum class RgbWavelengths {
    automatic,  // schuler when the scene's basis is rgb_schuler, bruneton otherwise
    bruneton,   // 680, 550, 440 nm (Bruneton 2017 demo, kLambdaR/G/B)
    schuler,    // 615, 535, 445 nm (Schüler 2012 follow-up basis, seed 001)
};

std::string_view length_unit_name(LengthUnit u);  // "km", "m"
double metres_per_unit(LengthUnit u);              // 1000, 1
std::string_view region_name(VdbRegion r);         // "planet", "view", "box"

struct VdbOptions {
    VdbRegion region = VdbRegion::planet;
    LengthUnit unit = LengthUnit::km;
    PlanetOrigin origin = PlanetOrigin::surface;
    // Edge of a voxel in `unit`; empty: automatic (auto_voxel_size).
    std::optional<double> voxel_size;
    // VdbRegion::box: {xmin, ymin, zmin, xmax, ymax, zmax} in `unit`, world frame.
    std::array<double, 6> box{0, 0, 0, 0, 0, 0};
    // Optical depth (in the most extinguishing RGB channel) that the inactive cells of
    // one constituent may remove from any ray: a cell is active when its relative
    // density is ≥ tolerance / (max_rgb(σs + σa) · longest chord through the shell).
    // 0 keeps every cell of the region with a nonzero density.
    double tolerance = 1e-4;
    // Refuse (VdbError) when the dense bounding boxes Blender 3.4 allocates, summed
    // over grids and tiles, exceed this many MiB (4 bytes per voxel of each box).
    double max_dense_mb = 1024.0;
    // Refuse before building when the grids could need more than this many MiB.
    double max_memory_mb = 4096.0;
    // Tiling: 0 = automatic (split when it shrinks the dense boxes), -1 = one tile,
    // N > 0 = tiles of N voxels per edge (a multiple of 8).
    int tile_voxels = 0;
    int max_tiles = 256;
    RgbWavelengths rgb = RgbWavelengths::automatic;
};

// Automatic voxel size in `unit` (docs/vdb.md, "Voxel size"): half the thinnest layer
// among the active constituents (scale height, tent flank, knot spacing); no finer than
// the camera's pixel footprint at the nearest point of the atmosphere it can see (view
// region); and coarse enough that the region's estimated grids fit --max-memory-mb and
// --max-dense-mb.
double auto_voxel_size(const Scene& scene, const VdbOptions& options);

// One grid of the output, as Blender 3.4 will see it.
struct VdbGridStats {
    std::string name;
    std::size_t tile = 0;
    std::uint64_t active_voxels = 0;
    std::array<std::int32_t, 6> bbox{};  // active index bounding box, min then max (inclusive)
    std::uint64_t dense_voxels = 0;      // bbox volume: what Blender 3.4 densifies
    std::uint64_t memory_bytes = 0;      // OpenVDB tree in memory
};

struct VdbStats {
    double voxel_size = 0;  // in the unit
    LengthUnit unit = LengthUnit::km;
    std::size_t tiles = 0;
    std::vector<VdbGridStats> grids;
    std::uint64_t active_voxels = 0;  // summed over grids
    std::uint64_t memory_bytes = 0;
    std::uint64_t dense_bytes = 0;        // Σ dense_voxels · 4 with the chosen tiling
    std::uint64_t dense_bytes_untiled = 0;  // the same for one tile
    double build_seconds = 0;
    double write_seconds = 0;
    std::uint64_t file_bytes = 0;  // all .vdb files written (0 before writing)
    std::vector<std::filesystem::path> files;

    std::string summary() const;  // multi-line human-readable report
};

// Progress: fraction of the build done, from the calling thread.
using VdbProgress = std::function<void(double fraction)>;

struct VdbRunOptions {
    VdbProgress progress;                 // may be empty
    const CancelFlag* cancel = nullptr;   // polled; Cancelled is thrown, nothing written
    bool dry_run = false;                 // build and report, write nothing
    // Called with the stats after the build and before anything is written (the CLI
    // prints them there).
    std::function<void(const VdbStats&)> before_write;
};

// Builds the grids of every active constituent over the requested region and writes
// them: one file `path` when there is one tile, otherwise `<stem>.tileNNN.vdb` per tile
// plus the manifest `<stem>.tiles.json` (docs/vdb.md, "Tiling"). Atomic: every file
// goes to a temporary beside its destination and is renamed only after all were
// written; on any failure no output (and no temporary) is left. Throws VdbError
// (bad options, limits, unwritable output), SceneError (invalid scene), Cancelled.
VdbStats export_vdb(const Scene& scene, const VdbOptions& options, const std::filesystem::path& path,
                    const VdbRunOptions& run = {});

// The files export_vdb writes for `path` when the volume has `tiles` tiles.
std::vector<std::filesystem::path> vdb_output_paths(const std::filesystem::path& path, std::size_t tiles);

// ---- Analytic density --------------------------------------------------------------

// JSON description of the atmosphere for renderers that evaluate densities in closed
// form (the Blender add-on's Cycles node tree, POV-Ray function patterns): planet and
// frame in `unit`, and per active constituent its profile (type and parameters in
// `unit`), RGB scattering/absorption per `unit` at density 1, phase function.
// Schema in docs/vdb.md, "Analytic density".
std::string analytic_density_json(const Scene& scene, const VdbOptions& options);

// A POV-Ray 3.7 include declaring, per active constituent, the density as a function
// of POV-Ray's (x, y, z) (y up: POV (x, y, z) = airmass (x, z, y), the planet centre
// at <0, −R, 0> for PlanetOrigin::surface), its maximum, and its RGB coefficients.
std::string pov_include(const Scene& scene, const VdbOptions& options);

// POV-Ray density_file: one .df3 per active constituent (`<stem>.<name>.df3`) over the
// region's bounding box at the options' voxel size, 32-bit big-endian, normalised to
// the constituent's maximum in the box, one voxel of zeros around it; plus
// `<stem>.df3.inc` placing each file in POV-Ray's frame. Atomic like export_vdb.
// Returns the files written.
std::vector<std::filesystem::path> export_df3(const Scene& scene, const VdbOptions& options,
                                              const std::filesystem::path& stem_path, const VdbRunOptions& run = {});

// Writes `text` to `path` via temporary file + rename (VdbError on failure).
void write_text_atomic(const std::filesystem::path& path, std::string_view text);

}  // namespace airmass
