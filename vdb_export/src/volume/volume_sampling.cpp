// Sampling the densities into 8³ blocks: enumerate the blocks the region may touch by
// recursive culling, then fill them in parallel (airmass/parallel.hpp) — the one
// implementation behind the OpenVDB writer's leaves, the plan's bounding boxes and the
// dense blocks a host copies into its own grids.
#include <glm/geometric.hpp>

#include <algorithm>
#include <atomic>
#include <bit>
#include <mutex>
#include <new>
#include <string>
#include <unordered_map>

#include "airmass/parallel.hpp"
#include "airmass/progress.hpp"
#include "airmass/volume.hpp"
#include "volume_format.hpp"
#include "volume_region.hpp"
#include "voxel_average.hpp"

namespace airmass {

using Vec3d = Vec3<double>;

namespace {

constexpr int kDim = kVolumeBlockDim;
// Approximate bytes of one OpenVDB float leaf in memory (values, masks, origin, node overhead).
constexpr double kLeafBytes = kVolumeBlockVoxels * sizeof(float) + 2 * (kVolumeBlockVoxels / 8) + 32;

int floor_div(int a, int b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }
int block_floor(int a) { return floor_div(a, kDim) * kDim; }

struct Radii {
    double r_min, r_max;  // shell radii (unit) of a constituent's band
};

// The lattice of top-level chunks the enumeration starts from: it depends on the layout
// only, so a restricted enumeration walks exactly the hierarchy of the full one.
struct ChunkLattice {
    VoxelCoord lo{0, 0, 0};  // block-aligned corner
    int chunk = kDim;        // edge of a chunk in voxels (power-of-two multiple of a block)
    std::array<std::int64_t, 3> n{0, 0, 0};
};

ChunkLattice chunk_lattice(const VdbLayout& layout) {
    const VoxelBox& b = layout.index_bounds;
    ChunkLattice c;
    std::array<std::int64_t, 3> ext{};
    for (int a = 0; a < 3; ++a) {
        c.lo[a] = block_floor(b.min[a]);
        ext[a] = std::int64_t(b.max[a]) - c.lo[a] + 1;
    }
    // The smallest power-of-two multiple of a block that keeps the number of chunks near
    // 2^18, so huge regions do not enumerate billions of blocks.
    auto chunks_of = [&](std::int64_t s) {
        return double((ext[0] + s - 1) / s) * double((ext[1] + s - 1) / s) * double((ext[2] + s - 1) / s);
    };
    while (chunks_of(c.chunk) > double(1 << 18) && c.chunk < (1 << 28)) c.chunk *= 2;
    for (int a = 0; a < 3; ++a) c.n[a] = (ext[a] + c.chunk - 1) / c.chunk;
    return c;
}

VoxelBox node_box(const VoxelCoord& origin, int size) {
    return VoxelBox{origin, {origin[0] + size - 1, origin[1] + size - 1, origin[2] + size - 1}};
}

class BlockEnumerator {
public:
    BlockEnumerator(const VdbLayout& layout, const detail::VdbRegionTest& region, const std::vector<Radii>& radii,
                    const VoxelBox& clip, std::uint64_t max_block_bits)
        : layout_(layout), region_(region), radii_(radii), clip_(clip), max_block_bits_(max_block_bits) {}

    std::vector<VolumeBlock> run(int threads) {
        const ChunkLattice lat = chunk_lattice(layout_);
        // The chunks meeting the clip box.
        std::array<std::int64_t, 3> first{}, count{};
        for (int a = 0; a < 3; ++a) {
            const std::int64_t f = std::max<std::int64_t>(0, floor_div64(std::int64_t(clip_.min[a]) - lat.lo[a], lat.chunk));
            const std::int64_t l =
                std::min<std::int64_t>(lat.n[a] - 1, floor_div64(std::int64_t(clip_.max[a]) - lat.lo[a], lat.chunk));
            first[a] = f;
            count[a] = std::max<std::int64_t>(0, l - f + 1);
        }
        const std::int64_t total = count[0] * count[1] * count[2];
        const int workers = volume_workers(threads);
        std::vector<std::vector<VolumeBlock>> local(std::size_t(std::max(1, workers)));
        parallel_for(0, std::size_t(std::max<std::int64_t>(0, total)), 64, workers,
                     [&](std::size_t b, std::size_t e, int w) {
                         auto& out = local[std::size_t(w)];
                         for (std::size_t i = b; i != e && !overflow_.load(std::memory_order_relaxed); ++i) {
                             const std::int64_t ii = std::int64_t(i);
                             const std::int64_t x = ii % count[0], y = (ii / count[0]) % count[1],
                                                z = ii / (count[0] * count[1]);
                             const VoxelCoord o{int(lat.lo[0] + (first[0] + x) * lat.chunk),
                                                int(lat.lo[1] + (first[1] + y) * lat.chunk),
                                                int(lat.lo[2] + (first[2] + z) * lat.chunk)};
                             visit(o, lat.chunk, out);
                         }
                     });
        std::vector<VolumeBlock> blocks;
        for (auto& v : local) blocks.insert(blocks.end(), v.begin(), v.end());
        // A fixed order makes every pass reproducible run to run.
        std::sort(blocks.begin(), blocks.end(),
                  [](const VolumeBlock& a, const VolumeBlock& b) { return a.origin < b.origin; });
        return blocks;
    }

    bool overflow() const { return overflow_.load(); }

private:
    static std::int64_t floor_div64(std::int64_t a, std::int64_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

    void visit(const VoxelCoord& origin, int size, std::vector<VolumeBlock>& out) {
        if (overflow_.load(std::memory_order_relaxed)) return;
        if (!node_box(origin, size).intersects(clip_)) return;
        const double v = layout_.voxel_size;
        // World box of the voxel centres in this node.
        const Vec3d lo = Vec3d(origin[0], origin[1], origin[2]) * v;
        const Vec3d hi = Vec3d(origin[0] + size - 1, origin[1] + size - 1, origin[2] + size - 1) * v;
        if (!region_.may_intersect(lo, hi, region_.shell_min(), region_.shell_max())) return;
        if (size == kDim) {
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
        for (int i = 0; i < 8; ++i)
            visit({origin[0] + (i & 1 ? h : 0), origin[1] + (i & 2 ? h : 0), origin[2] + (i & 4 ? h : 0)}, h, out);
    }

    const VdbLayout& layout_;
    const detail::VdbRegionTest& region_;
    const std::vector<Radii>& radii_;
    VoxelBox clip_;
    std::uint64_t max_block_bits_;
    std::atomic<std::uint64_t> bits_{0};
    std::atomic<bool> overflow_{false};
};

std::string where_of(const VdbLayout& layout) {
    return "the " + std::string(region_name(layout.options.region)) + " region";
}

}  // namespace

struct VolumeSampler::Region {
    detail::VdbRegionTest test;
    detail::SymmetricAverages::Lattice lattice;  // the voxels' geometry (fill and the store share it)
    std::vector<Radii> radii;
    std::vector<detail::DensityPieces> pieces;  // VoxelValues::average: each constituent's profile
    // The means that need quadrature, once per class of voxels the planet's symmetry makes
    // equal (voxel_average.hpp); at most kAverageMemoBytes of table, then computed directly.
    std::unique_ptr<detail::SymmetricAverages> averages;
    static constexpr std::size_t kAverageMemoBytes = std::size_t(192) << 20;
    explicit Region(const VdbLayout& layout)
        : test(layout),
          lattice{layout.voxel_size, layout.planet_center, layout.planet_radius, layout.metres_per_unit} {
        const double top_m = (layout.atmosphere_top - layout.planet_radius) * layout.metres_per_unit;
        bool any_average = false;
        for (const auto& c : layout.constituents) {
            radii.push_back({layout.planet_radius + c.band_min_m / layout.metres_per_unit,
                             layout.planet_radius + c.band_max_m / layout.metres_per_unit});
            pieces.push_back(detail::DensityPieces::of(c.source->profile, top_m));
            any_average = any_average || c.values == VoxelValues::average;
        }
        if (any_average)
            averages = std::make_unique<detail::SymmetricAverages>(lattice, pieces, kAverageMemoBytes);
    }
};

VolumeSampler::VolumeSampler(const VdbLayout& layout) : layout_(layout) {
    if (layout.constituents.size() > kMaxVolumeConstituents)
        throw VdbError("the scene has " + std::to_string(layout.constituents.size()) + " active constituents; at most " +
                       std::to_string(kMaxVolumeConstituents) + " can be exported");
    region_ = std::make_unique<Region>(layout);
}

// The kept blocks: a map from origin to the values of the constituents active there, filled by
// the sampling pass's workers, read by box requests, a lock per block either way (a plain mutex:
// std::shared_mutex would take pthread_rwlock_* at GLIBC_2.34, past the add-on's 2.28 baseline).
// A block's entry never changes once inserted, and map nodes do not move: `kept` hands out
// pointers into it.
struct VolumeSampler::Kept {
    struct Hash {
        std::size_t operator()(const VoxelCoord& o) const {
            std::uint64_t h = 0;
            for (int a = 0; a < 3; ++a) h = (h ^ std::uint32_t(o[std::size_t(a)])) * 0x9E3779B97F4A7C15ull;
            return std::size_t(h ^ (h >> 29));
        }
    };
    struct Block {
        std::uint64_t on = 0;       // constituents with active voxels
        std::vector<float> values;  // kVolumeBlockVoxels per constituent of `on`, in order
    };
    explicit Kept(std::size_t max) : max_bytes(max) {}
    const std::size_t max_bytes;
    mutable std::mutex mutex;
    std::size_t bytes = 0;  // under mutex
    std::unordered_map<VoxelCoord, Block, Hash> blocks;
};

VolumeSampler::VolumeSampler(const VdbLayout& layout, std::size_t keep_bytes) : VolumeSampler(layout) {
    if (keep_bytes > 0) kept_ = std::make_unique<Kept>(keep_bytes);
}

VolumeSampler::~VolumeSampler() = default;

void VolumeSampler::keep(const VolumeBlock& block, std::uint64_t on, std::span<const VolumeBlockValues> values) const {
    if (!kept_) return;
    const std::size_t n = std::size_t(std::popcount(on));
    // the entry, its map node and the values
    const std::size_t cost = sizeof(Kept::Block) + sizeof(VoxelCoord) + 32 + n * kVolumeBlockVoxels * sizeof(float);
    {
        std::lock_guard<std::mutex> lock(kept_->mutex);
        if (kept_->bytes + cost > kept_->max_bytes || kept_->blocks.count(block.origin)) return;
    }
    // Keeping is an optimisation: out of memory it stops (the limit is taken as reached), and the
    // pass goes on; the blocks not kept are sampled again when asked.
    std::lock_guard<std::mutex> lock(kept_->mutex);
    if (kept_->bytes + cost > kept_->max_bytes) return;
    try {
        Kept::Block b;
        b.on = on;
        b.values.reserve(n * kVolumeBlockVoxels);
        for (std::size_t c = 0; c < values.size() && c < 64; ++c)
            if (on >> c & 1) b.values.insert(b.values.end(), values[c].value.begin(), values[c].value.end());
        if (kept_->blocks.emplace(block.origin, std::move(b)).second) kept_->bytes += cost;
    } catch (const std::bad_alloc&) {
        kept_->bytes = kept_->max_bytes;
    }
}

bool VolumeSampler::kept(const VoxelCoord& origin, std::size_t c, const float*& values) const {
    values = nullptr;
    if (!kept_) return false;
    std::lock_guard<std::mutex> lock(kept_->mutex);
    const auto it = kept_->blocks.find(origin);
    if (it == kept_->blocks.end()) return false;
    const Kept::Block& b = it->second;
    if (c < 64 && (b.on >> c & 1))
        values = b.values.data() + std::size_t(std::popcount(b.on & ((std::uint64_t(1) << c) - 1))) * kVolumeBlockVoxels;
    return true;
}

std::size_t VolumeSampler::kept_bytes() const {
    if (!kept_) return 0;
    std::lock_guard<std::mutex> lock(kept_->mutex);
    return kept_->bytes;
}

int volume_workers(int threads) { return threads > 0 ? threads : hardware_threads(); }

VoxelBox volume_request_bounds(const VdbLayout& layout) {
    const VoxelBox& b = layout.index_bounds;
    if (b.empty()) return {};
    VoxelBox out;
    for (int a = 0; a < 3; ++a) {
        out.min[a] = block_floor(b.min[a]);
        out.max[a] = block_floor(b.max[a]) + kDim - 1;
    }
    return out;
}

std::vector<VolumeBlock> VolumeSampler::blocks(const VoxelBox* within, int threads) const {
    VoxelBox clip = volume_request_bounds(layout_);
    if (within) {
        for (int a = 0; a < 3; ++a) {
            clip.min[a] = std::max(clip.min[a], within->min[a]);
            clip.max[a] = std::min(clip.max[a], within->max[a]);
        }
    }
    if (clip.empty()) return {};
    const double max_bytes = layout_.options.max_memory_mb * 1024.0 * 1024.0;
    BlockEnumerator enumerator(layout_, region_->test, region_->radii, clip, std::uint64_t(max_bytes / kLeafBytes) + 1);
    std::vector<VolumeBlock> out = enumerator.run(threads);
    if (enumerator.overflow()) {
        const std::string unit(length_unit_name(layout_.options.unit));
        throw VdbError(where_of(layout_) + " at --voxel-size " + detail::fmt(layout_.voxel_size) + " " + unit +
                       " needs more than --max-memory-mb = " + detail::fmt(layout_.options.max_memory_mb) +
                       " MiB of grids; use a larger --voxel-size (try " + detail::suggest_voxel(layout_, 4.0, 2.0) +
                       " or more), a smaller region (--region view or box), or raise --max-memory-mb");
    }
    return out;
}

std::uint64_t VolumeSampler::fill(const VolumeBlock& block, std::span<VolumeBlockValues> out) const {
    const VdbLayout& L = layout_;
    const std::size_t nc = L.constituents.size();
    if (out.size() < nc) throw std::invalid_argument("VolumeSampler::fill: one VolumeBlockValues per constituent");
    for (std::size_t c = 0; c < nc; ++c) out[c] = VolumeBlockValues{};
    const std::uint64_t mask = nc >= 64 ? block.constituents : block.constituents & ((std::uint64_t(1) << nc) - 1);
    if (mask == 0) return 0;
    const double v = L.voxel_size, Lm = L.metres_per_unit;
    const detail::VdbRegionTest& region = region_->test;
    std::uint64_t any = 0;
    for (int x = 0; x < kDim; ++x) {
        for (int y = 0; y < kDim; ++y) {
            for (int z = 0; z < kDim; ++z) {
                const VoxelCoord ijk{block.origin[0] + x, block.origin[1] + y, block.origin[2] + z};
                const Vec3d p = region_->lattice.point(ijk[0], ijk[1], ijk[2]);
                if (!region.contains_ignoring_shell(p)) continue;
                const auto [r, h_m, up] = region_->lattice.at(p);
                // No atmosphere above the top: no point value there; a mean there is its hat's
                // share of the air below the top (the bands say how far).
                const bool above_top = r > L.atmosphere_top;
                const int offset = x * kDim * kDim + y * kDim + z;
                // Each constituent's value; the means without a closed form are asked of the
                // symmetric store together (one lookup per voxel).
                double rho[kMaxVolumeConstituents];
                std::uint64_t in_band = 0, quadrature = 0;
                for (std::size_t c = 0; c < nc; ++c) {
                    if (!(mask >> c & 1)) continue;
                    const VdbConstituent& con = L.constituents[c];
                    if (h_m < con.band_min_m || h_m > con.band_max_m) continue;
                    if (above_top && con.values != VoxelValues::average) continue;
                    in_band |= std::uint64_t(1) << c;
                    if (con.values != VoxelValues::average)
                        rho[c] = con.source->profile.at(h_m);
                    else if (!detail::voxel_average_closed_form(region_->pieces[c], h_m, up, v * Lm, rho[c]))
                        quadrature |= std::uint64_t(1) << c;
                }
                if (quadrature) region_->averages->get(ijk, quadrature, rho);
                for (std::size_t c = 0; c < nc; ++c) {
                    if (!(in_band >> c & 1)) continue;
                    const VdbConstituent& con = L.constituents[c];
                    if (!(rho[c] > 0.0) || rho[c] < con.density_threshold) continue;
                    const float f = float(rho[c]);
                    if (!(f > 0.0f)) continue;  // an active voxel holds a nonzero value
                    VolumeBlockValues& o = out[c];
                    o.value[std::size_t(offset)] = f;
                    o.active[std::size_t(offset) >> 6] |= std::uint64_t(1) << (offset & 63);
                    ++o.active_count;
                    o.active_box.expand(ijk);
                    any |= std::uint64_t(1) << c;
                }
            }
        }
    }
    return any;
}

namespace {

// Runs body(index, worker) over [0, n) in ~100 batches; cancellation and progress between.
template <class Body>
void in_batches(std::size_t n, const VolumeRunOptions& run, const char* what, Body&& body) {
    const int workers = volume_workers(run.threads);
    const std::size_t batches = std::min<std::size_t>(n, 100);
    for (std::size_t b = 0; b < batches; ++b) {
        const std::size_t begin = n * b / batches, end = n * (b + 1) / batches;
        parallel_for(begin, end, 8, workers, [&](std::size_t bb, std::size_t ee, int w) {
            for (std::size_t i = bb; i != ee; ++i) body(i, w);
        });
        if (run.cancel && run.cancel->requested()) throw Cancelled(std::string(what) + " cancelled");
        if (run.progress) run.progress(double(b + 1) / double(batches));
    }
}

}  // namespace

std::vector<VolumeLeaf> sample_volume(const VolumeSampler& sampler, const VolumeRunOptions& run,
                                      const VolumeBlockSink& sink) {
    const VdbLayout& L = sampler.layout();
    const std::vector<VolumeBlock> blocks = sampler.blocks(nullptr, run.threads);
    if (blocks.empty()) {
        const std::string unit(length_unit_name(L.options.unit));
        throw VdbError("region outside the atmosphere: " + where_of(L) + " does not meet the atmosphere (radius " +
                       detail::fmt(L.planet_radius) + " to " + detail::fmt(L.atmosphere_top) + " " + unit +
                       " around the planet centre)");
    }
    if (run.cancel && run.cancel->requested()) throw Cancelled("vdb export cancelled");
    const std::size_t nc = L.constituents.size();
    const int workers = volume_workers(run.threads);
    std::vector<std::vector<VolumeLeaf>> leaves(static_cast<std::size_t>(workers));
    std::vector<std::vector<VolumeBlockValues>> scratch(static_cast<std::size_t>(workers));
    in_batches(blocks.size(), run, "vdb export", [&](std::size_t i, int w) {
        auto& values = scratch[std::size_t(w)];
        if (values.size() != nc) values.resize(nc);
        const VolumeBlock& block = blocks[i];
        const std::uint64_t on = sampler.fill(block, values);
        sampler.keep(block, on, values);
        for (std::size_t c = 0; c < nc; ++c) {
            if (!(on >> c & 1)) continue;
            const VolumeBlockValues& v = values[c];
            leaves[std::size_t(w)].push_back({block.origin, std::uint32_t(c), v.active_count, v.active_box});
            if (sink) sink(w, block, c, v);
        }
    });
    std::vector<VolumeLeaf> out;
    for (auto& v : leaves) out.insert(out.end(), v.begin(), v.end());
    std::sort(out.begin(), out.end(), [](const VolumeLeaf& a, const VolumeLeaf& b) {
        return a.origin != b.origin ? a.origin < b.origin : a.constituent < b.constituent;
    });
    return out;
}

void sample_volume_box(const VolumeSampler& sampler, std::size_t constituent, const VoxelBox& box,
                       std::span<float> out, const VolumeRunOptions& run) {
    const VdbLayout& L = sampler.layout();
    const std::size_t nc = L.constituents.size();
    if (constituent >= nc)
        throw VdbError("constituent index " + std::to_string(constituent) + ": must be < " + std::to_string(nc));
    const char* axes = "xyz";
    for (int a = 0; a < 3; ++a)
        if (box.min[a] > box.max[a])
            throw VdbError(std::string("box: min.") + axes[a] + " = " + std::to_string(box.min[a]) + " must be <= max." +
                           axes[a] + " = " + std::to_string(box.max[a]));
    const VoxelBox bounds = volume_request_bounds(L);
    if (!bounds.contains(box))
        throw VdbError("box (" + std::to_string(box.min[0]) + ", " + std::to_string(box.min[1]) + ", " +
                       std::to_string(box.min[2]) + ") to (" + std::to_string(box.max[0]) + ", " +
                       std::to_string(box.max[1]) + ", " + std::to_string(box.max[2]) +
                       "): must lie within the region's index bounds (" + std::to_string(bounds.min[0]) + ", " +
                       std::to_string(bounds.min[1]) + ", " + std::to_string(bounds.min[2]) + ") to (" +
                       std::to_string(bounds.max[0]) + ", " + std::to_string(bounds.max[1]) + ", " +
                       std::to_string(bounds.max[2]) + ")");
    if (std::uint64_t(out.size()) != box.volume())
        throw VdbError("values: " + std::to_string(out.size()) + " floats for a box of " + std::to_string(box.dim(0)) +
                       " x " + std::to_string(box.dim(1)) + " x " + std::to_string(box.dim(2)) + " = " +
                       std::to_string(box.volume()) + " voxels");
    std::fill(out.begin(), out.end(), 0.0f);
    std::vector<VolumeBlock> blocks = sampler.blocks(&box, run.threads);
    const std::uint64_t bit = std::uint64_t(1) << constituent;
    std::erase_if(blocks, [&](const VolumeBlock& b) { return !(b.constituents & bit); });
    for (auto& b : blocks) b.constituents = bit;
    if (run.cancel && run.cancel->requested()) throw Cancelled("volume block cancelled");
    const std::int64_t ny = box.dim(1), nz = box.dim(2);
    const int workers = volume_workers(run.threads);
    std::vector<std::vector<VolumeBlockValues>> scratch(static_cast<std::size_t>(workers));
    in_batches(blocks.size(), run, "volume block", [&](std::size_t i, int w) {
        auto& values = scratch[std::size_t(w)];
        if (values.size() != nc) values.resize(nc);
        const VolumeBlock& block = blocks[i];
        // A block the sampling pass kept is copied, else sampled (the same values either way).
        const float* src;
        if (!sampler.kept(block.origin, constituent, src)) {
            if (!(sampler.fill(block, values) & bit)) return;
            src = values[constituent].value.data();
        }
        if (!src) return;  // kept: no active voxel of this constituent
        // The part of the block inside the box; blocks are disjoint, so are their writes.
        int lo[3], hi[3];
        for (int a = 0; a < 3; ++a) {
            lo[a] = std::max(block.origin[a], box.min[a]) - block.origin[a];
            hi[a] = std::min(block.origin[a] + kDim - 1, box.max[a]) - block.origin[a];
        }
        for (int x = lo[0]; x <= hi[0]; ++x)
            for (int y = lo[1]; y <= hi[1]; ++y) {
                const std::int64_t i0 = std::int64_t(block.origin[0]) + x - box.min[0];
                const std::int64_t j0 = std::int64_t(block.origin[1]) + y - box.min[1];
                const std::int64_t row = (i0 * ny + j0) * nz + (std::int64_t(block.origin[2]) - box.min[2]);
                for (int z = lo[2]; z <= hi[2]; ++z) out[std::size_t(row + z)] = src[std::size_t(x * 64 + y * 8 + z)];
            }
    });
}

}  // namespace airmass
