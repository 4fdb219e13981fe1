// export_vdb: build, report, write every tile atomically.
#include <openvdb/io/File.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>

#include "airmass/progress.hpp"
#include "airmass/vdb_grids.hpp"
#include "atomic_output.hpp"
#include "vdb_format.hpp"

namespace airmass {

namespace fs = std::filesystem;

namespace {

// What openvdb::io::File::write does — Archive::write(stream, grids, seekable = true, meta) —
// into a stream whose failure is checked: io::File never looks at its stream after writing,
// so a full disk or a file-size limit (EFBIG) would leave a truncated file that looks written.
class CheckedVdbWriter : public openvdb::io::Archive {
public:
    void write_file(const fs::path& tmp, const fs::path& dest, const openvdb::GridPtrVec& grids,
                    const openvdb::MetaMap& meta) const {
        std::ofstream os(tmp, std::ios::binary | std::ios::trunc);
        if (!os) throw VdbError("cannot write '" + dest.string() + "': cannot create '" + tmp.string() + "'");
        errno = 0;
        Archive::write(os, grids, /*seekable=*/true, meta);
        os.close();
        if (!os)
            throw VdbError("cannot write '" + dest.string() + "': " +
                           (errno != 0 ? std::string(std::strerror(errno)) : std::string("the write failed")));
    }
};

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
    AtomicOutputs outputs(run.cancel);  // nothing replaced unless every file was written
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
            CheckedVdbWriter writer;
            writer.setCompression(compression);
            openvdb::MetaMap meta;
            detail::insert_metadata(meta, volume_file_metadata(volume.layout, t, volume.tiles.size()));
            writer.write_file(tmp, paths[t], grids, meta);
        } catch (const openvdb::Exception& e) {
            throw VdbError("cannot write '" + paths[t].string() + "': " + e.what());
        }
    }
    detail::as_vdb_error([&] {
        if (volume.tiles.size() > 1)
            outputs.write(paths.back(), volume_tiles_manifest(volume.layout, volume.stats, file_names(paths)));
        outputs.commit();
    });
    stats.write_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    stats.files = paths;
    for (const auto& p : paths)
        if (p.extension() == ".vdb") stats.file_bytes += fs::file_size(p);
    return stats;
}

}  // namespace airmass
