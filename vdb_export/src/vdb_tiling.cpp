// Choosing and applying the tile lattice (see vdb_tiling.hpp).
#include "vdb_tiling.hpp"

#include <algorithm>
#include <limits>
#include <map>
#include <tuple>
#include <unordered_map>

#include "vdb_format.hpp"

namespace airmass::detail {

namespace {

using LeafT = openvdb::FloatTree::LeafNodeType;

// A tile's per-tile cost beyond its voxels (an extra Volume object, file, BVH node):
// splitting must save at least this much dense memory per extra tile.
constexpr std::uint64_t kTileOverheadBytes = 4u << 20;

struct LeafBox {
    openvdb::Coord origin;
    openvdb::CoordBBox active;
};

openvdb::Coord leaf_floor(const openvdb::Coord& c) {
    const auto f = [](int a) { return a >= 0 ? a / 8 * 8 : -((-a + 7) / 8) * 8; };
    return openvdb::Coord(f(c.x()), f(c.y()), f(c.z()));
}

std::uint64_t tile_key(const openvdb::Coord& origin, const openvdb::Coord& base, int tile_voxels) {
    if (tile_voxels <= 0) return 0;
    std::uint64_t key = 0;
    for (int a = 0; a < 3; ++a) key = (key << 21) | std::uint64_t((origin[a] - base[a]) / tile_voxels);
    return key;
}

std::vector<std::vector<LeafBox>> leaf_boxes(const std::vector<openvdb::FloatGrid::Ptr>& grids) {
    std::vector<std::vector<LeafBox>> out(grids.size());
    for (std::size_t g = 0; g < grids.size(); ++g) {
        for (auto it = grids[g]->tree().cbeginLeaf(); it; ++it) {
            openvdb::CoordBBox b;
            it->evalActiveBoundingBox(b, true);
            if (!b.empty()) out[g].push_back({it->origin(), b});
        }
    }
    return out;
}

// Σ over (tile, grid) of the tile's bbox volume, and the number of non-empty tiles.
std::pair<std::uint64_t, std::size_t> dense_for(const std::vector<std::vector<LeafBox>>& boxes,
                                                const openvdb::Coord& base, int tile_voxels) {
    std::unordered_map<std::uint64_t, std::vector<openvdb::CoordBBox>> tiles;
    for (std::size_t g = 0; g < boxes.size(); ++g) {
        for (const auto& lb : boxes[g]) {
            auto& v = tiles[tile_key(lb.origin, base, tile_voxels)];
            if (v.empty()) v.resize(boxes.size());
            v[g].expand(lb.active);
        }
    }
    std::uint64_t dense = 0;
    for (const auto& [key, v] : tiles)
        for (const auto& b : v)
            if (!b.empty()) dense += b.volume();
    return {dense, tiles.size()};
}

}  // namespace

TilingChoice choose_tiling(const std::vector<openvdb::FloatGrid::Ptr>& grids, const VdbOptions& options) {
    const auto boxes = leaf_boxes(grids);
    openvdb::CoordBBox all;
    for (const auto& v : boxes)
        for (const auto& lb : v) all.expand(lb.active);
    TilingChoice best;
    best.base = all.empty() ? openvdb::Coord(0) : leaf_floor(all.min());
    const auto [untiled, one] = dense_for(boxes, best.base, 0);
    best.dense_voxels = best.dense_voxels_untiled = untiled;
    best.tiles = one;
    if (options.tile_voxels == -1 || all.empty()) return best;
    // A lattice of cubes of `t` voxels, centred on the grids' bounding box (so that a
    // shell is cut symmetrically, without slivers), aligned to leaves.
    const auto lattice = [&](int t) {
        openvdb::Coord base;
        for (int a = 0; a < 3; ++a) {
            const int extent = all.max()[a] - all.min()[a] + 1;
            const int n = (extent + t - 1) / t;
            base[a] = all.min()[a] - (n * t - extent) / 2;
        }
        return leaf_floor(base);
    };
    if (options.tile_voxels > 0) {
        const openvdb::Coord base = lattice(options.tile_voxels);
        const auto [dense, n] = dense_for(boxes, base, options.tile_voxels);
        if (n > std::size_t(options.max_tiles))
            throw VdbError("--tile-voxels = " + std::to_string(options.tile_voxels) + " gives " + std::to_string(n) +
                           " tiles > --max-tiles = " + std::to_string(options.max_tiles) +
                           "; use larger tiles or raise --max-tiles");
        best.tile_voxels = options.tile_voxels;
        best.base = base;
        best.dense_voxels = dense;
        best.tiles = n;
        return best;
    }
    // Automatic: n = 2, 3, ... cubes across the largest extent, while the lattice can
    // stay within max_tiles (a shell fills about n² of the n³ cubes). The cheapest
    // lattice whose dense boxes fit --max-dense-mb wins; if none fits, the cheapest.
    const int extent = std::max({all.dim().x(), all.dim().y(), all.dim().z()});
    const double limit = options.max_dense_mb * 1024.0 * 1024.0;
    const auto cost_of = [](const TilingChoice& c) {
        return double(c.dense_voxels) * sizeof(float) + double(c.tiles) * double(kTileOverheadBytes);
    };
    const auto fits = [&](const TilingChoice& c) { return double(c.dense_voxels) * sizeof(float) <= limit; };
    const auto better = [&](const TilingChoice& a, const TilingChoice& b) {
        if (fits(a) != fits(b)) return fits(a);
        return cost_of(a) < cost_of(b);
    };
    int previous_t = 0;
    for (int n = 2; n * n <= 4 * options.max_tiles; ++n) {
        const int t = ((extent + n - 1) / n + LeafT::DIM - 1) / LeafT::DIM * LeafT::DIM;
        if (t == previous_t || t < int(LeafT::DIM)) continue;
        previous_t = t;
        TilingChoice c = best;
        c.tile_voxels = t;
        c.base = lattice(t);
        std::tie(c.dense_voxels, c.tiles) = dense_for(boxes, c.base, t);
        if (c.tiles > std::size_t(options.max_tiles)) break;
        if (better(c, best)) best = c;
    }
    return best;
}

std::vector<VdbTile> split_into_tiles(std::vector<openvdb::FloatGrid::Ptr>& grids, const TilingChoice& choice) {
    const openvdb::Coord& base = choice.base;
    if (choice.tile_voxels <= 0) {
        VdbTile t;
        for (const auto& g : grids) t.grids.push_back(g->activeVoxelCount() > 0 ? g : nullptr);
        return {t};
    }
    // Tiles in lattice order (the key sorts as (i, j, k)), so file names are stable.
    std::map<std::uint64_t, std::size_t> index;
    for (const auto& g : grids)
        for (auto it = g->tree().cbeginLeaf(); it; ++it)
            if (it->onVoxelCount() > 0) index.emplace(tile_key(it->origin(), base, choice.tile_voxels), 0);
    std::size_t n = 0;
    for (auto& [key, i] : index) i = n++;
    std::vector<VdbTile> tiles(n);
    for (auto& t : tiles) t.grids.resize(grids.size());
    for (std::size_t g = 0; g < grids.size(); ++g) {
        // Move the leaves (no copy): the source grid is left empty.
        std::vector<LeafT*> leaves;
        grids[g]->tree().stealNodes(leaves);
        for (LeafT* leaf : leaves) {
            if (leaf->onVoxelCount() == 0) {
                delete leaf;
                continue;
            }
            auto& slot = tiles[index.at(tile_key(leaf->origin(), base, choice.tile_voxels))].grids[g];
            if (!slot) {
                slot = openvdb::FloatGrid::create(0.0f);
                slot->setTransform(grids[g]->transform().copy());
                slot->setName(grids[g]->getName());
                slot->setGridClass(grids[g]->getGridClass());
            }
            slot->tree().addLeaf(leaf);  // takes ownership
        }
        grids[g]->clear();
    }
    return tiles;
}

}  // namespace airmass::detail
