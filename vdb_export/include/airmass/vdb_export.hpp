// The atmosphere as OpenVDB files: sparse float grids of each constituent's relative
// density (`airmass vdb`), POV-Ray density files, and the text outputs beside them.
//
// Every decision about the grids — region, voxel size, activity, tiling, metadata — is
// the OpenVDB-free volume layer's (airmass/volume.hpp, library airmass_volume); this
// library (airmass_vdb) only turns its blocks into OpenVDB trees and writes the files.
// Everything a reader needs is in docs/vdb.md: grid names and values, the metadata
// keys, length units, regions, tiling and the voxel-size trade table.
//
// This header is free of OpenVDB; airmass/vdb_grids.hpp exposes the grids in memory.
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "airmass/volume.hpp"

namespace airmass {

struct VdbRunOptions {
    VdbProgress progress;                 // may be empty
    const CancelFlag* cancel = nullptr;   // polled; Cancelled is thrown, nothing written
    bool dry_run = false;                 // build and report, write nothing
    int threads = 0;                      // workers of the build; 0: all hardware threads
    // Called with the stats after the build and before anything is written (the CLI
    // prints them there).
    std::function<void(const VdbStats&)> before_write;
};

// Builds the grids of every active constituent over the requested region and writes
// them: one file `path` when there is one tile, otherwise `<stem>.NNN.tile.vdb` per tile
// plus the manifest `<stem>.tiles.json` (docs/vdb.md, "Tiling"). Atomic: every file
// goes to a temporary beside its destination and is renamed only after all were
// written; on any failure no output (and no temporary) is left. Throws VdbError
// (bad options, limits, unwritable output), SceneError (invalid scene), Cancelled.
VdbStats export_vdb(const Scene& scene, const VdbOptions& options, const std::filesystem::path& path,
                    const VdbRunOptions& run = {});

// The files export_vdb writes for `path` when the volume has `tiles` tiles.
std::vector<std::filesystem::path> vdb_output_paths(const std::filesystem::path& path, std::size_t tiles);

// ---- Other outputs ------------------------------------------------------------------------

// analytic_density_json and pov_include: airmass/volume.hpp.

// POV-Ray density_file: one .df3 per active constituent (`<stem>.<name>.df3`) over the
// region's bounding box at the options' voxel size, 32-bit big-endian, normalised to
// the constituent's maximum in the box, one voxel of zeros around it; plus
// `<stem>.df3.inc` placing each file in POV-Ray's frame. Atomic like export_vdb.
// Returns the files written.
std::vector<std::filesystem::path> export_df3(const Scene& scene, const VdbOptions& options,
                                              const std::filesystem::path& stem_path, const VdbRunOptions& run = {});

// Writes `text` to `path` via temporary file + rename (airmass/atomic_file.hpp): VdbError on
// failure, Cancelled when `cancel` is requested before the rename; either way `path` untouched.
void write_text_atomic(const std::filesystem::path& path, std::string_view text, const CancelFlag* cancel = nullptr);

}  // namespace airmass
