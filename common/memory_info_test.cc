#include "common/memory_info.h"

#include <fstream>
#include <string>

#include "gtest/gtest.h"

namespace pf {
namespace {

TEST(MemoryInfo, ReadsMemAvailableInBytes) {
  EXPECT_EQ(MemAvailableFromMeminfo("MemTotal:       24568732 kB\n"
                                    "MemFree:         1000000 kB\n"
                                    "MemAvailable:   20123456 kB\n"
                                    "Buffers:          123 kB\n"),
            int64_t{20123456} * 1024);
  EXPECT_EQ(MemAvailableFromMeminfo("MemTotal: 24568732 kB\nMemFree: 1 kB\n"), -1);
  EXPECT_EQ(MemAvailableFromMeminfo("MemAvailable: lots kB\n"), -1);
  EXPECT_EQ(MemAvailableFromMeminfo("MemAvailable: 12 MB\n"), -1);
}

TEST(MemoryInfo, RoomUnderACgroupLimit) {
  EXPECT_EQ(CgroupRoom("8589934592\n", "1073741824\n"), int64_t{7} << 30);
  EXPECT_EQ(CgroupRoom("1000\n", "1500\n"), 0);  // Over the limit (reclaim pending).
  EXPECT_EQ(CgroupRoom("max\n", "1073741824\n"), -1);
  EXPECT_EQ(CgroupRoom("9223372036854771712\n", "1073741824\n"), -1);  // v1: no limit.
  EXPECT_EQ(CgroupRoom("", ""), -1);
  EXPECT_EQ(CgroupRoom("8589934592", "x"), -1);
  // The inactive page cache in the usage is room: the kernel reclaims it.
  EXPECT_EQ(CgroupRoom("8589934592\n", "7516192768\n", int64_t{3} << 30), int64_t{4} << 30);
  EXPECT_EQ(CgroupRoom("1000\n", "500\n", 800), 1000);
}

TEST(MemoryInfo, TheMachineHasSomeAndNoMoreThanItsTotal) {
  std::ifstream meminfo("/proc/meminfo");
  if (!meminfo) GTEST_SKIP() << "no /proc/meminfo on this system";
  std::string key;
  int64_t total_kib = 0;
  meminfo >> key >> total_kib;
  ASSERT_EQ(key, "MemTotal:");
  const int64_t available = AvailableMemoryBytes();
  EXPECT_GE(available, 0);  // 0: a cgroup at its limit.
  EXPECT_LE(available, total_kib * 1024);
}

}  // namespace
}  // namespace pf
