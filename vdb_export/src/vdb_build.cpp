// Building the OpenVDB grids from the volume layer's blocks (airmass/volume.hpp): the
// sampling pass fills 8³ blocks in parallel, each worker turns its blocks into leaves of
// its own trees, and the per-worker trees are merged at the end (the pattern OpenVDB's
// FAQ recommends for multithreaded writes: no shared accessor, no locks). The tiles, the
// grids' boxes and the limits are the plan's (make_volume_plan), so a host that copies
// sample_volume_box's dense blocks into its own grids gets exactly these grids.
#include <array>
#include <chrono>
#include <memory>
#include <stdexcept>

#include "airmass/parallel.hpp"
#include "airmass/progress.hpp"
#include "airmass/vdb_grids.hpp"
#include "vdb_format.hpp"

namespace airmass {

namespace {

using LeafT = openvdb::FloatTree::LeafNodeType;
static_assert(int(LeafT::DIM) == kVolumeBlockDim && int(LeafT::SIZE) == kVolumeBlockVoxels,
              "volume blocks are OpenVDB leaves");

openvdb::FloatGrid::Ptr empty_grid(const VdbLayout& layout, const std::string& name) {
    auto grid = openvdb::FloatGrid::create(0.0f);
    grid->setTransform(openvdb::math::Transform::createLinearTransform(layout.voxel_size));
    grid->setName(name);
    grid->setGridClass(openvdb::GRID_FOG_VOLUME);
    return grid;
}

// Guard voxels (kVolumeGuardValue; airmass/volume.hpp, docs/vdb.md "Tiling") of constituent c:
// every active voxel of another tile within one voxel (26 neighbours) of a value of tile t
// joins tile t's grid. Found first, set after, so guards never beget guards. Both passes run
// over the tiles in parallel (`threads` workers): the first only reads the grids, the second
// writes tile t's grid alone, each tile's guards in the order the serial loop set them.
void add_guards(std::vector<VdbTile>& tiles, std::size_t c, const VolumePlan& plan, int threads) {
    std::vector<std::vector<openvdb::Coord>> guards(tiles.size());
    parallel_for_each(tiles.size(), threads, [&](std::size_t t) {
        const auto& grid = tiles[t].grids[c];
        if (!grid) return;
        for (auto leaf = grid->tree().cbeginLeaf(); leaf; ++leaf) {
            const openvdb::Coord o = leaf->origin();
            std::array<const LeafT*, 27> near{};  // by (dx + 1) * 9 + (dy + 1) * 3 + (dz + 1)
            bool any = false;
            for (int dx = -1; dx <= 1; ++dx)
                for (int dy = -1; dy <= 1; ++dy)
                    for (int dz = -1; dz <= 1; ++dz) {
                        if (dx == 0 && dy == 0 && dz == 0) continue;
                        const openvdb::Coord no = o.offsetBy(dx * LeafT::DIM, dy * LeafT::DIM, dz * LeafT::DIM);
                        const std::size_t u = plan.find_tile({no.x(), no.y(), no.z()});
                        if (u == t || u >= tiles.size() || !tiles[u].grids[c]) continue;
                        const LeafT* n = tiles[u].grids[c]->tree().probeConstLeaf(no);
                        if (n) near[std::size_t((dx + 1) * 9 + (dy + 1) * 3 + (dz + 1))] = n, any = true;
                    }
            if (!any) continue;
            const auto side = [](int local) { return local < 0 ? 0 : local >= int(LeafT::DIM) ? 2 : 1; };
            for (auto v = leaf->cbeginValueOn(); v; ++v) {
                const openvdb::Coord p = v.getCoord();
                const openvdb::Coord l = p - o;
                const bool edge = l.x() == 0 || l.y() == 0 || l.z() == 0 || l.x() == int(LeafT::DIM) - 1 ||
                                  l.y() == int(LeafT::DIM) - 1 || l.z() == int(LeafT::DIM) - 1;
                if (!edge) continue;
                for (int dx = -1; dx <= 1; ++dx)
                    for (int dy = -1; dy <= 1; ++dy)
                        for (int dz = -1; dz <= 1; ++dz) {
                            const int sx = side(l.x() + dx), sy = side(l.y() + dy), sz = side(l.z() + dz);
                            if (sx == 1 && sy == 1 && sz == 1) continue;  // inside this leaf
                            const LeafT* n = near[std::size_t(sx * 9 + sy * 3 + sz)];
                            const openvdb::Coord q = p.offsetBy(dx, dy, dz);
                            if (n && n->isValueOn(q)) guards[t].push_back(q);
                        }
            }
        }
    });
    parallel_for_each(tiles.size(), threads, [&](std::size_t t) {
        if (guards[t].empty()) return;
        auto acc = tiles[t].grids[c]->getAccessor();
        for (const auto& q : guards[t]) acc.setValueOn(q, kVolumeGuardValue);
    });
}

// Moves tile t's grids onto its own index lattice (VolumePlan::index_offset o; docs/vdb.md
// "Tiling"): voxel p of the common lattice becomes voxel p - o, and the transform gains a
// translation by o voxels, so that every voxel keeps its world position and value while the
// tile's 8³ leaves are shifted against its neighbours'. The transform is built from the matrix
// the plan JSON gives hosts (createLinearTransform(Mat4d): a UniformScaleTranslateMap, as the
// host path's createLinearTransform(matrix) makes it).
void shift_tile(VdbTile& tile, const VoxelCoord& o, double voxel_size) {
    if (o == VoxelCoord{0, 0, 0}) return;
    const double v = voxel_size;
    const openvdb::Mat4d m(v, 0.0, 0.0, 0.0, 0.0, v, 0.0, 0.0, 0.0, 0.0, v, 0.0, o[0] * v, o[1] * v, o[2] * v, 1.0);
    const openvdb::Coord d(o[0], o[1], o[2]);
    for (auto& g : tile.grids) {
        if (!g) continue;
        auto tree = std::make_shared<openvdb::FloatTree>(0.0f);
        openvdb::tree::ValueAccessor<openvdb::FloatTree> acc(*tree);
        if (g->tree().activeTileCount() > 0) {  // not made here (leaves only); kept general
            for (auto it = g->tree().cbeginValueOn(); it; ++it) acc.setValueOn(it.getCoord() - d, *it);
        } else {
            // Leaf by leaf: a leaf's voxels land in at most 8 leaves of the new tree, each
            // made (as the accessor's setValueOn makes it) when its first voxel arrives.
            const int mask = ~int(LeafT::DIM - 1);
            for (auto leaf = g->tree().cbeginLeaf(); leaf; ++leaf) {
                const openvdb::Coord first = leaf->origin() - d;  // where voxel (0, 0, 0) lands
                const openvdb::Coord low(first.x() & mask, first.y() & mask, first.z() & mask);
                std::array<LeafT*, 8> to{};  // by (x beyond low) + 2 (y) + 4 (z)
                for (auto v = leaf->cbeginValueOn(); v; ++v) {
                    const openvdb::Coord q = v.getCoord() - d;
                    const std::size_t k = std::size_t(((q.x() & mask) != low.x() ? 1 : 0) +
                                                      ((q.y() & mask) != low.y() ? 2 : 0) +
                                                      ((q.z() & mask) != low.z() ? 4 : 0));
                    if (!to[k]) to[k] = acc.touchLeaf(q);
                    to[k]->setValueOn(q, *v);
                }
            }
        }
        g->setTree(tree);
        g->setTransform(openvdb::math::Transform::createLinearTransform(m));
    }
}

}  // namespace

VdbVolume build_vdb_volume(const Scene& scene, const VdbOptions& options, const VdbRunOptions& run) {
    return build_vdb_volume(resolve_vdb_layout(scene, options), run);
}

VdbVolume build_vdb_volume(const VdbLayout& layout, const VdbRunOptions& run) {
    openvdb::initialize();
    const auto t0 = std::chrono::steady_clock::now();
    const VolumeSampler sampler(layout);
    const std::size_t nc = layout.constituents.size();

    // 1. Sample every block; each worker's leaves go to its own trees.
    std::vector<std::vector<openvdb::FloatTree::Ptr>> trees(std::size_t(volume_workers(run.threads)));
    VolumeRunOptions sampling;
    sampling.progress = run.progress;
    sampling.cancel = run.cancel;
    sampling.threads = run.threads;
    const std::vector<VolumeLeaf> leaves =
        sample_volume(sampler, sampling, [&](int worker, const VolumeBlock& block, std::size_t c, const VolumeBlockValues& v) {
            auto& mine = trees[std::size_t(worker)];
            if (mine.empty())
                for (std::size_t k = 0; k < nc; ++k) mine.push_back(std::make_shared<openvdb::FloatTree>(0.0f));
            auto leaf = std::make_unique<LeafT>(to_openvdb(block.origin), 0.0f, false);
            for (int i = 0; i < kVolumeBlockVoxels; ++i)
                if (v.on(i)) leaf->setValueOn(openvdb::Index(i), v.value[std::size_t(i)]);
            mine[c]->addLeaf(leaf.release());  // the tree takes ownership
        });

    // 2. Merge the per-worker trees (their leaves are disjoint: merging moves them).
    std::vector<openvdb::FloatGrid::Ptr> grids;
    for (std::size_t c = 0; c < nc; ++c) {
        auto grid = empty_grid(layout, layout.constituents[c].name);
        for (auto& mine : trees)
            if (!mine.empty()) grid->tree().merge(*mine[c]);
        grids.push_back(grid);
    }
    trees.clear();

    // 3. The plan: tiles, grid boxes, limits (throws when a limit is exceeded).
    VolumePlan plan = make_volume_plan(layout, leaves);
    VdbVolume volume;
    std::vector<std::pair<openvdb::Index64, openvdb::CoordBBox>> values_of;  // tiled: per (tile, grid) before guards
    volume.layout = layout;
    const std::size_t n_tiles = plan.tile_keys.size();
    if (plan.tiling.tile_voxels <= 0) {
        VdbTile t;
        for (const auto& g : grids) t.grids.push_back(g->activeVoxelCount() > 0 ? g : nullptr);
        volume.tiles.push_back(std::move(t));
    } else {
        volume.tiles.resize(n_tiles);
        for (auto& t : volume.tiles) t.grids.resize(nc);
        for (std::size_t c = 0; c < nc; ++c) {
            // Move the leaves (no copy): the source grid is left empty.
            std::vector<LeafT*> stolen;
            grids[c]->tree().stealNodes(stolen);
            for (LeafT* leaf : stolen) {
                std::unique_ptr<LeafT> owned(leaf);
                if (owned->onVoxelCount() == 0) continue;
                const openvdb::Coord o = owned->origin();
                auto& slot = volume.tiles[plan.tile_of({o.x(), o.y(), o.z()})].grids[c];
                if (!slot) slot = empty_grid(layout, layout.constituents[c].name);
                slot->tree().addLeaf(owned.release());  // takes ownership
            }
            grids[c]->clear();
        }
        // The plan's values (checked below need the values' boxes and counts): taken before
        // the guards join.
        values_of.resize(n_tiles * nc);
        parallel_for_each(n_tiles, run.threads, [&](std::size_t t) {
            for (std::size_t c = 0; c < nc; ++c)
                if (const auto& g = volume.tiles[t].grids[c])
                    values_of[t * nc + c] = {g->activeVoxelCount(), g->evalActiveVoxelBoundingBox()};
        });
        for (std::size_t c = 0; c < nc; ++c) add_guards(volume.tiles, c, plan, run.threads);
        // Each tile's grids are its own: the tiles shift in parallel (the user's thread count).
        parallel_for_each(n_tiles, run.threads,
                          [&](std::size_t t) { shift_tile(volume.tiles[t], plan.index_offset(t), layout.voxel_size); });
    }
    grids.clear();

    // 4. Metadata, and the statistics: the plan's, with the trees' real memory. The trees
    //    must hold exactly the plan's grids (a check of the one implementation, not a guess).
    //    Each grid's metadata, box and memory first, in parallel over the tiles; then the checks.
    struct GridFacts {
        openvdb::CoordBBox all;  // active voxels, values and guards, in the common lattice
        openvdb::Index64 memory = 0;
    };
    std::vector<GridFacts> facts(volume.tiles.size() * nc);
    parallel_for_each(volume.tiles.size(), run.threads, [&](std::size_t t) {
        const VoxelCoord o = plan.index_offset(t);
        for (std::size_t c = 0; c < nc; ++c) {
            const auto& g = volume.tiles[t].grids[c];
            if (!g) continue;
            detail::insert_metadata(*g, volume_grid_metadata(layout, c, t, volume.tiles.size(), o));
            GridFacts& f = facts[t * nc + c];
            f.all = g->evalActiveVoxelBoundingBox();  // in the tile's lattice
            f.all.translate(openvdb::Coord(o[0], o[1], o[2]));
            f.memory = g->memUsage();
        }
    });
    VdbStats s = plan.stats;
    s.memory_bytes = 0;
    std::size_t gi = 0;
    for (std::size_t t = 0; t < volume.tiles.size(); ++t) {
        for (std::size_t c = 0; c < nc; ++c) {
            const auto& g = volume.tiles[t].grids[c];
            if (!g) continue;
            if (gi >= s.grids.size()) throw std::logic_error("vdb_export: more grids than the volume plan lists");
            VdbGridStats& gs = s.grids[gi++];
            const openvdb::CoordBBox& all = facts[t * nc + c].all;
            const auto [active, bb] = values_of.empty() ? std::make_pair(g->activeVoxelCount(), all) : values_of[t * nc + c];
            const std::array<std::int32_t, 6> box{bb.min().x(), bb.min().y(), bb.min().z(),
                                                  bb.max().x(), bb.max().y(), bb.max().z()};
            const auto& d = gs.dense_bbox;
            const bool in_dense = all.min().x() >= d[0] && all.min().y() >= d[1] && all.min().z() >= d[2] &&
                                  all.max().x() <= d[3] && all.max().y() <= d[4] && all.max().z() <= d[5];
            if (gs.name != g->getName() || gs.tile != t || gs.active_voxels != active || gs.bbox != box || !in_dense)
                throw std::logic_error("vdb_export: grid '" + g->getName() + "' of tile " + std::to_string(t) +
                                       " differs from the volume plan");
            gs.memory_bytes = facts[t * nc + c].memory;
            s.memory_bytes += gs.memory_bytes;
        }
    }
    if (gi != s.grids.size()) throw std::logic_error("vdb_export: fewer grids than the volume plan lists");
    s.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    volume.stats = s;
    volume.plan = std::move(plan);
    return volume;
}

}  // namespace airmass
