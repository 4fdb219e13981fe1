// Storage for the multiple-scattering precompute's large work arrays (megabytes to tens of
// megabytes, written by the parallel stages before they are read).
//
// Two costs of a fresh std::vector<float> of that size are avoided:
//  * zeroing: std::vector writes every element on the calling thread, and the stages then
//    overwrite them all (LargeBuffer leaves them uninitialised);
//  * first-touch page faults: one per 4 KiB page, each costly on a virtual machine. An array of
//    at least 2 MiB is placed on 2 MiB boundaries and, on Linux, advised as a candidate for
//    transparent huge pages (madvise MADV_HUGEPAGE, honoured when the system's THP mode is
//    "madvise" or "always"; ignored where it is "never"), so its pages fault 512 at a time.
//    Elsewhere the advice is a no-op and only the alignment remains.
// docs/multiple_scattering.md (Cost) has the measurement.
#pragma once

#include <cstddef>
#include <memory>
#include <span>

namespace airmass {

// `bytes` of uninitialised storage (aligned to 2 MiB and advised for huge pages from 2 MiB on);
// release with release_large(p, bytes). Throws std::bad_alloc like operator new.
void* allocate_large(std::size_t bytes);
void release_large(void* p, std::size_t bytes) noexcept;

// An uninitialised array of trivially constructible T on allocate_large's storage.
template <class T>
class LargeBuffer {
public:
    LargeBuffer() = default;
    explicit LargeBuffer(std::size_t n) : p_(static_cast<T*>(allocate_large(n * sizeof(T)))), n_(n) {}
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
    T* p_ = nullptr;
    std::size_t n_ = 0;
};

}  // namespace airmass
