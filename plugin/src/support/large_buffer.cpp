#include "airmass/large_buffer.hpp"

#include <limits>
#include <new>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace airmass {

namespace {
constexpr std::size_t kHugePage = std::size_t(2) << 20;  // x86-64's transparent huge page
}

void* allocate_large(std::size_t bytes) {
    if (bytes < kHugePage) return ::operator new(bytes == 0 ? 1 : bytes);
    if (bytes > std::numeric_limits<std::size_t>::max() - kHugePage) throw std::bad_alloc();  // rounding would wrap
    // Whole huge pages, so the advice covers the array's last one too.
    const std::size_t size = (bytes + kHugePage - 1) / kHugePage * kHugePage;
    void* p = ::operator new(size, std::align_val_t(kHugePage));
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    // Advice only: a kernel built without THP answers EINVAL, one set to "never" ignores it;
    // either way the pages stay 4 KiB, which is what they would have been.
    (void)madvise(p, size, MADV_HUGEPAGE);
#endif
    return p;
}

void release_large(void* p, std::size_t bytes) noexcept {
    if (p == nullptr) return;
    if (bytes < kHugePage) ::operator delete(p);
    else ::operator delete(p, std::align_val_t(kHugePage));
}

}  // namespace airmass
