// Keeps libairmass_c.so on the glibc 2.28 baseline of official Blender builds (Rocky Linux 8)
// while it is built on Debian 12 (glibc 2.36). Linked with -Wl,--wrap=SYMBOL for each symbol
// below (plugin/capi/CMakeLists.txt), so every reference to SYMBOL — ours and those inside the
// statically linked libstdc++.a / libgcc_eh.a — goes to __wrap_SYMBOL here, which calls the
// symbol's old version (bound with .symver) or, where glibc 2.28 has no such symbol, does its
// work with what 2.28 has. tests/portable/check_linux_library.sh checks the result
// (docs/portable.md). Linux only: macOS and Windows have no <features.h> (and no glibc).
#if defined(__linux__)
#ifndef _GNU_SOURCE
#define _GNU_SOURCE 1
#endif
#include <features.h>  // defines __GLIBC__

#if defined(__linux__) && defined(__GLIBC__)

#include <dlfcn.h>
#include <link.h>
#include <pthread.h>
#include <sys/random.h>
#include <sys/stat.h>

#include <cstdint>

// Old versions: calls to airmass_glibc_old_X are references to X@GLIBC_2.2.5 (x86-64's first).
#define AIRMASS_OLD_VERSION(name, alias) __asm__(".symver " #alias "," #name "@GLIBC_2.2.5")

extern "C" {

// ---- pthread (moved from libpthread into libc in 2.34; the 2.2.5 versions remain) -------
int airmass_glibc_old_pthread_create(pthread_t*, const pthread_attr_t*, void* (*)(void*), void*);
int airmass_glibc_old_pthread_join(pthread_t, void**);
int airmass_glibc_old_pthread_detach(pthread_t);
int airmass_glibc_old_pthread_once(pthread_once_t*, void (*)(void));
int airmass_glibc_old_pthread_key_create(pthread_key_t*, void (*)(void*));
AIRMASS_OLD_VERSION(pthread_create, airmass_glibc_old_pthread_create);
AIRMASS_OLD_VERSION(pthread_join, airmass_glibc_old_pthread_join);
AIRMASS_OLD_VERSION(pthread_detach, airmass_glibc_old_pthread_detach);
AIRMASS_OLD_VERSION(pthread_once, airmass_glibc_old_pthread_once);
AIRMASS_OLD_VERSION(pthread_key_create, airmass_glibc_old_pthread_key_create);

int __wrap_pthread_create(pthread_t* t, const pthread_attr_t* a, void* (*f)(void*), void* arg) {
    return airmass_glibc_old_pthread_create(t, a, f, arg);
}
int __wrap_pthread_join(pthread_t t, void** r) { return airmass_glibc_old_pthread_join(t, r); }
int __wrap_pthread_detach(pthread_t t) { return airmass_glibc_old_pthread_detach(t); }
int __wrap_pthread_once(pthread_once_t* o, void (*f)(void)) { return airmass_glibc_old_pthread_once(o, f); }
int __wrap_pthread_key_create(pthread_key_t* k, void (*d)(void*)) {
    return airmass_glibc_old_pthread_key_create(k, d);
}
int airmass_glibc_old___pthread_key_create(pthread_key_t*, void (*)(void*));
int airmass_glibc_old_pthread_key_delete(pthread_key_t);
int airmass_glibc_old_pthread_setspecific(pthread_key_t, const void*);
void* airmass_glibc_old_pthread_getspecific(pthread_key_t);
AIRMASS_OLD_VERSION(__pthread_key_create, airmass_glibc_old___pthread_key_create);
AIRMASS_OLD_VERSION(pthread_key_delete, airmass_glibc_old_pthread_key_delete);
AIRMASS_OLD_VERSION(pthread_setspecific, airmass_glibc_old_pthread_setspecific);
AIRMASS_OLD_VERSION(pthread_getspecific, airmass_glibc_old_pthread_getspecific);
// libstdc++ takes this one's address to ask "are threads linked in?" (a weak reference).
int __wrap___pthread_key_create(pthread_key_t* k, void (*d)(void*)) {
    return airmass_glibc_old___pthread_key_create(k, d);
}
int __wrap_pthread_key_delete(pthread_key_t k) { return airmass_glibc_old_pthread_key_delete(k); }
int __wrap_pthread_setspecific(pthread_key_t k, const void* v) { return airmass_glibc_old_pthread_setspecific(k, v); }
void* __wrap_pthread_getspecific(pthread_key_t k) { return airmass_glibc_old_pthread_getspecific(k); }

// ---- fstat64 (a function only since 2.33; before, <sys/stat.h> called __fxstat64) --------
int airmass_glibc_old___fxstat64(int, int, struct stat64*);
AIRMASS_OLD_VERSION(__fxstat64, airmass_glibc_old___fxstat64);
int __wrap_fstat64(int fd, struct stat64* buf) { return airmass_glibc_old___fxstat64(1 /* _STAT_VER_LINUX */, fd, buf); }

// ---- arc4random (2.36), referenced by libstdc++'s std::random_device, which the library
// never uses; answered with getentropy (2.25) all the same.
std::uint32_t __wrap_arc4random(void) {
    std::uint32_t v = 0;
    if (getentropy(&v, sizeof v) != 0) v = 0x9e3779b9u;
    return v;
}

// ---- math (new, errno-free versions in 2.29; the 2.2.5 ones give the same values) -------
double airmass_glibc_old_exp(double);
double airmass_glibc_old_log(double);
double airmass_glibc_old_pow(double, double);
double airmass_glibc_old_exp2(double);
double airmass_glibc_old_log2(double);
double airmass_glibc_old_hypot(double, double);
AIRMASS_OLD_VERSION(hypot, airmass_glibc_old_hypot);
AIRMASS_OLD_VERSION(exp, airmass_glibc_old_exp);
AIRMASS_OLD_VERSION(log, airmass_glibc_old_log);
AIRMASS_OLD_VERSION(pow, airmass_glibc_old_pow);
AIRMASS_OLD_VERSION(exp2, airmass_glibc_old_exp2);
AIRMASS_OLD_VERSION(log2, airmass_glibc_old_log2);

double __wrap_exp(double x) { return airmass_glibc_old_exp(x); }
double __wrap_log(double x) { return airmass_glibc_old_log(x); }
double __wrap_pow(double x, double y) { return airmass_glibc_old_pow(x, y); }
double __wrap_exp2(double x) { return airmass_glibc_old_exp2(x); }
double __wrap_log2(double x) { return airmass_glibc_old_log2(x); }
double __wrap_hypot(double x, double y) { return airmass_glibc_old_hypot(x, y); }  // 2.35

// ---- __libc_single_threaded (2.32): libstdc++ skips atomic reference counting when it is
// nonzero. Zero (always use atomics) is correct in every process, single-threaded or not.
char __wrap___libc_single_threaded = 0;

// ---- _dl_find_object (2.35): the static unwinder's way to find a PC's .eh_frame_hdr. Glibc
// 2.28 has dl_iterate_phdr, which answers the same question: the loaded object whose PT_LOAD
// segment holds the PC, and its PT_GNU_EH_FRAME segment.
struct airmass_dl_find_object {  // glibc 2.35's struct dl_find_object (x86-64 layout)
    unsigned long long dlfo_flags;
    void* dlfo_map_start;
    void* dlfo_map_end;
    struct link_map* dlfo_link_map;
    void* dlfo_eh_frame;
    unsigned long long dlfo_reserved[7];
};

namespace {
struct FindQuery {
    std::uintptr_t pc;
    airmass_dl_find_object* out;
    bool found;
};

int find_object_callback(struct dl_phdr_info* info, size_t, void* data) {
    auto* q = static_cast<FindQuery*>(data);
    bool contains = false;
    std::uintptr_t lo = UINTPTR_MAX, hi = 0;
    const ElfW(Phdr)* eh = nullptr;
    for (ElfW(Half) i = 0; i < info->dlpi_phnum; ++i) {
        const ElfW(Phdr)& ph = info->dlpi_phdr[i];
        if (ph.p_type == PT_LOAD) {
            const std::uintptr_t start = info->dlpi_addr + ph.p_vaddr;
            const std::uintptr_t end = start + ph.p_memsz;
            if (start < lo) lo = start;
            if (end > hi) hi = end;
            if (q->pc >= start && q->pc < end) contains = true;
        } else if (ph.p_type == PT_GNU_EH_FRAME) {
            eh = &ph;
        }
    }
    if (!contains) return 0;
    q->found = true;
    q->out->dlfo_flags = 0;
    q->out->dlfo_map_start = reinterpret_cast<void*>(lo);
    q->out->dlfo_map_end = reinterpret_cast<void*>(hi);
    q->out->dlfo_link_map = nullptr;
    q->out->dlfo_eh_frame = eh ? reinterpret_cast<void*>(info->dlpi_addr + eh->p_vaddr) : nullptr;
    return 1;
}
}  // namespace

int __wrap__dl_find_object(void* pc, airmass_dl_find_object* result) {
    FindQuery q{reinterpret_cast<std::uintptr_t>(pc), result, false};
    dl_iterate_phdr(find_object_callback, &q);
    return q.found ? 0 : -1;
}

}  // extern "C"

#endif  // __GLIBC__
#endif  // __linux__
