// Tiling and the plan: Blender 3.4 densifies each grid's active bounding box, so a shell
// seen from orbit in one box costs its whole empty interior. Splitting the grids into
// tiles (a regular lattice of cubes, aligned to blocks) and keeping only the tiles that
// hold active voxels, each with its own tight boxes, removes that waste. Tiles partition
// the voxels and share one world lattice of voxel centres (each on its own index lattice,
// shifted by whole voxels: VolumePlan::index_offset): trilinear interpolation is linear in
// the voxel values, so the sum of the tiles renders like the single grid.
#include <algorithm>
#include <chrono>
#include <map>
#include <tuple>
#include <unordered_map>

#include "airmass/volume.hpp"
#include "volume_format.hpp"

namespace airmass {

namespace {

// A tile's per-tile cost beyond its voxels (an extra Volume object, file, BVH node):
// splitting must save at least this much dense memory per extra tile.
constexpr std::uint64_t kTileOverheadBytes = 4u << 20;
constexpr int kDim = kVolumeBlockDim;
constexpr double kLeafBytes = kVolumeBlockVoxels * sizeof(float) + 2 * (kVolumeBlockVoxels / 8) + 32;

VoxelCoord block_floor(const VoxelCoord& c) {
    const auto f = [](int a) { return a >= 0 ? a / kDim * kDim : -((-a + kDim - 1) / kDim) * kDim; };
    return {f(c[0]), f(c[1]), f(c[2])};
}

std::uint64_t tile_key(const VoxelCoord& origin, const VoxelCoord& base, int tile_voxels) {
    if (tile_voxels <= 0) return 0;
    std::uint64_t key = 0;
    for (int a = 0; a < 3; ++a) key = (key << 21) | std::uint64_t((origin[a] - base[a]) / tile_voxels);
    return key;
}

// The leaves' neighbours: for each leaf, the indices of the (up to 26) leaves of the same
// constituent whose blocks touch it (faces, edges, corners). Flat: leaf i's are
// index[offset[i], offset[i + 1]).
struct LeafNeighbours {
    std::vector<std::uint32_t> offset, index;
};

LeafNeighbours leaf_neighbours(const std::vector<VolumeLeaf>& leaves) {
    struct Key {
        VoxelCoord o;
        std::uint32_t c;
        bool operator==(const Key&) const = default;
    };
    struct Hash {
        std::size_t operator()(const Key& k) const {
            std::uint64_t h = std::uint32_t(k.o[0]);
            h = h * 0x9E3779B97F4A7C15ull ^ std::uint32_t(k.o[1]);
            h = h * 0x9E3779B97F4A7C15ull ^ std::uint32_t(k.o[2]);
            h = h * 0x9E3779B97F4A7C15ull ^ k.c;
            return std::size_t(h ^ (h >> 29));
        }
    };
    std::unordered_map<Key, std::uint32_t, Hash> at;
    at.reserve(leaves.size());
    for (std::size_t i = 0; i < leaves.size(); ++i) at.emplace(Key{leaves[i].origin, leaves[i].constituent}, std::uint32_t(i));
    LeafNeighbours n;
    n.offset.reserve(leaves.size() + 1);
    n.offset.push_back(0);
    for (const auto& leaf : leaves) {
        for (int dx = -1; dx <= 1; ++dx)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dz = -1; dz <= 1; ++dz) {
                    if (dx == 0 && dy == 0 && dz == 0) continue;
                    const VoxelCoord o{leaf.origin[0] + dx * kDim, leaf.origin[1] + dy * kDim, leaf.origin[2] + dz * kDim};
                    const auto it = at.find(Key{o, leaf.constituent});
                    if (it != at.end()) n.index.push_back(it->second);
                }
        n.offset.push_back(std::uint32_t(n.index.size()));
    }
    return n;
}

// Where leaf `a`'s tile may get guard voxels in neighbour leaf `n` (another tile's): n's
// active voxels within one voxel of a's — bounded by a's box grown by one ∩ n's box.
VoxelBox guard_bound(const VolumeLeaf& a, const VolumeLeaf& n) {
    VoxelBox b;
    for (int k = 0; k < 3; ++k) {
        b.min[k] = std::max(a.active_box.min[k] - 1, n.active_box.min[k]);
        b.max[k] = std::min(a.active_box.max[k] + 1, n.active_box.max[k]);
    }
    return b;
}

struct TileBoxes {
    VoxelBox values, dense;  // the values' box; with the guards
};

// Per (tile key, constituent): the boxes of a lattice (tile_voxels <= 0: one tile, no guards).
std::unordered_map<std::uint64_t, std::vector<TileBoxes>> tile_boxes(const std::vector<VolumeLeaf>& leaves,
                                                                    const LeafNeighbours& nb, std::size_t nc,
                                                                    const VoxelCoord& base, int tile_voxels) {
    std::vector<std::uint64_t> key(leaves.size());
    for (std::size_t i = 0; i < leaves.size(); ++i) key[i] = tile_key(leaves[i].origin, base, tile_voxels);
    std::unordered_map<std::uint64_t, std::vector<TileBoxes>> tiles;
    for (std::size_t i = 0; i < leaves.size(); ++i) {
        auto& v = tiles[key[i]];
        if (v.empty()) v.resize(nc);
        TileBoxes& b = v[leaves[i].constituent];
        b.values.expand(leaves[i].active_box);
        b.dense.expand(leaves[i].active_box);
        if (tile_voxels <= 0) continue;
        for (std::uint32_t j = nb.offset[i]; j < nb.offset[i + 1]; ++j) {
            const std::uint32_t n = nb.index[j];
            if (key[n] == key[i]) continue;
            const VoxelBox g = guard_bound(leaves[i], leaves[n]);
            if (!g.empty()) b.dense.expand(g);
        }
    }
    return tiles;
}

// Σ over (tile, grid) of the tile's dense box volume (with guards), and the number of non-empty tiles.
std::pair<std::uint64_t, std::size_t> dense_for(const std::vector<VolumeLeaf>& leaves, const LeafNeighbours& nb,
                                                std::size_t nc, const VoxelCoord& base, int tile_voxels) {
    const auto tiles = tile_boxes(leaves, nb, nc, base, tile_voxels);
    std::uint64_t dense = 0;
    for (const auto& [key, v] : tiles)
        for (const auto& b : v) dense += b.dense.volume();
    return {dense, tiles.size()};
}

}  // namespace

VolumeTiling choose_volume_tiling(const std::vector<VolumeLeaf>& leaves, std::size_t nc, const VdbOptions& options) {
    VoxelBox all;
    for (const auto& leaf : leaves) all.expand(leaf.active_box);
    const LeafNeighbours nb = leaf_neighbours(leaves);
    VolumeTiling best;
    best.base = all.empty() ? VoxelCoord{0, 0, 0} : block_floor(all.min);
    const auto [untiled, one] = dense_for(leaves, nb, nc, best.base, 0);
    best.dense_voxels = best.dense_voxels_untiled = untiled;
    best.tiles = one;
    if (options.tile_voxels == -1 || all.empty()) return best;
    // A lattice of cubes of `t` voxels, centred on the grids' bounding box (so that a
    // shell is cut symmetrically, without slivers), aligned to blocks.
    const auto lattice = [&](int t) {
        VoxelCoord base{};
        for (int a = 0; a < 3; ++a) {
            const int extent = all.max[a] - all.min[a] + 1;
            const int n = (extent + t - 1) / t;
            base[a] = all.min[a] - (n * t - extent) / 2;
        }
        return block_floor(base);
    };
    if (options.tile_voxels > 0) {
        const VoxelCoord base = lattice(options.tile_voxels);
        const auto [dense, n] = dense_for(leaves, nb, nc, base, options.tile_voxels);
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
    const int extent = int(std::max({all.dim(0), all.dim(1), all.dim(2)}));
    const double limit = options.max_dense_mb * 1024.0 * 1024.0;
    const auto cost_of = [](const VolumeTiling& c) {
        return double(c.dense_voxels) * sizeof(float) + double(c.tiles) * double(kTileOverheadBytes);
    };
    const auto fits = [&](const VolumeTiling& c) { return double(c.dense_voxels) * sizeof(float) <= limit; };
    const auto better = [&](const VolumeTiling& a, const VolumeTiling& b) {
        if (fits(a) != fits(b)) return fits(a);
        return cost_of(a) < cost_of(b);
    };
    int previous_t = 0;
    for (int n = 2; n * n <= 4 * options.max_tiles; ++n) {
        const int t = ((extent + n - 1) / n + kDim - 1) / kDim * kDim;
        if (t == previous_t || t < kDim) continue;
        previous_t = t;
        VolumeTiling c = best;
        c.tile_voxels = t;
        c.base = lattice(t);
        std::tie(c.dense_voxels, c.tiles) = dense_for(leaves, nb, nc, c.base, t);
        if (c.tiles > std::size_t(options.max_tiles)) break;
        if (better(c, best)) best = c;
    }
    return best;
}

std::size_t VolumePlan::tile_of(const VoxelCoord& origin) const {
    const std::uint64_t key = tile_key(origin, tiling.base, tiling.tile_voxels);
    const auto it = std::lower_bound(tile_keys.begin(), tile_keys.end(), key);
    if (it == tile_keys.end() || *it != key) throw std::out_of_range("VolumePlan::tile_of: a block outside every tile");
    return std::size_t(it - tile_keys.begin());
}

VoxelCoord VolumePlan::index_offset(std::size_t tile) const {
    if (tiling.tile_voxels <= 0 || tile_keys.size() <= 1) return {0, 0, 0};
    const std::uint64_t key = tile_keys.at(tile);
    const int mask = (1 << 21) - 1;
    const int ci = int(key >> 42) & mask, cj = int(key >> 21) & mask, ck = int(key) & mask;
    const int c = 4 * (ci & 1) + 2 * (cj & 1) + (ck & 1);
    return {c, c, c};
}

std::size_t VolumePlan::find_tile(const VoxelCoord& origin) const {
    if (tiling.tile_voxels <= 0) return 0;
    for (int a = 0; a < 3; ++a)
        if (origin[a] < tiling.base[a] || std::int64_t(origin[a] - tiling.base[a]) / tiling.tile_voxels >= (1 << 21))
            return tiles();
    const std::uint64_t key = tile_key(origin, tiling.base, tiling.tile_voxels);
    const auto it = std::lower_bound(tile_keys.begin(), tile_keys.end(), key);
    return it == tile_keys.end() || *it != key ? tiles() : std::size_t(it - tile_keys.begin());
}

VolumePlan make_volume_plan(const VdbLayout& layout, const std::vector<VolumeLeaf>& leaves) {
    const std::size_t nc = layout.constituents.size();
    VolumePlan plan;
    plan.layout = layout;
    plan.tiling = choose_volume_tiling(leaves, nc, layout.options);
    // Tiles in lattice order (the key sorts as (i, j, k)), so file names are stable.
    for (const auto& leaf : leaves) plan.tile_keys.push_back(tile_key(leaf.origin, plan.tiling.base, plan.tiling.tile_voxels));
    std::sort(plan.tile_keys.begin(), plan.tile_keys.end());
    plan.tile_keys.erase(std::unique(plan.tile_keys.begin(), plan.tile_keys.end()), plan.tile_keys.end());
    if (plan.tile_keys.empty()) plan.tile_keys.push_back(0);
    const std::size_t tiles = plan.tile_keys.size();

    struct Acc {
        VoxelBox box, dense;
        std::uint64_t active = 0, leaves = 0;
    };
    std::vector<Acc> acc(tiles * nc);
    std::vector<VoxelCoord> offsets(tiles);
    for (std::size_t t = 0; t < tiles; ++t) offsets[t] = plan.index_offset(t);
    // The tile's leaves are on its own lattice (shifted by the index offset): a block's active
    // box can span up to 8 of them. Counted as the distinct shifted leaves the boxes touch.
    std::unordered_map<std::uint64_t, std::vector<VoxelCoord>> shifted;  // per (tile, constituent)
    for (const auto& leaf : leaves) {
        const std::size_t t = plan.tile_of(leaf.origin);
        Acc& a = acc[t * nc + leaf.constituent];
        a.box.expand(leaf.active_box);
        a.active += leaf.active_voxels;
        const VoxelCoord o = offsets[t];
        if (o == VoxelCoord{0, 0, 0}) {
            ++a.leaves;
            continue;
        }
        VoxelBox local;
        for (int k = 0; k < 3; ++k) {
            local.min[k] = leaf.active_box.min[k] - o[k];
            local.max[k] = leaf.active_box.max[k] - o[k];
        }
        const VoxelCoord lo = block_floor(local.min), hi = block_floor(local.max);
        auto& list = shifted[t * nc + leaf.constituent];
        for (int x = lo[0]; x <= hi[0]; x += kDim)
            for (int y = lo[1]; y <= hi[1]; y += kDim)
                for (int z = lo[2]; z <= hi[2]; z += kDim) list.push_back({x, y, z});
    }
    for (auto& [i, list] : shifted) {
        std::sort(list.begin(), list.end());
        acc[i].leaves = std::uint64_t(std::unique(list.begin(), list.end()) - list.begin());
    }
    if (plan.tiling.tile_voxels > 0) {
        const auto boxes = tile_boxes(leaves, leaf_neighbours(leaves), nc, plan.tiling.base, plan.tiling.tile_voxels);
        for (std::size_t t = 0; t < tiles; ++t)
            for (std::size_t c = 0; c < nc; ++c) acc[t * nc + c].dense = boxes.at(plan.tile_keys[t])[c].dense;
    } else {
        for (Acc& a : acc) a.dense = a.box;
    }
    VdbStats& s = plan.stats;
    s.voxel_size = layout.voxel_size;
    s.unit = layout.options.unit;
    s.tiles = tiles;
    s.index_offsets = offsets;
    for (std::size_t t = 0; t < tiles; ++t) {
        for (std::size_t c = 0; c < nc; ++c) {
            const Acc& a = acc[t * nc + c];
            if (a.active == 0) continue;
            VdbGridStats g;
            g.name = layout.constituents[c].name;
            g.tile = t;
            g.active_voxels = a.active;
            g.bbox = {a.box.min[0], a.box.min[1], a.box.min[2], a.box.max[0], a.box.max[1], a.box.max[2]};
            g.dense_bbox = {a.dense.min[0], a.dense.min[1], a.dense.min[2], a.dense.max[0], a.dense.max[1], a.dense.max[2]};
            g.dense_voxels = a.dense.volume();
            g.memory_bytes = std::uint64_t(double(a.leaves) * kLeafBytes);
            s.active_voxels += g.active_voxels;
            s.memory_bytes += g.memory_bytes;
            s.dense_bytes += g.dense_voxels * sizeof(float);
            s.grids.push_back(g);
            plan.grid_constituent.push_back(c);
        }
    }
    s.dense_bytes_untiled = plan.tiling.dense_voxels_untiled * sizeof(float);
    const std::string where = "the " + std::string(region_name(layout.options.region)) + " region";
    if (s.active_voxels == 0)
        throw VdbError("region outside the atmosphere: " + where +
                       " holds no voxel with a density above the activity threshold (--tolerance = " +
                       detail::fmt(layout.options.tolerance) + ")");
    const double dense_mb = double(s.dense_bytes) / (1024.0 * 1024.0);
    if (dense_mb > layout.options.max_dense_mb)
        throw VdbError("the dense bounding boxes Blender 3.4 would allocate need " + detail::mib(double(s.dense_bytes)) +
                       " (" + std::to_string(s.tiles) + " tile(s)) > --max-dense-mb = " +
                       detail::fmt(layout.options.max_dense_mb) + "; use --voxel-size " +
                       detail::suggest_voxel(layout, dense_mb / layout.options.max_dense_mb, 3.0) +
                       " or more, --region view or box, or raise --max-dense-mb");
    return plan;
}

VolumePlan plan_volume(const VolumeSampler& sampler, const VolumeRunOptions& run) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::vector<VolumeLeaf> leaves = sample_volume(sampler, run);
    VolumePlan plan = make_volume_plan(sampler.layout(), leaves);
    plan.stats.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return plan;
}

VolumePlan plan_volume(const VdbLayout& layout, const VolumeRunOptions& run) {
    const VolumeSampler sampler(layout);
    return plan_volume(sampler, run);
}

}  // namespace airmass
