// A set of output files written atomically: each goes to a hidden temporary beside its
// destination (same directory, so rename(2) is atomic), and all are renamed into place
// only by commit(). Destroying the set without commit() removes every temporary, so a
// failure or cancellation anywhere leaves no partial file.
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace airmass::detail {

// Throws VdbError unless `dest`'s directory exists and a file can be created there
// (checked by creating and removing a probe), before any expensive work.
void check_output_destination(const std::filesystem::path& dest);

class AtomicOutputs {
public:
    AtomicOutputs() = default;
    ~AtomicOutputs();
    AtomicOutputs(const AtomicOutputs&) = delete;
    AtomicOutputs& operator=(const AtomicOutputs&) = delete;

    // Registers `dest` and returns the temporary to write instead.
    std::filesystem::path add(const std::filesystem::path& dest);
    // Renames every temporary onto its destination (VdbError on failure; the
    // temporaries not yet renamed are removed).
    void commit();

private:
    std::vector<std::pair<std::filesystem::path, std::filesystem::path>> files_;  // (temporary, destination)
    bool committed_ = false;
};

}  // namespace airmass::detail
