// Output files written atomically — the one helper behind every file the command line
// writes (EXR through image_io.hpp; .vdb, .df3, JSON, POV-Ray and CSV text through
// vdb_export.hpp; `airmass compare`'s files). The airmass_files library: not part of the
// core (a host such as Blender writes its own files).
//
// Each output goes to a hidden temporary beside its destination,
//     <dir>/.<stem>.airmass-tmp-<pid>-<n><ext>
// (same directory, so rename(2) is atomic; same extension, so a writer that picks its format
// from the name still does). commit() checks the cancel flag, flushes every temporary to
// disk (fsync) and only then renames each over its destination. So a reader of a
// destination sees the previous file (or none), or the complete new one — never a part:
//   * any error (folder not writable, disk full, a file-size limit, a writer's own error)
//     or a cancel requested before commit(): every temporary is removed, nothing replaced;
//   * the process killed (SIGKILL) before commit(): its temporary stays behind. It is
//     hidden and says what it is, and the next AtomicOutputs writing the same destination
//     removes it once process <pid> no longer exists (remove_stale_temporaries).
// A set of several files is replaced together; only a rename failing part-way through
// commit() (the folder removed meanwhile, say) can leave the first ones new and the rest old.
#pragma once

#include <cstddef>
#include <filesystem>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "airmass/progress.hpp"

namespace airmass {

// Every problem writing an output; the message names the destination and the cause.
struct FileWriteError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// Throws FileWriteError unless `dest` is a non-empty path that is not a directory, in an
// existing folder where a file can be created (tried: a temporary is created and removed,
// which also holds for root in a read-only mount). For use before any expensive work.
void check_output_destination(const std::filesystem::path& dest);

// The temporaries of `dest` present in its folder, of any process (tests, cleanup).
std::vector<std::filesystem::path> temporaries_of(const std::filesystem::path& dest);

// Removes the temporaries of `dest` left by processes that no longer exist (a kill -9);
// returns how many. Those of live processes (this one included) are left alone.
std::size_t remove_stale_temporaries(const std::filesystem::path& dest);

class AtomicOutputs {
public:
    // Whether commit() flushes the temporaries (and then the folder) to disk before and after
    // the renames. `none` keeps the atomicity for readers of a running system (a reader sees
    // the previous file or the whole new one) but not across a power loss or a system crash,
    // after which a renamed file may be empty or partly written: only for files whose reader
    // checks them and can do without them — the table cache (table_cache.hpp), whose entries
    // carry their length and checksum and are rebuilt when they fail. An fsync of a 10 MB
    // entry is ≈ 10 ms of a cold sky's wall time.
    enum class Sync { to_disk, none };

    // `cancel` (may be null) is checked by write() and commit(): a requested cancel removes
    // every temporary and throws Cancelled before any destination is replaced.
    explicit AtomicOutputs(const CancelFlag* cancel = nullptr, Sync sync = Sync::to_disk)
        : cancel_(cancel), sync_(sync) {}
    ~AtomicOutputs();  // without commit(): removes every temporary
    AtomicOutputs(const AtomicOutputs&) = delete;
    AtomicOutputs& operator=(const AtomicOutputs&) = delete;

    // Registers `dest` (removing its stale temporaries) and returns the temporary to write.
    std::filesystem::path add(const std::filesystem::path& dest);
    // add(dest) and writes `bytes` to the temporary (FileWriteError if that fails).
    void write(const std::filesystem::path& dest, std::string_view bytes);
    // The same for content given as pieces, written one after the other.
    void write(const std::filesystem::path& dest, std::span<const std::span<const std::byte>> pieces);
    // fsyncs every temporary (Sync::to_disk), then renames each onto its destination. FileWriteError or
    // Cancelled on failure (the temporaries not yet renamed are removed).
    void commit();

private:
    void check_cancel();
    void discard() noexcept;
    const CancelFlag* cancel_;
    Sync sync_;
    std::vector<std::pair<std::filesystem::path, std::filesystem::path>> files_;  // (temporary, destination)
    bool done_ = false;
};

// A folder of outputs published whole (`airmass compare -o DIR`). The outputs are written
// into a staging folder beside DIR (same parent, so the same filesystem),
//     <parent>/.<name>.airmass-stage-<pid>
// and publish_folder swaps it in by one rename: Linux's renameat2(RENAME_EXCHANGE) when DIR
// exists (DIR becomes the new set in one step, the staging name the old set, then removed),
// rename(2) when it does not. Where the exchange is not supported, DIR is first renamed to
// <parent>/.<name>.airmass-old-<pid> and the staging folder then renamed to DIR: between the
// two, DIR does not exist (the previous set or nothing). A process killed mid-run leaves its
// staging (or old) folder; remove_stale_staging, run by the next publisher of DIR, removes
// those of processes that no longer exist — putting an old folder back as DIR if DIR is missing.
std::filesystem::path staging_folder_for(const std::filesystem::path& dest);
std::size_t remove_stale_staging(const std::filesystem::path& dest);
// Swaps `staging` in as `dest` (see above) and removes the previous set. FileWriteError if the
// swap fails (nothing changed then). Returns the folder still holding the previous set when it
// could not be removed (empty: removed). `exchange` false: the fallback (tests).
std::filesystem::path publish_folder(const std::filesystem::path& staging, const std::filesystem::path& dest,
                                     bool exchange = true);

// One file: check_output_destination, then write + commit through an AtomicOutputs.
void write_file_atomic(const std::filesystem::path& path, std::string_view bytes, const CancelFlag* cancel = nullptr);

}  // namespace airmass
