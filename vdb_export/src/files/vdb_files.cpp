// The OpenVDB-free part of the volume export's file handling: the file names of a tiled
// export and atomic text outputs (airmass/vdb_export.hpp). Library airmass_vdb_files, which the
// `airmass` CLI links directly; what needs OpenVDB is loaded only when a command writes grids
// (plugin/cli/vdb_module.hpp).
#include <filesystem>
#include <string_view>
#include <vector>

#include "airmass/vdb_export.hpp"
#include "atomic_output.hpp"

namespace airmass {

namespace fs = std::filesystem;

std::vector<fs::path> vdb_output_paths(const fs::path& path, std::size_t tiles) {
    if (tiles <= 1) return {path};
    std::vector<fs::path> out;
    const fs::path dir = path.parent_path();
    for (const auto& name : volume_file_names(path.stem().string(), tiles)) out.push_back(dir / name);
    return out;
}

void write_text_atomic(const fs::path& path, std::string_view text, const CancelFlag* cancel) {
    detail::as_vdb_error([&] { write_file_atomic(path, text, cancel); });
}

}  // namespace airmass
