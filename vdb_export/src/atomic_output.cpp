// Temporary files + rename (see atomic_output.hpp).
#include "atomic_output.hpp"

#include <unistd.h>

#include <atomic>
#include <fstream>
#include <system_error>

#include "airmass/vdb_export.hpp"

namespace airmass::detail {

namespace fs = std::filesystem;

namespace {

// "<dir>/.<name>.airmass-tmp-<pid>-<n><ext>": hidden, unique within and across processes.
fs::path temporary_for(const fs::path& dest) {
    static std::atomic<unsigned> counter{0};
    const fs::path dir = dest.has_parent_path() ? dest.parent_path() : fs::path(".");
    return dir / ("." + dest.stem().string() + ".airmass-tmp-" + std::to_string(::getpid()) + "-" +
                  std::to_string(counter.fetch_add(1)) + dest.extension().string());
}

}  // namespace

void check_output_destination(const fs::path& dest) {
    if (dest.empty()) throw VdbError("output path is empty");
    const fs::path dir = dest.has_parent_path() ? dest.parent_path() : fs::path(".");
    std::error_code ec;
    if (!fs::is_directory(dir, ec))
        throw VdbError("cannot write '" + dest.string() + "': directory '" + dir.string() + "' does not exist");
    if (fs::is_directory(dest, ec)) throw VdbError("cannot write '" + dest.string() + "': it is a directory");
    const fs::path probe = temporary_for(dest);
    {
        std::ofstream f(probe, std::ios::binary);
        if (!f) throw VdbError("cannot write '" + dest.string() + "': directory '" + dir.string() + "' is not writable");
    }
    fs::remove(probe, ec);
}

AtomicOutputs::~AtomicOutputs() {
    if (committed_) return;
    std::error_code ec;
    for (const auto& [tmp, dest] : files_) fs::remove(tmp, ec);
}

fs::path AtomicOutputs::add(const fs::path& dest) {
    files_.emplace_back(temporary_for(dest), dest);
    return files_.back().first;
}

void AtomicOutputs::commit() {
    for (std::size_t i = 0; i < files_.size(); ++i) {
        std::error_code ec;
        fs::rename(files_[i].first, files_[i].second, ec);
        if (ec) {
            const std::string why = ec.message();
            for (std::size_t j = i; j < files_.size(); ++j) fs::remove(files_[j].first, ec);
            committed_ = true;
            throw VdbError("cannot move '" + files_[i].first.string() + "' to '" + files_[i].second.string() +
                           "': " + why);
        }
    }
    committed_ = true;
}

}  // namespace airmass::detail
