// How the process's allocator treats memory it frees.
//
// A reconstruction allocates and frees gigabytes: each context view's
// compositing weights grow to tens of MB, the colour fit's vectors are
// hundreds of MB, and every stage's scratch is freed before the next.
// glibc's malloc serves each block over 32 MB from its own fresh mapping
// and gives it back to the kernel when freed, so the next such block is
// fresh memory again, and every page of it is faulted in and zeroed on
// first touch (docs/PERFORMANCE.md, "Fresh memory", has what that costs).
#ifndef POINTFORWARD_COMMON_MEMORY_REUSE_H_
#define POINTFORWARD_COMMON_MEMORY_REUSE_H_

namespace pf {

// Makes malloc serve every block from its heap and keep what is freed
// there for the process's later blocks, instead of mapping large blocks on
// their own and returning them to the kernel: freed memory is reused,
// already mapped. The price is that the process keeps its peak footprint
// until it exits (the kernel can still reclaim it under pressure only by
// swapping). For the command line's and the worker's main() before any
// thread starts. Returns false (and changes nothing) where the allocator is
// not glibc's malloc, for instance under a sanitizer.
bool KeepFreedMemoryForReuse();

}  // namespace pf

#endif  // POINTFORWARD_COMMON_MEMORY_REUSE_H_
