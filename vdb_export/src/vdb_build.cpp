// Building the grids: enumerate the 8³ blocks (OpenVDB leaf nodes) the region may
// touch by recursive culling, then fill them in parallel — each thread builds its own
// trees from whole leaves, and the per-thread trees are merged at the end (the
// pattern OpenVDB's FAQ recommends for multithreaded writes: no shared accessor).
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>

#include "airmass/progress.hpp"
#include "airmass/vdb_grids.hpp"
#include "vdb_format.hpp"
#include "vdb_region.hpp"
#include "vdb_tiling.hpp"

namespace airmass {

using openvdb::Coord;
using openvdb::Vec3d;

namespace {

using LeafT = openvdb::FloatTree::LeafNodeType;
constexpr int kLeafDim = int(LeafT::DIM);  // 8
// Approximate bytes of one leaf in memory (values, masks, origin, node overhead).
constexpr double kLeafBytes = LeafT::SIZE * sizeof(float) + 2 * sizeof(LeafT::NodeMaskType) + 32;
constexpr std::size_t kMaxConstituents = 64;  // one bit each in a block's mask

int floor_div(int a, int b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

// A block that may hold active voxels, with one bit per constituent whose altitude
// band it may meet.
struct Block {
    Coord origin;
    std::uint64_t mask;
};

struct Radii {
    double r_min, r_max;  // shell radii (unit) of a constituent's band
};

class BlockEnumerator {
public:
    BlockEnumerator(const VdbLayout& layout, const detail::VdbRegionTest& region, std::uint64_t max_blocks)
        : layout_(layout), region_(region), max_block_bits_(max_blocks) {
        for (const auto& c : layout.constituents)
            radii_.push_back({layout.planet_radius + c.band_min_m / layout.metres_per_unit,
                              std::min(layout.atmosphere_top, layout.planet_radius + c.band_max_m / layout.metres_per_unit)});
    }

    // Visits every block of the index bounds in parallel over top-level chunks.
    std::vector<Block> run() {
        const auto& b = layout_.index_bounds;
        const Coord lo(floor_div(b.min().x(), kLeafDim) * kLeafDim, floor_div(b.min().y(), kLeafDim) * kLeafDim,
                       floor_div(b.min().z(), kLeafDim) * kLeafDim);
        const Coord ext = b.max() - lo + Coord(1);
        // Top-level chunk: the smallest power-of-two multiple of a leaf that keeps the
        // number of chunks near 2^18, so huge regions do not enumerate billions of blocks.
        int chunk = kLeafDim;
        auto chunks_of = [&](int c) {
            return double((ext.x() + c - 1) / c) * double((ext.y() + c - 1) / c) * double((ext.z() + c - 1) / c);
        };
        while (chunks_of(chunk) > double(1 << 18) && chunk < (1 << 28)) chunk *= 2;
        const Coord n((ext.x() + chunk - 1) / chunk, (ext.y() + chunk - 1) / chunk, (ext.z() + chunk - 1) / chunk);
        const std::int64_t total = std::int64_t(n.x()) * n.y() * n.z();
        tbb::enumerable_thread_specific<std::vector<Block>> local;
        tbb::parallel_for(tbb::blocked_range<std::int64_t>(0, total, 64), [&](const auto& range) {
            auto& out = local.local();
            for (std::int64_t i = range.begin(); i != range.end() && !overflow_.load(std::memory_order_relaxed); ++i) {
                const int x = int(i % n.x()), y = int((i / n.x()) % n.y()), z = int(i / (std::int64_t(n.x()) * n.y()));
                visit(lo + Coord(x * chunk, y * chunk, z * chunk), chunk, out);
            }
        });
        std::vector<Block> blocks;
        for (auto& v : local) blocks.insert(blocks.end(), v.begin(), v.end());
        // A fixed order makes the build reproducible run to run.
        std::sort(blocks.begin(), blocks.end(), [](const Block& a, const Block& b) { return a.origin < b.origin; });
        return blocks;
    }

    bool overflow() const { return overflow_.load(); }
    std::uint64_t grid_blocks() const { return bits_.load(); }

private:
    void visit(const Coord& origin, int size, std::vector<Block>& out) {
        if (overflow_.load(std::memory_order_relaxed)) return;
        const double v = layout_.voxel_size;
        // World box of the voxel centres in this node.
        const Vec3d lo = origin.asVec3d() * v, hi = (origin + Coord(size - 1)).asVec3d() * v;
        if (!region_.may_intersect(lo, hi, region_.shell_min(), region_.shell_max())) return;
        if (size == kLeafDim) {
            std::uint64_t mask = 0;
            for (std::size_t c = 0; c < radii_.size(); ++c)
                if (region_.may_intersect(lo, hi, radii_[c].r_min, radii_[c].r_max)) mask |= std::uint64_t(1) << c;
            if (mask == 0) return;
            out.push_back({origin, mask});
            if (bits_.fetch_add(std::popcount(mask), std::memory_order_relaxed) + std::popcount(mask) > max_block_bits_)
                overflow_.store(true);
            return;
        }
        const int h = size / 2;
        for (int i = 0; i < 8; ++i) visit(origin + Coord(i & 1 ? h : 0, i & 2 ? h : 0, i & 4 ? h : 0), h, out);
    }

    const VdbLayout& layout_;
    const detail::VdbRegionTest& region_;
    std::vector<Radii> radii_;
    std::uint64_t max_block_bits_;
    std::atomic<std::uint64_t> bits_{0};
    std::atomic<bool> overflow_{false};
};

// Fills one block: the density of every constituent at each voxel centre of the
// region, active where it reaches the constituent's threshold. Leaves go to the
// calling thread's trees.
void fill_block(const VdbLayout& layout, const detail::VdbRegionTest& region, const Block& block,
                std::vector<openvdb::FloatTree::Ptr>& trees) {
    const double v = layout.voxel_size, L = layout.metres_per_unit;
    const std::size_t nc = layout.constituents.size();
    std::array<LeafT*, kMaxConstituents> leaves{};
    for (int x = 0; x < kLeafDim; ++x) {
        for (int y = 0; y < kLeafDim; ++y) {
            for (int z = 0; z < kLeafDim; ++z) {
                const Coord ijk = block.origin + Coord(x, y, z);
                const Vec3d p = ijk.asVec3d() * v;
                if (!region.contains_ignoring_shell(p)) continue;
                const double r = (p - layout.planet_center).length();
                if (r > layout.atmosphere_top) continue;  // no atmosphere above the top
                const double h_m = (r - layout.planet_radius) * L;
                for (std::size_t c = 0; c < nc; ++c) {
                    if (!(block.mask >> c & 1)) continue;
                    const VdbConstituent& con = layout.constituents[c];
                    if (h_m < con.band_min_m || h_m > con.band_max_m) continue;
                    const double rho = con.source->profile.at(h_m);
                    if (!(rho > 0.0) || rho < con.density_threshold) continue;
                    if (!leaves[c]) leaves[c] = new LeafT(block.origin, 0.0f, false);
                    leaves[c]->setValueOn(LeafT::coordToOffset(ijk), float(rho));
                }
            }
        }
    }
    for (std::size_t c = 0; c < nc; ++c)
        if (leaves[c]) trees[c]->addLeaf(leaves[c]);  // the tree takes ownership
}

// A voxel size that would bring a cost scaling as v^−exponent down by `ratio`.
std::string suggest_voxel(const VdbLayout& layout, double ratio, double exponent) {
    return detail::fmt(layout.voxel_size * std::pow(std::max(1.0, ratio), 1.0 / exponent) * 1.05) + " " +
           std::string(length_unit_name(layout.options.unit));
}

}  // namespace

VdbVolume build_vdb_volume(const Scene& scene, const VdbOptions& options, const VdbRunOptions& run) {
    return build_vdb_volume(resolve_vdb_layout(scene, options), run);
}

VdbVolume build_vdb_volume(const VdbLayout& layout, const VdbRunOptions& run) {
    openvdb::initialize();
    const auto t0 = std::chrono::steady_clock::now();
    if (layout.constituents.size() > kMaxConstituents)
        throw VdbError("the scene has " + std::to_string(layout.constituents.size()) + " active constituents; at most " +
                       std::to_string(kMaxConstituents) + " can be exported");
    const detail::VdbRegionTest region(layout);
    const std::string unit(length_unit_name(layout.options.unit));
    const std::string where = "the " + std::string(region_name(layout.options.region)) + " region";

    // 1. Blocks, refusing early when they could not fit in memory.
    const double max_bytes = layout.options.max_memory_mb * 1024.0 * 1024.0;
    BlockEnumerator enumerator(layout, region, std::uint64_t(max_bytes / kLeafBytes) + 1);
    std::vector<Block> blocks = enumerator.run();
    if (enumerator.overflow())
        throw VdbError(where + " at --voxel-size " + detail::fmt(layout.voxel_size) + " " + unit +
                       " needs more than --max-memory-mb = " + detail::fmt(layout.options.max_memory_mb) +
                       " MiB of grids; use a larger --voxel-size (try " + suggest_voxel(layout, 4.0, 2.0) +
                       " or more), a smaller region (--region view or box), or raise --max-memory-mb");
    if (blocks.empty())
        throw VdbError("region outside the atmosphere: " + where + " does not meet the atmosphere (radius " +
                       detail::fmt(layout.planet_radius) + " to " + detail::fmt(layout.atmosphere_top) + " " + unit +
                       " around the planet centre)");
    if (run.cancel && run.cancel->requested()) throw Cancelled("vdb export cancelled");

    // 2. Fill the blocks in parallel, in batches so that progress and cancellation are
    //    handled from the calling thread.
    const std::size_t nc = layout.constituents.size();
    tbb::enumerable_thread_specific<std::vector<openvdb::FloatTree::Ptr>> local([nc] {
        std::vector<openvdb::FloatTree::Ptr> t;
        for (std::size_t c = 0; c < nc; ++c) t.push_back(std::make_shared<openvdb::FloatTree>(0.0f));
        return t;
    });
    const std::size_t batches = std::min<std::size_t>(blocks.size(), 100);
    for (std::size_t b = 0; b < batches; ++b) {
        const std::size_t begin = blocks.size() * b / batches, end = blocks.size() * (b + 1) / batches;
        tbb::parallel_for(tbb::blocked_range<std::size_t>(begin, end, 8), [&](const auto& range) {
            auto& trees = local.local();
            for (std::size_t i = range.begin(); i != range.end(); ++i) fill_block(layout, region, blocks[i], trees);
        });
        if (run.cancel && run.cancel->requested()) throw Cancelled("vdb export cancelled");
        if (run.progress) run.progress(double(b + 1) / double(batches));
    }
    blocks = {};

    // 3. Merge the per-thread trees (their leaves are disjoint: merging moves them).
    std::vector<openvdb::FloatGrid::Ptr> grids;
    for (std::size_t c = 0; c < nc; ++c) {
        auto tree = std::make_shared<openvdb::FloatTree>(0.0f);
        for (auto& trees : local) tree->merge(*trees[c]);
        auto grid = openvdb::FloatGrid::create(tree);
        grid->setTransform(openvdb::math::Transform::createLinearTransform(layout.voxel_size));
        grid->setName(layout.constituents[c].name);
        grid->setGridClass(openvdb::GRID_FOG_VOLUME);
        grids.push_back(grid);
    }
    local.clear();

    // 4. Tiles, metadata, statistics.
    const detail::TilingChoice tiling = detail::choose_tiling(grids, layout.options);
    VdbVolume volume;
    volume.layout = layout;
    volume.tiles = detail::split_into_tiles(grids, tiling);
    grids.clear();

    VdbStats& s = volume.stats;
    s.voxel_size = layout.voxel_size;
    s.unit = layout.options.unit;
    s.tiles = volume.tiles.size();
    for (std::size_t t = 0; t < volume.tiles.size(); ++t) {
        for (std::size_t c = 0; c < nc; ++c) {
            const auto& g = volume.tiles[t].grids[c];
            if (!g) continue;
            detail::add_grid_metadata(*g, layout, layout.constituents[c], t, volume.tiles.size());
            VdbGridStats gs;
            gs.name = g->getName();
            gs.tile = t;
            gs.active_voxels = g->activeVoxelCount();
            const auto bb = g->evalActiveVoxelBoundingBox();
            gs.bbox = {bb.min().x(), bb.min().y(), bb.min().z(), bb.max().x(), bb.max().y(), bb.max().z()};
            gs.dense_voxels = bb.empty() ? 0 : bb.volume();
            gs.memory_bytes = g->memUsage();
            s.active_voxels += gs.active_voxels;
            s.memory_bytes += gs.memory_bytes;
            s.dense_bytes += gs.dense_voxels * sizeof(float);
            s.grids.push_back(gs);
        }
    }
    s.dense_bytes_untiled = tiling.dense_voxels_untiled * sizeof(float);
    s.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (s.active_voxels == 0)
        throw VdbError("region outside the atmosphere: " + where +
                       " holds no voxel with a density above the activity threshold (--tolerance = " +
                       detail::fmt(layout.options.tolerance) + ")");
    const double dense_mb = double(s.dense_bytes) / (1024.0 * 1024.0);
    if (dense_mb > layout.options.max_dense_mb)
        throw VdbError("the dense bounding boxes Blender 3.4 would allocate need " + detail::mib(double(s.dense_bytes)) +
                       " (" + std::to_string(s.tiles) + " tile(s)) > --max-dense-mb = " +
                       detail::fmt(layout.options.max_dense_mb) + "; use --voxel-size " +
                       suggest_voxel(layout, dense_mb / layout.options.max_dense_mb, 3.0) +
                       " or more, --region view or box, or raise --max-dense-mb");
    return volume;
}

}  // namespace airmass
