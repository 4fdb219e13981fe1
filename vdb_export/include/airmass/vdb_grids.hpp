// The OpenVDB level of vdb_export: the grids in memory, for callers that sample them
// in-process (tests, the voxel-size trade report). Most callers want export_vdb() in
// vdb_export.hpp instead; the layout, the sampling and the plan are the volume layer's
// (airmass/volume.hpp), which these grids are built from.
#pragma once

#include <openvdb/openvdb.h>

#include <vector>

#include "airmass/vdb_export.hpp"

namespace airmass {

// The grids of one tile.
struct VdbTile {
    std::vector<openvdb::FloatGrid::Ptr> grids;  // one per layout constituent, same order; nullptr when empty
};

struct VdbVolume {
    VdbLayout layout;
    VolumePlan plan;             // the tiles and grids the volume layer decided
    std::vector<VdbTile> tiles;  // one unless tiled
    VdbStats stats;              // the plan's, with the trees' memory; without file_bytes / write_seconds
};

// Builds (in parallel) and tiles the grids, with metadata. Throws VdbError when the
// region holds no atmosphere or a limit (memory, dense boxes) is exceeded, Cancelled.
VdbVolume build_vdb_volume(const Scene& scene, const VdbOptions& options, const VdbRunOptions& run = {});

// The same from a resolved layout (the trade report reuses one layout per voxel size).
VdbVolume build_vdb_volume(const VdbLayout& layout, const VdbRunOptions& run = {});

// The volume layer's vectors and boxes as OpenVDB's.
inline openvdb::Vec3d to_openvdb(const Vec3<double>& v) { return openvdb::Vec3d(v.x, v.y, v.z); }
inline openvdb::Coord to_openvdb(const VoxelCoord& c) { return openvdb::Coord(c[0], c[1], c[2]); }
inline openvdb::CoordBBox to_openvdb(const VoxelBox& b) {
    return b.empty() ? openvdb::CoordBBox() : openvdb::CoordBBox(to_openvdb(b.min), to_openvdb(b.max));
}

}  // namespace airmass
