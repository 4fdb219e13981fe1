// The library's one parallel loop, over the standard library's threads.
//
// The core links no TBB (the library a host such as Blender loads must not bring a second
// TBB into a process that has its own), so work is split here: `threads` workers (0: all
// hardware threads) take consecutive chunks of `grain` items of [begin, end) from one atomic
// counter. body(chunk_begin, chunk_end, worker) runs with worker in [0, workers), so per-
// worker scratch is a plain vector indexed by worker (parallel_workers tells its size).
// The calling thread is worker 0. The first exception a body throws stops the other
// workers from taking new chunks and is rethrown on the calling thread once all have ended.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace airmass {

// Hardware threads (≥ 1).
inline int hardware_threads() {
    const unsigned n = std::thread::hardware_concurrency();
    return n == 0 ? 1 : static_cast<int>(n);
}

// Workers parallel_for uses for `items` items in chunks of `grain` with `threads` requested.
inline int parallel_workers(std::size_t items, std::size_t grain, int threads) {
    const int want = threads > 0 ? threads : hardware_threads();
    const std::size_t g = std::max<std::size_t>(1, grain);
    const std::size_t chunks = (items + g - 1) / g;
    return static_cast<int>(std::max<std::size_t>(1, std::min<std::size_t>(chunks, std::size_t(want))));
}

template <class Body>
void parallel_for(std::size_t begin, std::size_t end, std::size_t grain, int threads, Body&& body) {
    if (end <= begin) return;
    const std::size_t g = std::max<std::size_t>(1, grain);
    const int workers = parallel_workers(end - begin, g, threads);
    if (workers == 1) {
        for (std::size_t b = begin; b < end; b += g) body(b, std::min(end, b + g), 0);
        return;
    }
    std::atomic<std::size_t> next{begin};
    std::atomic<bool> failed{false};
    std::exception_ptr error;
    std::mutex error_mutex;
    auto run = [&](int worker) {
        try {
            while (!failed.load(std::memory_order_relaxed)) {
                const std::size_t b = next.fetch_add(g, std::memory_order_relaxed);
                if (b >= end) break;
                body(b, std::min(end, b + g), worker);
            }
        } catch (...) {
            std::lock_guard<std::mutex> lock(error_mutex);
            if (!error) error = std::current_exception();
            failed.store(true, std::memory_order_relaxed);
        }
    };
    std::vector<std::thread> pool;
    pool.reserve(std::size_t(workers - 1));
    try {
        for (int w = 1; w < workers; ++w) pool.emplace_back(run, w);
    } catch (...) {
        failed.store(true);  // could not start a thread: finish with the ones we have
        for (auto& t : pool) t.join();
        throw;
    }
    run(0);
    for (auto& t : pool) t.join();
    if (error) std::rethrow_exception(error);
}

// body(i) for every i in [0, n), one item per chunk (for items of real work each).
template <class Body>
void parallel_for_each(std::size_t n, int threads, Body&& body) {
    parallel_for(0, n, 1, threads, [&](std::size_t b, std::size_t e, int) {
        for (std::size_t i = b; i < e; ++i) body(i);
    });
}

}  // namespace airmass
