// export_vdb: build, report, write every tile atomically.
#include <openvdb/io/File.h>

#include <chrono>
#include <fstream>

#include "airmass/progress.hpp"
#include "airmass/vdb_grids.hpp"
#include "atomic_output.hpp"
#include "vdb_format.hpp"

namespace airmass {

namespace fs = std::filesystem;

std::vector<fs::path> vdb_output_paths(const fs::path& path, std::size_t tiles) {
    if (tiles <= 1) return {path};
    std::vector<fs::path> out;
    const fs::path dir = path.parent_path();
    for (const auto& name : volume_file_names(path.stem().string(), tiles)) out.push_back(dir / name);
    return out;
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

std::vector<std::string> file_names(const std::vector<fs::path>& paths) {
    std::vector<std::string> out;
    for (const auto& p : paths) out.push_back(p.filename().string());
    return out;
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
            openvdb::MetaMap meta;
            detail::insert_metadata(meta, volume_file_metadata(volume.layout, t, volume.tiles.size()));
            file.write(grids, meta);
            file.close();
        } catch (const openvdb::Exception& e) {
            throw VdbError("cannot write '" + paths[t].string() + "': " + e.what());
        }
    }
    if (volume.tiles.size() > 1) {
        const fs::path tmp = outputs.add(paths.back());
        std::ofstream f(tmp, std::ios::binary);
        f << volume_tiles_manifest(volume.layout, volume.stats, file_names(paths));
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
