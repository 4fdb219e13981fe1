// Long work shows progress and can be cancelled.
//
//   * CancelFlag: a cooperative cancellation request, polled by worker loops (once per
//     image row, say) — workers finish what they hold and stop; the caller then throws
//     `Cancelled` before anything is written.
//
// The command line's side of it (a progress bar, Ctrl-C as a cancel request) is in
// airmass/terminal.hpp, outside the core: the library a host loads holds no process-wide
// state and installs no signal handler.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstddef>
#include <functional>
#include <mutex>
#include <stdexcept>
#include <string>

namespace airmass {

// Thrown when work stops because cancellation was requested.
struct Cancelled : std::runtime_error {
    using std::runtime_error::runtime_error;
};

class CancelFlag {
public:
    bool requested() const noexcept { return flag_.load(std::memory_order_relaxed); }
    void request() noexcept { flag_.store(true, std::memory_order_relaxed); }
    void reset() noexcept { flag_.store(false, std::memory_order_relaxed); }

private:
    static_assert(std::atomic<bool>::is_always_lock_free, "set from a signal handler");
    std::atomic<bool> flag_{false};
};

// The one progress/cancel type of the library's long calls (sky, render, tables, volume):
// `work_done(units, total)` is called (from worker threads) as pieces of work finish — grid
// rows, image rows, table stages; `total` is the same on every call — and `cancel` is polled
// once per piece: a requested cancel makes the call throw Cancelled after its workers stop,
// before anything is returned or written.
struct RenderHooks {
    const CancelFlag* cancel = nullptr;
    std::function<void(std::size_t units, std::size_t total)> work_done;
};

}  // namespace airmass
