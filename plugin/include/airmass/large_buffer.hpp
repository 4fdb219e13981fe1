// Storage for large arrays: the multiple-scattering precompute's work arrays and the images'
// pixels (megabytes to tens of megabytes, written in parallel before they are read).
//
// Two costs of a fresh std::vector<float> of that size are avoided:
//  * zeroing: std::vector writes every element on the calling thread, and the stages then
//    overwrite them all (LargeBuffer leaves them uninitialised; LargeAllocator, for a
//    std::vector that must start at zero, does not);
//  * first-touch page faults: one per 4 KiB page, each costly on a virtual machine. An array of
//    at least 1 MiB gets whole 2 MiB pages of its own (on 2 MiB boundaries; a 1.5 MiB image
//    costs one huge page, not 384 small ones) and, on Linux, is advised as a candidate for
//    transparent huge pages (madvise MADV_HUGEPAGE, honoured when the system's THP mode is
//    "madvise" or "always"; ignored where it is "never"), so its pages fault 512 at a time.
//    On Linux that array is a mapping of its own (mmap, released with munmap), so the advice
//    and the pages end with it: nothing advised is left on the heap of a host process
//    (Blender) for malloc to hand out again. Elsewhere it comes from aligned operator new,
//    without advice.
// docs/multiple_scattering.md (Cost) and docs/sky.md have the measurements.
#pragma once

#include <cstddef>
#include <limits>
#include <memory>
#include <new>
#include <span>
#include <type_traits>

namespace airmass {

// `bytes` of uninitialised storage (aligned to 2 MiB and advised for huge pages from 1 MiB on);
// release with release_large(p, bytes). Throws std::bad_alloc like operator new.
void* allocate_large(std::size_t bytes);
void release_large(void* p, std::size_t bytes) noexcept;

// An uninitialised array of trivially constructible T on allocate_large's storage.
template <class T>
class LargeBuffer {
public:
    LargeBuffer() = default;
    static_assert(std::is_trivially_destructible_v<T> && alignof(T) <= __STDCPP_DEFAULT_NEW_ALIGNMENT__);
    explicit LargeBuffer(std::size_t n) : p_(static_cast<T*>(allocate_large(bytes_of(n)))), n_(n) {}
    LargeBuffer(LargeBuffer&& o) noexcept : p_(o.p_), n_(o.n_) { o.p_ = nullptr, o.n_ = 0; }
    LargeBuffer& operator=(LargeBuffer&& o) noexcept {
        if (this != &o) {
            release_large(p_, n_ * sizeof(T));
            p_ = o.p_, n_ = o.n_;
            o.p_ = nullptr, o.n_ = 0;
        }
        return *this;
    }
    LargeBuffer(const LargeBuffer&) = delete;
    LargeBuffer& operator=(const LargeBuffer&) = delete;
    ~LargeBuffer() { release_large(p_, n_ * sizeof(T)); }

    T* data() { return p_; }
    const T* data() const { return p_; }
    std::size_t size() const { return n_; }
    T& operator[](std::size_t i) { return p_[i]; }
    const T& operator[](std::size_t i) const { return p_[i]; }
    operator std::span<T>() { return {p_, n_}; }
    operator std::span<const T>() const { return {p_, n_}; }

private:
    static std::size_t bytes_of(std::size_t n) {
        if (n > std::numeric_limits<std::size_t>::max() / sizeof(T)) throw std::bad_array_new_length();
        return n * sizeof(T);
    }
    T* p_ = nullptr;
    std::size_t n_ = 0;
};

// The same storage for a std::vector (FloatImage's pixels).
template <class T>
struct LargeAllocator {
    static_assert(alignof(T) <= __STDCPP_DEFAULT_NEW_ALIGNMENT__);
    using value_type = T;
    LargeAllocator() = default;
    template <class U>
    LargeAllocator(const LargeAllocator<U>&) noexcept {}
    T* allocate(std::size_t n) {
        if (n > std::numeric_limits<std::size_t>::max() / sizeof(T)) throw std::bad_array_new_length();
        return static_cast<T*>(allocate_large(n * sizeof(T)));
    }
    void deallocate(T* p, std::size_t n) noexcept { release_large(p, n * sizeof(T)); }
    template <class U>
    friend bool operator==(const LargeAllocator&, const LargeAllocator<U>&) noexcept {
        return true;
    }
};

}  // namespace airmass
