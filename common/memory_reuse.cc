// glibc's malloc options behind KeepFreedMemoryForReuse().
#include "common/memory_reuse.h"

#include <cstdlib>  // Defines __GLIBC__ where the C library is glibc.

#if defined(__GLIBC__)
#include <malloc.h>
#endif

// Sanitizers bring their own allocator (GCC says so with __SANITIZE_*,
// clang with __has_feature).
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define PF_OWN_ALLOCATOR 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || \
    __has_feature(memory_sanitizer)
#define PF_OWN_ALLOCATOR 1
#endif
#endif

namespace pf {

bool KeepFreedMemoryForReuse() {
#if defined(__GLIBC__) && !defined(PF_OWN_ALLOCATOR)
  // No block gets its own mapping; the heap's top is never trimmed; the
  // heap grows 256 MB beyond each request, so a large allocation is a few
  // system calls rather than one per block.
  return mallopt(M_MMAP_MAX, 0) == 1 && mallopt(M_TRIM_THRESHOLD, -1) == 1 &&
         mallopt(M_TOP_PAD, 256 << 20) == 1;
#else
  return false;
#endif
}

}  // namespace pf
