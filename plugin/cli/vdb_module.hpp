// The OpenVDB writer as a module the CLI loads when a command writes grids.
//
// libopenvdb brings ≈ 64 000 relocations to every process that links it: most of the start-up
// of `airmass` (an empty program linked to it starts in ≈ 120 ms on a loaded 2-core machine, to
// OpenEXR alone in 3 ms; issue 14 goal 4). So the executable links only the OpenVDB-free layers
// (airmass_volume, airmass_vdb_files), and the functions that build or sample OpenVDB grids —
// export_vdb, export_df3, run_vdb_trade — are reached through this table, from the module
// libairmass_vdb_module.so beside the executable (build/bin/, the add-on zip's bin/), opened
// on first use. Same compiler, same headers, same libstdc++: the C++ signatures pass as they are.
#pragma once

#include <filesystem>
#include <vector>

#include "airmass/vdb_export.hpp"
#include "airmass/vdb_trade.hpp"

namespace airmass::cli {

inline constexpr int kVdbModuleVersion = 1;  // bumped with any change of VdbModule or its types
inline constexpr const char* kVdbModuleFile = "libairmass_vdb_module.so";
inline constexpr const char* kVdbModuleEntry = "airmass_vdb_module_v1";

struct VdbModule {
    int version = kVdbModuleVersion;
    VdbStats (*export_vdb)(const Scene&, const VdbOptions&, const std::filesystem::path&, const VdbRunOptions&);
    std::vector<std::filesystem::path> (*export_df3)(const Scene&, const VdbOptions&, const std::filesystem::path&,
                                                     const VdbRunOptions&);
    VdbTradeResult (*run_vdb_trade)(const Scene&, const VdbTradeOptions&);
};

// The module, opened once (thread-safe). Throws std::runtime_error naming the file and the
// loader's reason when it is missing, cannot be loaded, or is of another version.
const VdbModule& vdb_module();

}  // namespace airmass::cli
