#include "airmass/large_buffer.hpp"

#include <cassert>
#include <cstdint>
#include <limits>
#include <new>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace airmass {

namespace {
constexpr std::size_t kHugePage = std::size_t(2) << 20;  // x86-64's transparent huge page
// From this size on an array gets whole huge pages of its own (at most half of the last one unused).
constexpr std::size_t kLarge = kHugePage / 2;

// Whole huge pages, so the advice covers the array's last one too; a size whose rounding (or,
// on Linux, the extra huge page mapped for alignment) would wrap is refused.
std::size_t rounded_size(std::size_t bytes) {
    if (bytes > std::numeric_limits<std::size_t>::max() - 2 * kHugePage) throw std::bad_alloc();
    return (bytes + kHugePage - 1) / kHugePage * kHugePage;
}
}  // namespace

void* allocate_large(std::size_t bytes) {
    if (bytes < kLarge) return ::operator new(bytes == 0 ? 1 : bytes);
    const std::size_t size = rounded_size(bytes);
#if defined(__linux__)
    // A mapping of our own, not malloc's memory: the huge-page advice then ends with the
    // buffer (munmap in release_large) instead of staying on a range of the host's heap that
    // malloc hands out again, and the pages go back to the system when the buffer is freed.
    // One huge page more than needed is mapped and the ends trimmed, so the array starts on a
    // 2 MiB boundary.
    const std::size_t span = size + kHugePage;
    void* raw = ::mmap(nullptr, span, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (raw == MAP_FAILED) throw std::bad_alloc();
    const auto base = reinterpret_cast<std::uintptr_t>(raw);
    const auto start = (base + kHugePage - 1) & ~std::uintptr_t(kHugePage - 1);
    const std::size_t head = start - base, tail = span - head - size;
    // munmap of whole pages inside a mapping of our own cannot fail (it can only be given bad
    // arguments); the checks are for debug builds.
    [[maybe_unused]] int rc = 0;
    if (head > 0) rc |= ::munmap(raw, head);
    if (tail > 0) rc |= ::munmap(reinterpret_cast<void*>(start + size), tail);
    assert(rc == 0);
    void* p = reinterpret_cast<void*>(start);
#if defined(MADV_HUGEPAGE)
    // Advice only: a kernel built without THP answers EINVAL, one set to "never" ignores it;
    // either way the pages stay 4 KiB, which is what they would have been.
    (void)::madvise(p, size, MADV_HUGEPAGE);
#endif
    return p;
#else
    return ::operator new(size, std::align_val_t(kHugePage));
#endif
}

void release_large(void* p, std::size_t bytes) noexcept {
    if (p == nullptr) return;
    if (bytes < kLarge) {
        ::operator delete(p);
        return;
    }
#if defined(__linux__)
    [[maybe_unused]] const int rc = ::munmap(p, (bytes + kHugePage - 1) / kHugePage * kHugePage);
    assert(rc == 0);
#else
    ::operator delete(p, std::align_val_t(kHugePage));
#endif
}

}  // namespace airmass
