// The command line's progress and cancellation (the airmass_terminal library; not part of
// the core, which a host process such as Blender loads):
//   * InterruptGuard: for its lifetime, SIGINT/SIGTERM set a CancelFlag instead of
//     killing the process (a second Ctrl-C kills it the usual way, for a stuck job).
//     Signals are process-wide, so the guard is the one place holding a process-wide
//     pointer; guards nest (each restores what it replaced).
//   * ProgressBar: a one-line bar with rate and ETA on stderr, redrawn at most every
//     0.1 s, only when stderr is a terminal (logs and pipes stay clean). Thread-safe.
#pragma once

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <string>

#include "airmass/progress.hpp"

namespace airmass {

class InterruptGuard {
public:
    explicit InterruptGuard(CancelFlag& flag);
    ~InterruptGuard();
    InterruptGuard(const InterruptGuard&) = delete;
    InterruptGuard& operator=(const InterruptGuard&) = delete;

private:
    CancelFlag* previous_flag_;
    struct Saved;
    Saved* saved_;  // the sigactions this guard replaced
};

bool stderr_is_terminal();

class ProgressBar {
public:
    // `enabled` false makes every call a no-op (use stderr_is_terminal() && !quiet).
    ProgressBar(std::string label, std::size_t total, bool enabled);
    ~ProgressBar();  // finish()
    ProgressBar(const ProgressBar&) = delete;
    ProgressBar& operator=(const ProgressBar&) = delete;

    void advance(std::size_t n = 1);  // thread-safe; redraws if 0.1 s passed
    void set_total(std::size_t total);  // when the amount of work is known only later
    void finish();                    // draws the final state and ends the line (idempotent)

private:
    void draw(std::size_t done, bool final_line);

    std::string label_;
    std::atomic<std::size_t> total_;
    bool enabled_;
    std::atomic<std::size_t> done_{0};
    std::atomic<bool> finished_{false};
    std::chrono::steady_clock::time_point start_;
    std::atomic<std::int64_t> last_draw_ns_{0};
    std::mutex draw_mutex_;
};

// The library's progress/cancel hooks (progress.hpp) drawn on `bar` and cancelled by `cancel`.
inline RenderHooks progress_hooks(ProgressBar& bar, const CancelFlag& cancel) {
    RenderHooks hooks;
    hooks.cancel = &cancel;
    hooks.work_done = [&bar](std::size_t n, std::size_t total) {
        bar.set_total(total);
        bar.advance(n);
    };
    return hooks;
}

}  // namespace airmass
