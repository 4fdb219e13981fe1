// export_vdb: build, report, write every tile atomically.
#include <openvdb/io/File.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>

#include "airmass/progress.hpp"
#include "airmass/vdb_grids.hpp"
#include "atomic_output.hpp"
#include "vdb_format.hpp"

namespace airmass {

namespace fs = std::filesystem;
using detail::fmt;
using detail::mib;

std::vector<fs::path> vdb_output_paths(const fs::path& path, std::size_t tiles) {
    if (tiles <= 1) return {path};
    // "<stem>.003.tile.vdb". Blender 3.4's importer (File > Import > OpenVDB) turns any
    // multi-file selection of numbered names into one animated sequence unless "Detect
    // Sequences" is off (use_sequence_detection=False); docs/vdb.md says so.
    std::vector<fs::path> out;
    const fs::path dir = path.parent_path();
    const std::string stem = path.stem().string();
    for (std::size_t t = 0; t < tiles; ++t) {
        char idx[32];
        std::snprintf(idx, sizeof idx, "%03zu", t);
        out.push_back(dir / (stem + "." + idx + ".tile.vdb"));
    }
    out.push_back(dir / (stem + ".tiles.json"));
    return out;
}

std::string VdbStats::summary() const {
    std::ostringstream o;
    const std::string u(length_unit_name(unit));
    o << "voxel size " << fmt(voxel_size) << " " << u << ", " << tiles << " tile(s)\n";
    char line[256];
    std::snprintf(line, sizeof line, "  %-12s %5s %14s %22s %12s %12s\n", "grid", "tile", "active voxels",
                  "dense box (voxels)", "dense", "memory");
    o << line;
    // Per tile when there are few; per grid (summed over tiles) otherwise.
    const bool per_tile = tiles <= 4;
    std::map<std::string, VdbGridStats> sums;
    std::vector<std::string> order;
    for (const auto& g : grids) {
        if (per_tile) {
            const std::string box = std::to_string(g.bbox[3] - g.bbox[0] + 1) + "x" +
                                    std::to_string(g.bbox[4] - g.bbox[1] + 1) + "x" +
                                    std::to_string(g.bbox[5] - g.bbox[2] + 1);
            std::snprintf(line, sizeof line, "  %-12s %5zu %14llu %22s %12s %12s\n", g.name.c_str(), g.tile,
                          (unsigned long long)g.active_voxels, box.c_str(), mib(double(g.dense_voxels) * 4).c_str(),
                          mib(double(g.memory_bytes)).c_str());
            o << line;
        } else {
            if (!sums.count(g.name)) order.push_back(g.name);
            auto& s = sums[g.name];
            s.active_voxels += g.active_voxels;
            s.dense_voxels += g.dense_voxels;
            s.memory_bytes += g.memory_bytes;
        }
    }
    for (const auto& name : order) {
        const auto& s = sums[name];
        std::snprintf(line, sizeof line, "  %-12s %5s %14llu %22s %12s %12s\n", name.c_str(), "all",
                      (unsigned long long)s.active_voxels, "-", mib(double(s.dense_voxels) * 4).c_str(),
                      mib(double(s.memory_bytes)).c_str());
        o << line;
    }
    o << "  total: " << active_voxels << " active voxels, " << mib(double(memory_bytes)) << " in memory, dense boxes "
      << mib(double(dense_bytes)) << " (as one tile: " << mib(double(dense_bytes_untiled)) << "), built in "
      << fmt(build_seconds) << " s";
    if (!files.empty()) o << ", written in " << fmt(write_seconds) << " s, " << mib(double(file_bytes)) << " on disk";
    o << "\n";
    return o.str();
}

void write_text_atomic(const fs::path& path, std::string_view text) {
    detail::check_output_destination(path);
    detail::AtomicOutputs out;
    const fs::path tmp = out.add(path);
    {
        std::ofstream f(tmp, std::ios::binary);
        f.write(text.data(), std::streamsize(text.size()));
        f.close();
        if (!f) throw VdbError("cannot write '" + path.string() + "'");
    }
    out.commit();
}

namespace {

std::string tiles_manifest(const VdbVolume& volume, const std::vector<fs::path>& paths) {
    using nlohmann::json;
    json tiles = json::array();
    for (std::size_t t = 0; t < volume.tiles.size(); ++t) {
        json grids = json::object();
        for (const auto& g : volume.stats.grids) {
            if (g.tile != t) continue;
            grids[g.name] = json{{"active_voxels", g.active_voxels},
                                 {"bbox_min", {g.bbox[0], g.bbox[1], g.bbox[2]}},
                                 {"bbox_max", {g.bbox[3], g.bbox[4], g.bbox[5]}}};
        }
        tiles.push_back(json{{"file", paths[t].filename().string()}, {"grids", grids}});
    }
    const auto& L = volume.layout;
    json j{{"format", "airmass-vdb-tiles"},
           {"format_version", detail::kVdbFormatVersion},
           {"length_unit", std::string(length_unit_name(L.options.unit))},
           {"voxel_size", L.voxel_size},
           {"planet_center", {L.planet_center[0], L.planet_center[1], L.planet_center[2]}},
           {"planet_radius", L.planet_radius},
           {"atmosphere_top", L.atmosphere_top},
           {"tiles", tiles}};
    return j.dump(2) + "\n";
}

}  // namespace

VdbStats export_vdb(const Scene& scene, const VdbOptions& options, const fs::path& path, const VdbRunOptions& run) {
    if (!run.dry_run) {
        if (path.extension() != ".vdb")
            throw VdbError("output '" + path.string() + "': the file name must end in .vdb");
        detail::check_output_destination(path);  // fail before the expensive part
    }
    VdbVolume volume = build_vdb_volume(scene, options, run);
    VdbStats stats = volume.stats;
    if (run.before_write) run.before_write(stats);
    if (run.dry_run) return stats;

    const auto t0 = std::chrono::steady_clock::now();
    const std::vector<fs::path> paths = vdb_output_paths(path, volume.tiles.size());
    detail::AtomicOutputs outputs;
    const std::uint32_t compression = openvdb::io::Archive::hasBloscCompression()
                                          ? openvdb::io::COMPRESS_BLOSC | openvdb::io::COMPRESS_ACTIVE_MASK
                                          : openvdb::io::COMPRESS_ZIP | openvdb::io::COMPRESS_ACTIVE_MASK;
    for (std::size_t t = 0; t < volume.tiles.size(); ++t) {
        if (run.cancel && run.cancel->requested()) throw Cancelled("vdb export cancelled");
        openvdb::GridPtrVec grids;
        for (const auto& g : volume.tiles[t].grids)
            if (g) grids.push_back(g);
        const fs::path tmp = outputs.add(paths[t]);
        try {
            openvdb::io::File file(tmp.string());
            file.setCompression(compression);
            file.write(grids, *detail::file_metadata(volume.layout, t, volume.tiles.size()));
            file.close();
        } catch (const openvdb::Exception& e) {
            throw VdbError("cannot write '" + paths[t].string() + "': " + e.what());
        }
    }
    if (volume.tiles.size() > 1) {
        const fs::path tmp = outputs.add(paths.back());
        std::ofstream f(tmp, std::ios::binary);
        f << tiles_manifest(volume, paths);
        f.close();
        if (!f) throw VdbError("cannot write '" + paths.back().string() + "'");
    }
    outputs.commit();
    stats.write_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    stats.files = paths;
    for (const auto& p : paths)
        if (p.extension() == ".vdb") stats.file_bytes += fs::file_size(p);
    return stats;
}

}  // namespace airmass
