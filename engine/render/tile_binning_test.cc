// Tests of BinByTile: every pair lands in its tile's list, in the order of
// the positions, whatever the thread count and chunking; and of the depth
// sort on a pool.
#include "engine/render/tile_binning.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

namespace pf::raster {
namespace {

TEST(TileBinning, KeepsThePositionsOrderInEveryTileWhateverTheThreads) {
  // 20,001 positions (three chunks), each reaching 0-4 of 37 tiles; ids are
  // a shuffled map of the positions so that order and id differ.
  constexpr int kTiles = 37;
  constexpr size_t kCount = 2 * kBinChunk + 3617;
  std::mt19937 rng(11);
  std::vector<std::vector<uint32_t>> reach(kCount);
  std::vector<uint32_t> id(kCount);
  for (size_t k = 0; k < kCount; ++k) {
    id[k] = static_cast<uint32_t>((k * 7919) % kCount);
    const int n = static_cast<int>(rng() % 5);
    for (int j = 0; j < n; ++j) reach[k].push_back(static_cast<uint32_t>(rng() % kTiles));
  }
  // What a serial pass gives.
  std::vector<std::vector<uint32_t>> expected(kTiles);
  int64_t expected_emitting = 0;
  for (size_t k = 0; k < kCount; ++k) {
    for (uint32_t t : reach[k]) expected[t].push_back(id[k]);
    expected_emitting += !reach[k].empty();
  }
  for (int threads : {1, 2, 5}) {
    ThreadPool pool(threads);
    TileBinScratch scratch;
    std::vector<uint64_t> tile_begin;
    std::vector<uint32_t> lists(3, 99);        // Grown, never shrunk.
    for (int round = 0; round < 2; ++round) {  // The scratch reused.
      const int64_t emitting = BinByTile(
          kCount, kTiles,
          [&](size_t k, auto&& emit) {
            for (uint32_t t : reach[k]) emit(t, id[k]);
          },
          pool, &scratch, &tile_begin, &lists);
      EXPECT_EQ(emitting, expected_emitting) << threads;
      ASSERT_EQ(tile_begin.size(), static_cast<size_t>(kTiles) + 1);
      EXPECT_EQ(tile_begin[0], 0u);
      for (int t = 0; t < kTiles; ++t) {
        const std::vector<uint32_t> got(lists.begin() + tile_begin[t],
                                        lists.begin() + tile_begin[t + 1]);
        EXPECT_EQ(got, expected[t]) << "tile " << t << ", " << threads << " threads";
      }
      EXPECT_GE(lists.size(), tile_begin[kTiles]);
    }
  }
}

TEST(TileBinning, TheDepthSortOnAPoolIsTheStableSortWhateverTheThreads) {
  // Keys (depth bits << 32 | index) with few distinct depths, so ties are
  // common and only a stable sort keeps them in index order; sizes below,
  // at and well past one slice per thread.
  std::mt19937 rng(5);
  for (size_t n : {size_t{0}, size_t{1000}, kMinSortSlice * 2, kMinSortSlice * 7 + 123}) {
    std::vector<uint64_t> input(n);
    for (size_t k = 0; k < n; ++k) {
      const uint32_t depth = (rng() % 3000) * 4099u;  // Spread over all three digits.
      input[k] = (static_cast<uint64_t>(depth) << 32) | static_cast<uint32_t>((k * 7919) % n);
    }
    std::vector<uint64_t> expected = input;
    std::stable_sort(expected.begin(), expected.end(),
                     [](uint64_t a, uint64_t b) { return (a >> 32) < (b >> 32); });
    for (int threads : {0, 1, 2, 5}) {
      ThreadPool pool(threads);
      std::vector<uint64_t> keys = input, buffer;
      RadixSortByHighWord(&keys, &buffer, pool);
      EXPECT_EQ(keys, expected) << n << " keys, " << threads << " threads";
    }
  }
}

}  // namespace
}  // namespace pf::raster
