// vdb_export's side of airmass/atomic_file.hpp (the one atomic-write helper of every writer):
// the same calls, with their FileWriteError reported as VdbError.
#pragma once

#include <filesystem>
#include <utility>

#include "airmass/atomic_file.hpp"
#include "airmass/vdb_export.hpp"

namespace airmass::detail {

// Runs `f`, turning a FileWriteError into a VdbError with the same message.
template <class F>
decltype(auto) as_vdb_error(F&& f) {
    try {
        return std::forward<F>(f)();
    } catch (const FileWriteError& e) {
        throw VdbError(e.what());
    }
}

// check_output_destination (airmass/atomic_file.hpp), throwing VdbError.
inline void check_output_destination(const std::filesystem::path& dest) {
    as_vdb_error([&] { airmass::check_output_destination(dest); });
}

}  // namespace airmass::detail
