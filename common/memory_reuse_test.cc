// Tests that freed memory is reused, already mapped, once the process asks
// for it (KeepFreedMemoryForReuse).
#include "common/memory_reuse.h"

#include <gtest/gtest.h>
#include <sys/resource.h>

#include <cstdlib>
#include <cstring>

namespace pf {
namespace {

long MinorFaults() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_minflt;
}

TEST(MemoryReuse, AFreedLargeBlockIsReusedWithoutNewPageFaults) {
  if (!KeepFreedMemoryForReuse()) GTEST_SKIP() << "not glibc's malloc (a sanitizer's allocator)";
  // 96 MB: glibc would map a block this size on its own and unmap it when
  // freed, so writing a second one would fault in its 24,576 pages again.
  constexpr size_t kBytes = size_t{96} << 20;
  constexpr long kPages = kBytes / 4096;
  char* first = static_cast<char*>(std::malloc(kBytes));
  ASSERT_NE(first, nullptr);
  std::memset(first, 1, kBytes);
  // Keeps the compiler from dropping the writes as dead before free().
  asm volatile("" : : "r"(first) : "memory");
  std::free(first);
  const long before = MinorFaults();
  char* second = static_cast<char*>(std::malloc(kBytes));
  ASSERT_NE(second, nullptr);
  std::memset(second, 2, kBytes);
  const long faults = MinorFaults() - before;
  EXPECT_EQ(second[kBytes - 1], 2);
  std::free(second);
  EXPECT_LT(faults, kPages / 10) << faults << " page faults for " << kPages << " pages";
}

}  // namespace
}  // namespace pf
