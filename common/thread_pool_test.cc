// Tests for the thread pool's parallel-for.
#include "common/thread_pool.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <numeric>
#include <stdexcept>
#include <thread>
#include <vector>

namespace pf {
namespace {

TEST(ThreadPool, ParallelForVisitsEveryIndexOnce) {
  ThreadPool pool(3);
  std::vector<int> hits(10007, 0);
  pool.ParallelFor(0, static_cast<int64_t>(hits.size()), 64, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) ++hits[i];
  });
  for (int h : hits) ASSERT_EQ(h, 1);
}

TEST(ThreadPool, ChunkBoundariesDependOnlyOnRangeAndGrain) {
  ThreadPool pool(2);
  std::vector<std::pair<int64_t, int64_t>> chunks(4);
  pool.ParallelFor(5, 40, 10, [&](int64_t b, int64_t e) { chunks[(b - 5) / 10] = {b, e}; });
  EXPECT_EQ(chunks[0].first, 5);
  EXPECT_EQ(chunks[0].second, 15);
  EXPECT_EQ(chunks[3].first, 35);
  EXPECT_EQ(chunks[3].second, 40);
}

TEST(ThreadPool, NestedParallelForRunsAndCompletes) {
  ThreadPool pool(2);
  std::atomic<int> total{0};
  pool.ParallelFor(0, 8, 1, [&](int64_t, int64_t) {
    pool.ParallelFor(0, 8, 1, [&](int64_t b, int64_t e) { total += static_cast<int>(e - b); });
  });
  EXPECT_EQ(total.load(), 64);
}

TEST(ThreadPool, WithoutWorkersTheCallerDoesEverything) {
  ThreadPool pool(0);
  EXPECT_EQ(pool.num_threads(), 0);
  const std::thread::id caller = std::this_thread::get_id();
  std::vector<int> visits(100, 0);
  bool elsewhere = false;
  pool.ParallelFor(0, 100, 7, [&](int64_t b, int64_t e) {
    elsewhere |= std::this_thread::get_id() != caller;
    for (int64_t i = b; i < e; ++i) ++visits[i];
  });
  EXPECT_FALSE(elsewhere);
  EXPECT_EQ(std::count(visits.begin(), visits.end(), 1), 100);
  bool ran = false;
  pool.Schedule([&] { ran = std::this_thread::get_id() == caller; });
  EXPECT_TRUE(ran);
}

TEST(ThreadPool, ExceptionInBodyReachesCaller) {
  ThreadPool pool(2);
  EXPECT_THROW(pool.ParallelFor(0, 100, 1,
                                [](int64_t b, int64_t) {
                                  if (b == 57) throw std::runtime_error("boom");
                                }),
               std::runtime_error);
}

}  // namespace
}  // namespace pf
