// The atmosphere as voxels, without OpenVDB: every decision behind the grids airmass
// writes, in plain types, so that any host can build the same grids with its own
// OpenVDB (library `airmass_volume`; no OpenVDB, no TBB: threads via airmass/parallel.hpp).
//
//   * the request, resolved and validated: units, voxel size, constituents and their
//     activity thresholds, the region's geometry and index bounds (VdbLayout);
//   * the sampling of each constituent's density into 8³ blocks (OpenVDB's leaf nodes),
//     active where it reaches the constituent's threshold (VolumeSampler, sample_volume);
//   * the tiling and the list of grids with their index bounding boxes, active voxel
//     counts and dense sizes, refused above the limits (VolumePlan, plan_volume);
//   * the grid and file metadata (volume_grid_metadata, volume_file_metadata), the file
//     names and the tiles manifest;
//   * dense blocks of one constituent's values over any index box (sample_volume_box), in
//     the order numpy + OpenVDB's Python `grid.copyFromArray(array, ijk=box.min)` expect;
//   * the closed-form descriptions (analytic density JSON, POV-Ray include).
//
// The OpenVDB writer (vdb_export.hpp, library airmass_vdb: `airmass vdb`, the tests) is
// built on these functions, and the C ABI (airmass_c.h, "Volumes") exposes them to hosts
// that write the files themselves (the Blender add-on), so both produce the same grids.
//
// Frame and index space. The scene frame of scene.hpp (Z up, origin on the surface below
// the observer), scaled to the chosen length unit: with PlanetOrigin::surface (the
// default) the planet centre is at (0, 0, −R); with PlanetOrigin::center the frame is
// shifted by +R in z. Voxel (i, j, k) of every grid and tile holds the density at the
// world point voxel_size · (i, j, k): OpenVDB's linear transform of voxel size v with no
// translation, under which index point (i, j, k) is the centre of the voxel's cell
// [i − ½, i + ½] · v (docs/vdb.md).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "airmass/geometry.hpp"
#include "airmass/scene.hpp"

namespace airmass {

class CancelFlag;

// Every problem with a volume request or its output: the message names the option
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

// What a voxel holds (docs/vdb.md, "Voxel values"; `airmass report vdb` measures both).
enum class VoxelValues {
    // Per constituent: average where the voxel is more than half its thinnest layer
    // (profile_feature_m) and the rays cross the layer (the planet, a box, a view whose camera
    // is above it), point otherwise.
    automatic,
    // The density's mean over the voxel's trilinear hat, in the air above the ground: the
    // renderer's trilinear reconstruction then carries the atmosphere's mass at any voxel size
    // (rays across the layer: 8-km voxels 0.3 % instead of 27 %), at the cost of the density
    // right at the ground (a ray along the ground: 20 % instead of 2e-5).
    average,
    // The density at the voxel's index point (before 2026-12-07 the only choice): exact at the
    // nodes, the reconstruction's chords in place of the profile's curve between them.
    point,
};
std::string_view voxel_values_name(VoxelValues v);  // "auto", "average", "point"
// The choice of that name; nullopt for any other (the caller names its field in the error).
std::optional<VoxelValues> voxel_values_from_name(std::string_view name);

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
    // Refuse before sampling when the grids could need more than this many MiB.
    double max_memory_mb = 4096.0;
    // Tiling: 0 = automatic (split when it shrinks the dense boxes), -1 = one tile,
    // N > 0 = tiles of N voxels per edge (a multiple of 8).
    int tile_voxels = 0;
    int max_tiles = 256;
    RgbWavelengths rgb = RgbWavelengths::automatic;
    VoxelValues voxel_values = VoxelValues::automatic;
};

// Automatic voxel size in `unit` (docs/vdb.md, "Voxel size"): half the thinnest layer
// among the active constituents (scale height, tent flank, knot spacing); no finer than
// the camera's pixel footprint at the nearest point of the atmosphere it can see (view
// region); and coarse enough that the region's estimated grids fit --max-memory-mb and
// --max-dense-mb.
double auto_voxel_size(const Scene& scene, const VdbOptions& options);

// Thinnest layer of a density profile (metres): the length over which it changes by O(1)
// (exponential: the scale height; tent: its shorter flank; piecewise linear: the shortest
// knot spacing; constant: its thickness), at most `thickness_m` (the atmosphere's). The
// automatic voxel size and `airmass pov`'s media sampling are chosen from it.
double profile_feature_m(const DensityProfile& p, double thickness_m);

// ---- index space -------------------------------------------------------------------------

using VoxelCoord = std::array<std::int32_t, 3>;

// An inclusive box of voxel indices; empty when min > max on any axis.
struct VoxelBox {
    VoxelCoord min{0, 0, 0};
    VoxelCoord max{-1, -1, -1};

    bool empty() const { return min[0] > max[0] || min[1] > max[1] || min[2] > max[2]; }
    std::int64_t dim(int axis) const { return empty() ? 0 : std::int64_t(max[axis]) - min[axis] + 1; }
    std::uint64_t volume() const { return std::uint64_t(dim(0)) * std::uint64_t(dim(1)) * std::uint64_t(dim(2)); }
    bool contains(const VoxelCoord& c) const;
    bool contains(const VoxelBox& b) const;  // an empty b is contained in anything
    bool intersects(const VoxelBox& b) const;
    void expand(const VoxelCoord& c);
    void expand(const VoxelBox& b);
    friend bool operator==(const VoxelBox&, const VoxelBox&) = default;
};

// ---- the resolved request ----------------------------------------------------------------

// One constituent as exported: its grid name, the RGB coefficients per length unit at
// density 1, and the altitude band outside which its relative density is below the
// activity threshold (so its voxels there stay inactive).
struct VdbConstituent {
    const Constituent* source = nullptr;  // points into the Scene given to resolve_vdb_layout
    std::string name;
    std::array<double, 3> scattering_rgb{};  // per unit
    std::array<double, 3> absorption_rgb{};  // per unit
    double density_threshold = 0;            // cells with rho < threshold stay inactive
    double band_min_m = 0, band_max_m = 0;   // altitude band that may hold active cells
    double density_max = 0;                  // max of the profile over [0, atmosphere top]
    VoxelValues values = VoxelValues::point;  // what its voxels hold (VdbOptions::voxel_values resolved)
};

// The camera of the view region, in the unit's world frame.
struct VdbViewCone {
    Vec3<double> position{0.0}, forward{0.0}, right{0.0}, up{0.0};  // orthonormal basis
    double tan_half_h = 0, tan_half_v = 0;                          // half-angles of the frustum
    double max_distance = 0;
    double footprint_per_distance = 0;  // pixel footprint / distance (the AUTO sensor fit)
};

// Everything a build needs, resolved and validated, in the chosen unit.
struct VdbLayout {
    VdbOptions options;
    double metres_per_unit = 1000;
    double voxel_size = 1;  // in the unit
    bool voxel_size_automatic = false;
    Vec3<double> planet_center{0.0};  // world, unit
    double planet_radius = 0;         // unit
    double atmosphere_top = 0;        // radius of the top, unit
    std::array<double, 3> rgb_wavelengths_nm{680, 550, 440};
    std::string spectral_basis;  // metadata value, e.g. "rgb_bruneton_680_550_440"
    std::vector<VdbConstituent> constituents;
    std::optional<VdbViewCone> view;  // VdbRegion::view
    VoxelBox index_bounds;            // all voxels the region may activate
    std::string scene_name;
    std::string scene_json;  // scene_to_json(scene), file-level metadata
};

// Validates the scene and the options (VdbError/SceneError naming the field) and
// resolves units, voxel size, constituents and region.
VdbLayout resolve_vdb_layout(const Scene& scene, const VdbOptions& options);

// Relative density of `c` at the world point `p` (unit) as grids of point values store it,
// i.e. the profile at the point's altitude (0 above the atmosphere top), independent of
// the region and the activity threshold (means: detail::voxel_average, voxel_average.hpp).
double vdb_density_at(const VdbLayout& layout, const VdbConstituent& c, const Vec3<double>& p);

// ---- statistics --------------------------------------------------------------------------

// One grid of the output, as Blender 3.4 will see it.
struct VdbGridStats {
    std::string name;
    std::size_t tile = 0;
    std::uint64_t active_voxels = 0;
    // The values' index bounding box, min then max (inclusive), in the common lattice: the
    // tile's grid holds them at bbox - its index offset (VolumePlan::index_offset).
    std::array<std::int32_t, 6> bbox{};
    // The box with the tile's guard voxels (kVolumeGuardValue, at the other tiles' values next
    // to this tile's; docs/vdb.md "Tiling"): what Blender 3.4 densifies. A plan bounds it from
    // the leaves' boxes; equal to bbox for a single tile. Common lattice, as bbox.
    std::array<std::int32_t, 6> dense_bbox{};
    std::uint64_t dense_voxels = 0;      // dense_bbox volume
    std::uint64_t memory_bytes = 0;      // OpenVDB tree in memory (a plan estimates it from its values' leaves)
};

struct VdbStats {
    double voxel_size = 0;  // in the unit
    LengthUnit unit = LengthUnit::km;
    std::size_t tiles = 0;
    std::vector<VdbGridStats> grids;  // tile-major, constituents in layout order; empty grids omitted
    std::vector<VoxelCoord> index_offsets;  // per tile: VolumePlan::index_offset (bboxes stay in the common lattice)
    std::uint64_t active_voxels = 0;  // summed over grids
    std::uint64_t memory_bytes = 0;
    std::uint64_t dense_bytes = 0;          // Σ dense_voxels · 4 with the chosen tiling
    std::uint64_t dense_bytes_untiled = 0;  // the same for one tile
    double build_seconds = 0;
    double write_seconds = 0;
    std::uint64_t file_bytes = 0;  // all .vdb files written (0 before writing)
    std::vector<std::filesystem::path> files;

    std::string summary() const;  // multi-line human-readable report
};

// ---- sampling ----------------------------------------------------------------------------

// Progress: fraction of the work done, from the calling thread.
using VdbProgress = std::function<void(double fraction)>;

struct VolumeRunOptions {
    VdbProgress progress;                // may be empty
    const CancelFlag* cancel = nullptr;  // polled between batches; Cancelled is thrown
    int threads = 0;                     // workers; 0: all hardware threads
};

// Blocks are OpenVDB's leaf nodes: 8³ voxels at origins that are multiples of 8. Within
// a block, voxel (x, y, z) (0 ≤ x, y, z < 8) sits at offset x·64 + y·8 + z
// (LeafNode::coordToOffset).
inline constexpr int kVolumeBlockDim = 8;
inline constexpr int kVolumeBlockVoxels = 512;
inline constexpr std::size_t kMaxVolumeConstituents = 64;  // one bit each in a block's mask

// A block that may hold active voxels, with one bit per constituent whose altitude band
// it may meet.
struct VolumeBlock {
    VoxelCoord origin{0, 0, 0};
    std::uint64_t constituents = 0;
};

// One constituent's values in one block.
struct VolumeBlockValues {
    std::array<float, kVolumeBlockVoxels> value{};  // 0 where inactive
    std::array<std::uint64_t, kVolumeBlockVoxels / 64> active{};
    std::uint32_t active_count = 0;
    VoxelBox active_box;  // of the active voxels

    bool on(int offset) const { return (active[std::size_t(offset) >> 6] >> (offset & 63)) & 1u; }
};

// The region test and the per-voxel sampling of one layout. Keeps a reference to the
// layout (which must outlive it); const member functions may run concurrently.
class VolumeSampler {
public:
    explicit VolumeSampler(const VdbLayout& layout);
    // With keep_bytes > 0 the sampling pass (sample_volume; plan_volume(sampler)) keeps each
    // block's values, up to that many bytes of them, and sample_volume_box copies a kept block
    // instead of sampling it again: a host that asks the plan and then every grid's boxes (a
    // VDB session of the C ABI) computes each voxel once. The copies are the values sampling
    // gives, bit for bit; blocks past the limit are sampled again, as without it.
    VolumeSampler(const VdbLayout& layout, std::size_t keep_bytes);
    ~VolumeSampler();
    VolumeSampler(const VolumeSampler&) = delete;
    VolumeSampler& operator=(const VolumeSampler&) = delete;

    const VdbLayout& layout() const { return layout_; }

    // Every block the region may activate, sorted by origin (x, then y, then z), found by
    // recursive culling of the leaf-aligned cover of the index bounds. With `within`,
    // only the blocks meeting that box — decided exactly as the full enumeration decides
    // them (same hierarchy, same tests), so a box sees the blocks, and the values, that
    // the whole grid has there. Throws VdbError when the blocks could exceed
    // --max-memory-mb.
    std::vector<VolumeBlock> blocks(const VoxelBox* within = nullptr, int threads = 0) const;

    // Samples the constituents of the block's mask: every voxel's value (VdbOptions::voxel_values:
    // the density's mean over its hat, or the density at its index point) inside the region,
    // active where it is > 0, ≥ the constituent's threshold and
    // nonzero as a float. `out` has one entry per layout constituent; every entry is
    // reset. Returns the mask of the constituents that have at least one active voxel.
    std::uint64_t fill(const VolumeBlock& block, std::span<VolumeBlockValues> out) const;

    // The kept blocks (keep_bytes above). keep: the sampling pass hands each block's values
    // (`on`: fill's result); stored while the bytes allow, and served as given — only the
    // sampling pass should call it (tests inject values to see them served). kept: whether the block at `origin`
    // was kept, and then `values` → constituent c's kVolumeBlockVoxels values (0 where
    // inactive), nullptr when c has no active voxel there. Both thread-safe.
    void keep(const VolumeBlock& block, std::uint64_t on, std::span<const VolumeBlockValues> values) const;
    bool kept(const VoxelCoord& origin, std::size_t c, const float*& values) const;
    // Bytes of block values kept so far (0 without keep_bytes).
    std::size_t kept_bytes() const;

private:
    struct Region;
    struct Kept;
    const VdbLayout& layout_;
    std::unique_ptr<Region> region_;
    std::unique_ptr<Kept> kept_;  // null without keep_bytes
};

// A block's summary for one constituent with at least one active voxel.
struct VolumeLeaf {
    VoxelCoord origin{0, 0, 0};
    std::uint32_t constituent = 0;
    std::uint32_t active_voxels = 0;
    VoxelBox active_box;
};

// Workers sample_volume and sample_volume_box use for `threads` (0: all hardware threads).
int volume_workers(int threads);

// Called for each (block, constituent) with active voxels, from worker `worker` in
// [0, volume_workers(threads)); calls with the same worker never overlap.
using VolumeBlockSink =
    std::function<void(int worker, const VolumeBlock& block, std::size_t constituent, const VolumeBlockValues& values)>;

// The sampling pass: every block of the region, in parallel, in ~100 batches (progress
// and cancellation between them). Returns the leaves sorted by (origin, constituent).
// Throws VdbError (region outside the atmosphere, --max-memory-mb, more than
// kMaxVolumeConstituents constituents), Cancelled.
std::vector<VolumeLeaf> sample_volume(const VolumeSampler& sampler, const VolumeRunOptions& run = {},
                                      const VolumeBlockSink& sink = {});

// ---- tiling and the plan -----------------------------------------------------------------

// The value of a tile's guard voxels: active voxels just outside the tile, where another
// tile has values, one within one voxel (26 neighbours) of a value of this tile. They make
// Cycles before Blender 5.0 cover the cells where two tiles' interpolants meet (its volume
// mesh is the grid's active 8^3 leaves, padded across faces only; docs/vdb.md "Tiling").
// The smallest normal float, not 0: OpenVDB's copyFromArray(tolerance = 0) keeps it active,
// and its density is ~1e-38 of any threshold (invisible). Single-tile exports have none.
inline constexpr float kVolumeGuardValue = 1.17549435e-38f;  // std::numeric_limits<float>::min()

// The lattice of cubes the grids are split along (docs/vdb.md, "Tiling").
struct VolumeTiling {
    int tile_voxels = 0;            // edge in voxels; 0 = one tile
    VoxelCoord base{0, 0, 0};       // a corner of the lattice (aligned to blocks)
    std::size_t tiles = 1;
    std::uint64_t dense_voxels = 0;          // Σ over tiles and grids of the bbox volume
    std::uint64_t dense_voxels_untiled = 0;  // the same for one tile
};

// Picks the tiling (VdbOptions::tile_voxels, max_tiles; automatic: among lattices of
// n = 2, 3, ... cubes across the grids' extent, centred on them, the one that minimises
// dense bytes + 4 MiB per tile, preferring lattices that fit --max-dense-mb; one tile
// when nothing beats it). Throws VdbError when --tile-voxels gives more than --max-tiles.
VolumeTiling choose_volume_tiling(const std::vector<VolumeLeaf>& leaves, std::size_t constituents,
                                  const VdbOptions& options);

// What a build produces, without the voxels: the tiles and the grids of each.
struct VolumePlan {
    VdbLayout layout;  // its constituents still point into the Scene it was resolved from
    VolumeTiling tiling;
    std::vector<std::uint64_t> tile_keys;  // sorted; tile t holds the blocks whose key is tile_keys[t]
    VdbStats stats;                        // grids tile-major; memory estimated from the leaves
    std::vector<std::size_t> grid_constituent;  // per stats.grids entry: its index in layout.constituents

    // The tile holding the block at `origin` (a leaf of the sampling pass).
    std::size_t tile_of(const VoxelCoord& origin) const;
    // Tile t's index offset o (docs/vdb.md "Tiling"): voxel (i, j, k) of the tile's grids is
    // voxel (i, j, k) + o of the common lattice (the one every bbox of the plan, the stats and
    // the manifest is in), and the tile's transform is the common one after a translation by
    // o voxels, so every voxel keeps its world position and value. o = (c, c, c), c in 0..7 a
    // colour of the tile's lattice cube, 4·(ci & 1) + 2·(cj & 1) + (ck & 1) for cube indices
    // (ci, cj, ck): tiles whose cubes touch (26 neighbours) differ, so their 8³ leaves — and
    // the faces of the meshes Cycles < 5.0 builds from them — lie on planes ≥ 1 voxel apart
    // on every axis. (0, 0, 0) for a single tile.
    VoxelCoord index_offset(std::size_t tile) const;
    // The tile whose cube holds the block at `origin`, or tiles() when no tile does (a block
    // outside the lattice or in a cube without active voxels).
    std::size_t find_tile(const VoxelCoord& origin) const;
    std::size_t tiles() const { return tile_keys.size(); }
};

// Tiling, grids and limits from the leaves of a sampling pass. Throws VdbError when no
// voxel is active or the dense boxes exceed --max-dense-mb (with a suggested voxel size).
VolumePlan make_volume_plan(const VdbLayout& layout, const std::vector<VolumeLeaf>& leaves);

// sample_volume + make_volume_plan (the sampling's values are not kept).
VolumePlan plan_volume(const VdbLayout& layout, const VolumeRunOptions& run = {});
// The same with the caller's sampler (its layout), whose store of voxel means the pass fills
// — and which keeps the pass's blocks when made with keep_bytes — for the blocks asked of it
// afterwards (sample_volume_box with the same sampler).
VolumePlan plan_volume(const VolumeSampler& sampler, const VolumeRunOptions& run = {});

// ---- dense blocks ------------------------------------------------------------------------

// The boxes sample_volume_box accepts: the blocks (leaf-aligned) covering the index bounds.
VoxelBox volume_request_bounds(const VdbLayout& layout);

// Constituent `constituent`'s grid over `box` (within volume_request_bounds), dense:
// out[(i·ny + j)·nz + k] is voxel box.min + (i, j, k) — C order, z fastest, as a numpy
// array a[i][j][k] that OpenVDB's Python `grid.copyFromArray(a, ijk=box.min)` takes —
// and 0 where the voxel is inactive. These are the values the sampling pass gives, so a
// tile's grid over its plan bbox is exactly the writer's grid of that tile (tiles are
// unions of blocks). `out.size()` must be box.volume(). Throws VdbError (a box outside
// the bounds, a wrong size), Cancelled; on failure `out` is unspecified.
void sample_volume_box(const VolumeSampler& sampler, std::size_t constituent, const VoxelBox& box,
                       std::span<float> out, const VolumeRunOptions& run = {});

// ---- metadata and files ------------------------------------------------------------------

// Version of the grid/metadata layout (airmass:format_version); bump on any change a
// reader must know about.
inline constexpr int kVdbFormatVersion = 1;
// Version of the tiles manifest (<stem>.tiles.json); 2: per-tile index_offset and index_space.
inline constexpr int kVdbTilesManifestVersion = 2;
// The grid class of every grid (OpenVDB's GridBase::gridClassToString(GRID_FOG_VOLUME)).
inline constexpr std::string_view kVolumeGridClass = "fog volume";

// A metadata value: OpenVDB's StringMetadata, DoubleMetadata, Int32Metadata, Vec3DMetadata.
// (and Vec3IMetadata for std::array<std::int32_t, 3>).
using VolumeMetaValue = std::variant<std::string, double, std::int32_t, std::array<double, 3>, std::array<std::int32_t, 3>>;
struct VolumeMetadatum {
    std::string key;
    VolumeMetaValue value;
};
std::string_view volume_meta_type(const VolumeMetaValue& v);  // "string", "double", "int32", "vec3d", "vec3i"

// Every grid's metadata (docs/vdb.md, "Metadata"): the common keys plus the
// constituent's profile, coefficients, phase and the tile it belongs to; with several
// tiles also the tile's airmass:index_offset (VolumePlan::index_offset).
std::vector<VolumeMetadatum> volume_grid_metadata(const VdbLayout& layout, std::size_t constituent, std::size_t tile,
                                                  std::size_t tile_count, const VoxelCoord& index_offset = {0, 0, 0});
// A file's metadata: the common keys plus the scene (airmass:scene, JSON) and the tile.
std::vector<VolumeMetadatum> volume_file_metadata(const VdbLayout& layout, std::size_t tile, std::size_t tile_count);

// The file names of a volume with `tiles` tiles and the given stem: "<stem>.vdb" for one
// tile, else "<stem>.000.tile.vdb", ... and the manifest "<stem>.tiles.json" (last).
std::vector<std::string> volume_file_names(std::string_view stem, std::size_t tiles);
// The manifest of a tiled volume (docs/vdb.md, "Tiling"); `file_names` as above.
std::string volume_tiles_manifest(const VdbLayout& layout, const VdbStats& stats,
                                  const std::vector<std::string>& file_names);

// ---- analytic density --------------------------------------------------------------------

// JSON description of the atmosphere for renderers that evaluate densities in closed
// form (the Blender add-on's Cycles node tree, POV-Ray function patterns): planet and
// frame in `unit`, and per active constituent its profile (type and parameters in
// `unit`), RGB scattering/absorption per `unit` at density 1, phase function.
// Schema in docs/vdb.md, "Analytic density".
std::string analytic_density_json(const Scene& scene, const VdbOptions& options);

// ---- the sun's columns (renderers that light the atmosphere themselves) ----------------------
//
// For the Blender add-on's "Analytic Sun" lighting (docs/addon.md): a table, per active
// constituent in analytic_density_json's order, of the mass ∫ρ ds (in `unit`, density 1 = the
// profile's reference) along the ray from a point toward the sun to the top of the atmosphere,
// the library's own optical depth (sun_masses). Texel (i, j) holds the ray of
// sun_column_ray(x_mu = i / (mu_size − 1), x_r = j / (r_size − 1)): Bruneton's (2017)
// transmittance-texture parametrisation, every ray that reaches the top without meeting the
// ground — x_r = ρ/H (ρ = sqrt(r² − R²), H = sqrt(top² − R²)), x_mu = (d − d_min)/(d_max − d_min)
// (d the distance to the top along the ray, d_min = top − r straight up, d_max = ρ + H grazing
// the ground). A renderer reads it at u = (x_mu·(mu_size − 1) + 0.5)/mu_size and likewise v, and
// sets the sun to 0 below the horizon (mu < −ρ/r).
// The tables' sizes: mu_size and r_size in [2, 4096], else VdbError naming them ("<what>: mu_size = 1:
// must be in [2, 4096]").
void check_sun_table_sizes(std::string_view what, int mu_size, int r_size);

struct SunColumnRay {
    double r = 0;   // radius of the point, unit
    double mu = 1;  // cosine of the sun's zenith angle there
};
SunColumnRay sun_column_ray(double planet_radius, double atmosphere_top, double x_mu, double x_r);

struct SunColumnTable {
    int mu_size = 0, r_size = 0;
    std::vector<std::string> names;  // the layout's constituents, analytic_density_json's order
    std::vector<float> mass;         // [(j · mu_size + i) · names.size() + k], in the unit
};
// mu_size, r_size in [2, 4096] (VdbError naming them otherwise).
SunColumnTable sun_column_table(const Scene& scene, const VdbOptions& options, int mu_size, int r_size);
// The same with the layout already resolved (resolve_vdb_layout(scene, options)): a caller
// that needs the layout too resolves it once.
SunColumnTable sun_column_table(const Scene& scene, const VdbLayout& layout, int mu_size, int r_size);

// The multiple scattering of the same lighting: Hillaire's (2020) isotropic Ψ(altitude, sun zenith)
// (multiple_scattering.hpp, MsMode::isotropic_lut: every order ≥ 2, the sunlit ground included)
// per unit top-of-atmosphere irradiance, sr⁻¹, at the exporter's three RGB wavelengths
// (channel c = layout.rgb_wavelengths_nm[c], the renderer's RGB model of render.hpp). A point
// adds E_top,c · Ψ_c · Σ_j σs_j,c ρ_j per unit length, in the planet's shadow too. Texel (i, j):
// μs = mu_s_min + (1 − mu_s_min) · i/(mu_size − 1) (below mu_s_min no light is tabulated),
// x_r = j/(r_size − 1) as sun_column_table.
struct SunMsTable {
    int mu_size = 0, r_size = 0;
    double mu_s_min = -1.0;
    std::vector<float> psi;  // [(j · mu_size + i) · 3 + c]
};
SunMsTable sun_ms_table(const Scene& scene, const VdbOptions& options, int mu_size, int r_size);

// A POV-Ray 3.7 include declaring, per active constituent, the density as a function
// of POV-Ray's (x, y, z) (y up: POV (x, y, z) = airmass (x, z, y), the planet centre
// at <0, −R, 0> for PlanetOrigin::surface), its maximum, and its RGB coefficients.
std::string pov_include(const Scene& scene, const VdbOptions& options);

}  // namespace airmass
