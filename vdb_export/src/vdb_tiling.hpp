// Tiling: Blender 3.4 densifies each grid's active bounding box, so a shell seen from
// orbit in one box costs its whole empty interior. Splitting the grids into tiles (a
// regular lattice of cubes, aligned to OpenVDB leaves) and keeping only the tiles
// that hold active voxels, each with its own tight boxes, removes that waste. Tiles
// partition the voxels and share one transform: trilinear interpolation is linear in
// the voxel values, so the sum of the tiles renders like the single grid.
#pragma once

#include <cstdint>
#include <vector>

#include "airmass/vdb_grids.hpp"

namespace airmass::detail {

struct TilingChoice {
    int tile_voxels = 0;  // edge in voxels; 0 = one tile
    openvdb::Coord base;  // a corner of the lattice (aligned to leaves)
    std::size_t tiles = 1;
    std::uint64_t dense_voxels = 0;         // Σ over tiles and grids of the bbox volume
    std::uint64_t dense_voxels_untiled = 0;  // the same for one tile
};

// Picks the tiling (VdbOptions::tile_voxels, max_tiles; automatic: among lattices of
// n = 2, 3, ... cubes across the grids' extent, centred on them, the one that minimises
// dense bytes + 4 MiB per tile, preferring lattices that fit --max-dense-mb; one tile
// when nothing beats it).
TilingChoice choose_tiling(const std::vector<openvdb::FloatGrid::Ptr>& grids, const VdbOptions& options);

// Splits the grids along the chosen lattice, moving their leaves into the tiles (the
// grids are left empty); one tile returns the grids themselves. Empty grids of a tile
// are nullptr.
std::vector<VdbTile> split_into_tiles(std::vector<openvdb::FloatGrid::Ptr>& grids, const TilingChoice& choice);

}  // namespace airmass::detail
