// Long work shows progress and can be cancelled.
//
//   * CancelFlag: a cooperative cancellation request, polled by worker loops (once per
//     image row, say) — workers finish what they hold and stop; the caller then throws
//     `Cancelled` before anything is written.
//   * InterruptGuard: for its lifetime, SIGINT/SIGTERM set a CancelFlag instead of
//     killing the process (a second Ctrl-C kills it the usual way, for a stuck job).
//     Signals are process-wide, so the guard is the one place holding a process-wide
//     pointer; guards nest (each restores what it replaced).
//   * ProgressBar: a one-line bar with rate and ETA on stderr, redrawn at most every
//     0.1 s, only when stderr is a terminal (logs and pipes stay clean). Thread-safe.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstddef>
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

}  // namespace airmass
