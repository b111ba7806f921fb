// Heap-allocation counter for the no-malloc checks of the neural core: include in exactly ONE
// source file of an executable (it defines malloc/calloc/realloc in normal builds). Counts every
// allocation of the process, also those of Eigen, libgomp and OpenBLAS, while a CountAllocations
// object is alive. Normal builds: a forwarding malloc/calloc/realloc over glibc's; ASan builds:
// the sanitizer allocator's hooks (ASan owns malloc there).
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdlib>
#include <malloc.h>  // memalign: declared before the definitions below

// GCC says ASan with __SANITIZE_ADDRESS__, clang through __has_feature.
#if defined(__SANITIZE_ADDRESS__)
#define PCP_ALLOC_COUNTER_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define PCP_ALLOC_COUNTER_ASAN 1
#endif
#endif

#if defined(PCP_ALLOC_COUNTER_ASAN)
// From the sanitizer runtime's public interface (declared here: Debian's GCC does not ship
// <sanitizer/allocator_interface.h>).
extern "C" int __sanitizer_install_malloc_and_free_hooks(
    void (*malloc_hook)(const volatile void*, std::size_t), void (*free_hook)(const volatile void*));
#endif

namespace alloc_counter {
inline std::atomic<long> g_allocations{0};
inline std::atomic<bool> g_counting{false};
inline void note_allocation() {
    if (g_counting.load(std::memory_order_relaxed)) g_allocations.fetch_add(1, std::memory_order_relaxed);
}
}  // namespace alloc_counter

#if defined(PCP_ALLOC_COUNTER_ASAN)
namespace alloc_counter {
inline void count_malloc_hook(const volatile void*, std::size_t) { note_allocation(); }
inline void ignore_free_hook(const volatile void*) {}
struct InstallHooks {
    InstallHooks() { __sanitizer_install_malloc_and_free_hooks(count_malloc_hook, ignore_free_hook); }
};
inline InstallHooks install_hooks;
}  // namespace alloc_counter
#else
// glibc: every allocation (operator new, Eigen's aligned_malloc, std::aligned_alloc) goes through
// malloc, calloc, realloc, aligned_alloc or memalign (posix_memalign is left alone: <mm_malloc.h>
// redeclares it with another exception specification); these forward to glibc's
// implementations and count while counting is on.
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);
void* malloc(std::size_t n) {
    alloc_counter::note_allocation();
    return __libc_malloc(n);
}
void* calloc(std::size_t n, std::size_t m) {
    alloc_counter::note_allocation();
    return __libc_calloc(n, m);
}
void* realloc(void* p, std::size_t n) {
    alloc_counter::note_allocation();
    return __libc_realloc(p, n);
}
void* aligned_alloc(std::size_t alignment, std::size_t n) {
    alloc_counter::note_allocation();
    return __libc_memalign(alignment, n);
}
void* memalign(std::size_t alignment, std::size_t n) {
    alloc_counter::note_allocation();
    return __libc_memalign(alignment, n);
}
}
#endif

namespace alloc_counter {
/// Counts the allocations made while it is alive.
struct CountAllocations {
    CountAllocations() {
        g_allocations = 0;
        g_counting = true;
    }
    ~CountAllocations() { g_counting = false; }
    CountAllocations(const CountAllocations&) = delete;
    CountAllocations& operator=(const CountAllocations&) = delete;
    long count() const { return g_allocations.load(); }
};
}  // namespace alloc_counter
