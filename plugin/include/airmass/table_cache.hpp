// The command line's cache of multiple-scattering tables on disk (the TableStore of
// table_store.hpp for the CLI; the add-on keeps its tables in memory instead).
//
// Where: $AIRMASS_CACHE_DIR if set, else $XDG_CACHE_HOME/airmass, else ~/.cache/airmass
// (%LOCALAPPDATA%\airmass\cache on Windows). One file per key, `ms-<FNV-1a of the key>.amt`,
// written to a temporary beside it and renamed into place (a reader never sees half a file;
// two processes writing the same entry leave one whole file) — not flushed to disk first: an
// entry a power loss left empty or partial fails its checks like any corrupt one. An entry is
// checked whole when it is read and its G table is then used in place, from the mapped file
// (MultipleScattering::phase_radiance keeps the mapping): the cache itself replaces entries
// only by rename and removes them only by unlink, which leave a mapping intact; a file
// truncated or rewritten in place by something else while a run is using it is not guarded
// against (its pages change under the run, or vanish: SIGBUS). A read touches the file's
// time; after a write the oldest entries are removed until the folder holds at most
// `max_bytes` (AIRMASS_CACHE_MAX_MB, default 1024). An entry that fails its checks
// (table_store.hpp: another key, truncated, corrupt) is removed and the tables are
// computed afresh. Nothing here throws: a cache that cannot be read or written is no cache.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

#include "airmass/table_store.hpp"

namespace airmass {

// The folder the CLI's cache uses (see above); empty when no folder can be named.
std::filesystem::path default_table_cache_dir();
// AIRMASS_CACHE_MAX_MB in bytes, or the default 1 GiB.
std::uintmax_t default_table_cache_max_bytes();

class DiskTableStore final : public TableStore {
public:
    DiskTableStore(std::filesystem::path dir, std::uintmax_t max_bytes);

    std::shared_ptr<const MultipleScattering> load(std::string_view key) override;
    void store(std::string_view key, const MultipleScattering& tables) override;

    const std::filesystem::path& dir() const { return dir_; }
    std::filesystem::path entry_path(std::string_view key) const;
    // What happened at the last load: hit, miss (no entry) or rejected (an entry failed its checks).
    enum class Outcome { none, hit, miss, rejected };
    Outcome last_load() const { return last_load_; }
    // The last problem met (a folder that cannot be made, a write that failed), or empty.
    const std::string& last_problem() const { return problem_; }

private:
    void evict();
    std::filesystem::path dir_;
    std::uintmax_t max_bytes_;
    Outcome last_load_ = Outcome::none;
    std::string problem_;
};

}  // namespace airmass
