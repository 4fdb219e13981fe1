// Building the OpenVDB grids from the volume layer's blocks (airmass/volume.hpp): the
// sampling pass fills 8³ blocks in parallel, each worker turns its blocks into leaves of
// its own trees, and the per-worker trees are merged at the end (the pattern OpenVDB's
// FAQ recommends for multithreaded writes: no shared accessor, no locks). The tiles, the
// grids' boxes and the limits are the plan's (make_volume_plan), so a host that copies
// sample_volume_box's dense blocks into its own grids gets exactly these grids.
#include <chrono>
#include <memory>
#include <stdexcept>

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
    }
    grids.clear();

    // 4. Metadata, and the statistics: the plan's, with the trees' real memory. The trees
    //    must hold exactly the plan's grids (a check of the one implementation, not a guess).
    VdbStats s = plan.stats;
    s.memory_bytes = 0;
    std::size_t gi = 0;
    for (std::size_t t = 0; t < volume.tiles.size(); ++t) {
        for (std::size_t c = 0; c < nc; ++c) {
            const auto& g = volume.tiles[t].grids[c];
            if (!g) continue;
            detail::insert_metadata(*g, volume_grid_metadata(layout, c, t, volume.tiles.size()));
            if (gi >= s.grids.size()) throw std::logic_error("vdb_export: more grids than the volume plan lists");
            VdbGridStats& gs = s.grids[gi++];
            const openvdb::CoordBBox bb = g->evalActiveVoxelBoundingBox();
            const std::array<std::int32_t, 6> box{bb.min().x(), bb.min().y(), bb.min().z(),
                                                  bb.max().x(), bb.max().y(), bb.max().z()};
            if (gs.name != g->getName() || gs.tile != t || gs.active_voxels != g->activeVoxelCount() || gs.bbox != box)
                throw std::logic_error("vdb_export: grid '" + g->getName() + "' of tile " + std::to_string(t) +
                                       " differs from the volume plan");
            gs.memory_bytes = g->memUsage();
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
