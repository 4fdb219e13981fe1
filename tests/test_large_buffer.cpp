// LargeBuffer and LargeAllocator (airmass/large_buffer.hpp): the precompute's work arrays on 2 MiB boundaries,
// advised for transparent huge pages on Linux.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>
#include <stdexcept>

#if defined(__linux__)
#include <sys/mman.h>
#include <unistd.h>
#endif

#include "airmass/image.hpp"
#include "airmass/large_buffer.hpp"

namespace {

constexpr std::size_t kHuge = std::size_t(2) << 20;

TEST(LargeBuffer, HoldsWhatIsWrittenAndMovesWithoutCopying) {
    for (const std::size_t n : {std::size_t(0), std::size_t(1), std::size_t(1000), kHuge / 4 - 1, kHuge / 4,
                                std::size_t(5) * kHuge / 4 + 3}) {
        airmass::LargeBuffer<float> a(n);
        ASSERT_EQ(a.size(), n);
        for (std::size_t i = 0; i < n; ++i) a[i] = float(i % 65521) + 0.5f;
        const float* p = a.data();
        airmass::LargeBuffer<float> b(std::move(a));
        EXPECT_EQ(b.data(), p);
        EXPECT_EQ(a.size(), 0u);
        EXPECT_EQ(a.data(), nullptr);
        airmass::LargeBuffer<float> c;
        c = std::move(b);
        EXPECT_EQ(c.data(), p);
        for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(c[i], float(i % 65521) + 0.5f) << "n " << n << " i " << i;
        if (n * sizeof(float) >= kHuge / 2) {
            EXPECT_EQ(reinterpret_cast<std::uintptr_t>(c.data()) % kHuge, 0u) << "n " << n;
        }
    }
}

// FloatImage's pixels (LargeAllocator): zero, like the std::vector they replaced, and aligned.
TEST(LargeBuffer, ImagePixelsStartAtZeroAndGrowLikeAVector) {
    airmass::FloatImage big(1024, 512, 3), small(4, 2, 3);
    for (const airmass::FloatImage* im : {&big, &small}) {
        ASSERT_EQ(im->pixels.size(), std::size_t(im->width) * im->height * 3);
        for (float v : im->pixels) ASSERT_EQ(v, 0.0f);
    }
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(big.pixels.data()) % kHuge, 0u);
    std::vector<float, airmass::LargeAllocator<float>> v;
    for (int i = 0; i < 1 << 20; ++i) v.push_back(float(i));  // through 4 MiB: reallocations
    for (int i = 0; i < 1 << 20; ++i) ASSERT_EQ(v[std::size_t(i)], float(i));
    airmass::FloatImage copy = big;
    copy.pixels[7] = 1.0f;
    EXPECT_EQ(big.pixels[7], 0.0f);
    EXPECT_THROW(v.reserve(v.max_size() + 1), std::length_error);
    // sizes whose byte count or rounding to whole huge pages would wrap are refused, not shrunk
    EXPECT_THROW(airmass::allocate_large(std::size_t(-1) - 100), std::bad_alloc);
    EXPECT_THROW(airmass::LargeBuffer<float>(std::size_t(-1) / 2), std::bad_alloc);
}

#if defined(__linux__)
// The mapping that holds a buffer of ≥ 1 MiB carries the huge-page advice (VmFlags "hg") whenever
// the kernel offers transparent huge pages at all.
TEST(LargeBuffer, IsAdvisedForHugePagesOnLinux) {
    std::ifstream mode("/sys/kernel/mm/transparent_hugepage/enabled");
    std::string modes;
    if (!std::getline(mode, modes) || modes.find("[never]") != std::string::npos)
        GTEST_SKIP() << "no transparent huge pages here (" << modes << ")";
    for (const std::size_t n : {std::size_t(3) * kHuge / 2, std::size_t(3) * kHuge / 8}) {  // 6 MiB; 1.5 MiB
        airmass::LargeBuffer<std::uint16_t> buf(n);
        const auto at = reinterpret_cast<std::uintptr_t>(buf.data());
        std::ifstream smaps("/proc/self/smaps");
        std::string line;
        bool inside = false, found = false;
        while (std::getline(smaps, line)) {
            std::uintptr_t lo = 0, hi = 0;
            char dash = 0;
            std::istringstream head(line);
            if (head >> std::hex >> lo >> dash >> hi && dash == '-' && line.find(':') > line.find(' ')) {
                inside = lo <= at && at < hi;
                continue;
            }
            if (inside && line.rfind("VmFlags:", 0) == 0) {
                found = true;
                EXPECT_NE((line + " ").find(" hg "), std::string::npos) << line;
            }
        }
        EXPECT_TRUE(found) << "no mapping holds " << std::hex << at << " (" << std::dec << n << " elements)";
    }
}

// A released buffer's mapping is gone with its advice: nothing advised is left on the heap for
// later allocations (of a host process) to land on. Checked before anything else is allocated.
TEST(LargeBuffer, ReleasedBuffersLeaveNoMappingBehind) {
    // A host process that has freed a large block of its own: glibc's malloc then serves blocks
    // up to that size from its heap (its mmap threshold rises), which stays mapped after free.
    std::free(std::malloc(std::size_t(30) << 20));
    for (const std::size_t bytes : {kHuge / 2, kHuge, std::size_t(5) * kHuge + 12345}) {
        void* p = airmass::allocate_large(bytes);
        const auto at = reinterpret_cast<std::uintptr_t>(p);
        ASSERT_EQ(at % kHuge, 0u);
        auto mapped = [](std::uintptr_t a, std::uintptr_t b) {  // any mapping meets [a, b)?
            std::ifstream maps("/proc/self/maps");
            std::string line;
            while (std::getline(maps, line)) {
                unsigned long long lo = 0, hi = 0;
                if (std::sscanf(line.c_str(), "%llx-%llx", &lo, &hi) == 2 && lo < b && a < hi) return true;
            }
            return false;
        };
        const std::uintptr_t end = at + (bytes + kHuge - 1) / kHuge * kHuge;
        ASSERT_TRUE(mapped(at, end));
        static_cast<unsigned char*>(p)[bytes - 1] = 1;  // the last byte is writable
        // The huge page mapped beyond the array for alignment has been given back: the page just
        // past its end is free (mmap's hint is taken only when nothing is mapped there) ...
        const std::size_t page = std::size_t(::sysconf(_SC_PAGESIZE));
        void* guard = ::mmap(reinterpret_cast<void*>(end), page, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        ASSERT_NE(guard, MAP_FAILED);
        EXPECT_EQ(reinterpret_cast<std::uintptr_t>(guard), end) << "the mapping goes on past the array, bytes " << bytes;
        static_cast<volatile unsigned char*>(guard)[0] = 7;
        airmass::release_large(p, bytes);
        EXPECT_FALSE(mapped(at, end)) << "bytes " << bytes;
        // ... and releasing the array unmaps the array only: a neighbour's page stays.
        const auto g = reinterpret_cast<std::uintptr_t>(guard);
        EXPECT_TRUE(mapped(g, g + page)) << "release unmapped past the array, bytes " << bytes;
        if (mapped(g, g + page)) {
            EXPECT_EQ(static_cast<volatile unsigned char*>(guard)[0], 7);
        }
        ::munmap(guard, page);
    }
}

#endif

// A size the system cannot map (an exbibyte: more than x86-64's address space) is std::bad_alloc,
// like operator new, never a null pointer.
TEST(LargeBuffer, AnUnmappableSizeThrows) {
    EXPECT_THROW(airmass::allocate_large(std::size_t(1) << 60), std::bad_alloc);
    EXPECT_THROW(airmass::LargeBuffer<float>(std::size_t(1) << 58), std::bad_alloc);
}

}  // namespace
