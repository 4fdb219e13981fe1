// The OpenVDB level of vdb_export: the resolved request (VdbLayout) and the grids in
// memory, for callers that sample them in-process (tests, the voxel-size trade
// report). Most callers want export_vdb() in vdb_export.hpp instead.
#pragma once

#include <openvdb/openvdb.h>

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "airmass/vdb_export.hpp"

namespace airmass {

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
};

// The camera of the view region, in the unit's world frame.
struct VdbViewCone {
    openvdb::Vec3d position, forward, right, up;  // orthonormal basis
    double tan_half_h = 0, tan_half_v = 0;        // half-angles of the frustum
    double max_distance = 0;
    double footprint_per_distance = 0;  // pixel footprint / distance (the AUTO sensor fit)
};

// Everything a build needs, resolved and validated, in the chosen unit.
struct VdbLayout {
    VdbOptions options;
    double metres_per_unit = 1000;
    double voxel_size = 1;  // in the unit
    bool voxel_size_automatic = false;
    openvdb::Vec3d planet_center{0, 0, 0};  // world, unit
    double planet_radius = 0;               // unit
    double atmosphere_top = 0;              // radius of the top, unit
    std::array<double, 3> rgb_wavelengths_nm{680, 550, 440};
    std::string spectral_basis;  // metadata value, e.g. "rgb_bruneton_680_550_440"
    std::vector<VdbConstituent> constituents;
    std::optional<VdbViewCone> view;  // VdbRegion::view
    openvdb::CoordBBox index_bounds;   // all voxels the region may activate
    std::string scene_name;
    std::string scene_json;  // scene_to_json(scene), file-level metadata
};

// Validates the scene and the options (VdbError/SceneError naming the field) and
// resolves units, voxel size, constituents and region.
VdbLayout resolve_vdb_layout(const Scene& scene, const VdbOptions& options);

// The grids of one tile.
struct VdbTile {
    std::vector<openvdb::FloatGrid::Ptr> grids;  // one per layout constituent, same order
};

struct VdbVolume {
    VdbLayout layout;
    std::vector<VdbTile> tiles;  // one unless tiled
    VdbStats stats;              // without file_bytes / write_seconds
};

// Builds (in parallel) and tiles the grids, with metadata. Throws VdbError when the
// region holds no atmosphere or a limit (memory, dense boxes) is exceeded, Cancelled.
VdbVolume build_vdb_volume(const Scene& scene, const VdbOptions& options, const VdbRunOptions& run = {});

// The same from a resolved layout (the trade report reuses one layout per voxel size).
VdbVolume build_vdb_volume(const VdbLayout& layout, const VdbRunOptions& run = {});

// Relative density of `c` at the world point `p` (unit) as the grids store it, i.e.
// the profile at the point's altitude (0 above the atmosphere top), independent of
// the region and the activity threshold.
double vdb_density_at(const VdbLayout& layout, const VdbConstituent& c, const openvdb::Vec3d& p);

}  // namespace airmass
