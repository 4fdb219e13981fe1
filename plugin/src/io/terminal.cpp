// Progress bar on stderr and cooperative cancellation by SIGINT/SIGTERM (airmass/terminal.hpp).
#include "airmass/terminal.hpp"

#include <signal.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>

namespace airmass {

namespace {

// The flag the active InterruptGuard forwards signals to. A signal handler can reach
// nothing else; std::atomic<pointer> is lock-free, so reading it there is safe.
std::atomic<CancelFlag*> g_interrupt_target{nullptr};
static_assert(std::atomic<CancelFlag*>::is_always_lock_free);

extern "C" void on_interrupt(int sig) {
    CancelFlag* flag = g_interrupt_target.load();
    if (flag == nullptr || flag->requested()) {
        // Second request (or no guard): fall back to the default action, i.e. terminate.
        ::signal(sig, SIG_DFL);
        ::raise(sig);
        return;
    }
    flag->request();
    static const char msg[] = "\nairmass: interrupted - stopping; no output will be written (again to abort)\n";
    const ssize_t ignored = ::write(STDERR_FILENO, msg, sizeof msg - 1);
    (void)ignored;
}

}  // namespace

struct InterruptGuard::Saved {
    struct sigaction int_action, term_action;
};

InterruptGuard::InterruptGuard(CancelFlag& flag) : previous_flag_(g_interrupt_target.exchange(&flag)), saved_(new Saved) {
    struct sigaction sa;
    std::memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_interrupt;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESTART;
    ::sigaction(SIGINT, &sa, &saved_->int_action);
    ::sigaction(SIGTERM, &sa, &saved_->term_action);
}

InterruptGuard::~InterruptGuard() {
    ::sigaction(SIGINT, &saved_->int_action, nullptr);
    ::sigaction(SIGTERM, &saved_->term_action, nullptr);
    g_interrupt_target.store(previous_flag_);
    delete saved_;
}

bool stderr_is_terminal() { return ::isatty(STDERR_FILENO) == 1; }

ProgressBar::ProgressBar(std::string label, std::size_t total, bool enabled)
    : label_(std::move(label)), total_(total), enabled_(enabled), start_(std::chrono::steady_clock::now()) {}

void ProgressBar::set_total(std::size_t total) { total_.store(total); }

ProgressBar::~ProgressBar() { finish(); }

void ProgressBar::advance(std::size_t n) {
    if (!enabled_) return;
    const std::size_t done = done_.fetch_add(n, std::memory_order_relaxed) + n;
    const std::int64_t now_ns =
        std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - start_).count();
    std::int64_t last = last_draw_ns_.load(std::memory_order_relaxed);
    // One thread wins the right to redraw per 0.1 s; the others return immediately.
    if (now_ns - last < 100'000'000 || !last_draw_ns_.compare_exchange_strong(last, now_ns)) return;
    std::unique_lock lock(draw_mutex_, std::try_to_lock);
    if (lock && !finished_.load()) draw(done, false);
}

void ProgressBar::finish() {
    if (!enabled_ || finished_.exchange(true)) return;
    std::lock_guard lock(draw_mutex_);
    draw(done_.load(), true);
}

void ProgressBar::draw(std::size_t done, bool final_line) {
    const std::size_t total = total_.load();
    if (total == 0) return;
    if (done > total) done = total;
    const double frac = double(done) / double(total);
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    constexpr int kWidth = 30;
    const int filled = static_cast<int>(frac * kWidth + 0.5);
    char bar[kWidth + 1];
    for (int i = 0; i < kWidth; ++i) bar[i] = i < filled ? '#' : '-';
    bar[kWidth] = '\0';
    char eta[32] = "";
    if (!final_line && done > 0) std::snprintf(eta, sizeof eta, " ETA %.1fs", elapsed * (1.0 - frac) / frac);
    // \r + clear-to-end-of-line keeps a single line on the terminal.
    std::fprintf(stderr, "\r\033[K%s [%s] %3.0f%% %.1fs%s%s", label_.c_str(), bar, 100.0 * frac, elapsed, eta,
                 final_line ? "\n" : "");
    std::fflush(stderr);
}

}  // namespace airmass
