// Sorting Gaussians by depth and binning them into screen tiles, in
// parallel, keeping their order: the forward rasterizer's and its backward
// pass's depth order and tile lists (rasterizer.cc, raster_backward.cc).
#ifndef POINTFORWARD_ENGINE_RENDER_TILE_BINNING_H_
#define POINTFORWARD_ENGINE_RENDER_TILE_BINNING_H_

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "common/thread_pool.h"
#include "engine/render/splat_projection.h"

namespace pf::raster {

// The fewest keys a slice of RadixSortByHighWord on a pool takes: fewer
// than two slices' worth sort on one thread.
inline constexpr size_t kMinSortSlice = size_t{1} << 17;

// RadixSortByHighWord (splat_projection.h) with each pass's counting and
// scattering split over `pool`'s working threads: the keys in fixed slices,
// slice s's keys of a digit placed after those of slices 0 .. s-1, so the
// order is the one a stable sort gives, whatever the thread count.
inline void RadixSortByHighWord(std::vector<uint64_t>* keys, std::vector<uint64_t>* buffer,
                                ThreadPool& pool) {
  const size_t n = keys->size();
  const size_t slices =
      std::clamp<size_t>(n / kMinSortSlice, 1, static_cast<size_t>(pool.num_threads()) + 1);
  if (slices == 1) {
    RadixSortByHighWord(keys, buffer);
    return;
  }
  buffer->resize(n);
  uint64_t* from = keys->data();
  uint64_t* to = buffer->data();
  std::vector<size_t> cursor(slices * kSortDigits);
  auto slice_begin = [&](size_t s) { return n * s / slices; };
  for (int shift = 32; shift < 64; shift += kSortDigitBits) {
    pool.ParallelFor(0, static_cast<int64_t>(slices), 1, [&](int64_t s0, int64_t s1) {
      for (auto s = static_cast<size_t>(s0); s < static_cast<size_t>(s1); ++s) {
        size_t* count = &cursor[s * kSortDigits];
        std::fill(count, count + kSortDigits, 0);
        for (size_t k = slice_begin(s), end = slice_begin(s + 1); k < end; ++k) {
          ++count[(from[k] >> shift) & (kSortDigits - 1)];
        }
      }
    });
    size_t total = 0;
    for (size_t d = 0; d < kSortDigits; ++d) {
      for (size_t s = 0; s < slices; ++s) {
        const size_t count = cursor[s * kSortDigits + d];
        cursor[s * kSortDigits + d] = total;
        total += count;
      }
    }
    pool.ParallelFor(0, static_cast<int64_t>(slices), 1, [&](int64_t s0, int64_t s1) {
      for (auto s = static_cast<size_t>(s0); s < static_cast<size_t>(s1); ++s) {
        size_t* next = &cursor[s * kSortDigits];
        for (size_t k = slice_begin(s), end = slice_begin(s + 1); k < end; ++k) {
          to[next[(from[k] >> shift) & (kSortDigits - 1)]++] = from[k];
        }
      }
    });
    std::swap(from, to);
  }
  // Three passes: the result is in `buffer`.
  keys->swap(*buffer);
}

// Buffers of BinByTile, kept by callers that bin again and again.
struct TileBinScratch {
  struct Chunk {
    struct Pair {
      uint32_t tile, id;
    };
    std::vector<Pair> pairs;          // The emitted pairs, in order.
    std::vector<uint32_t> histogram;  // [tiles] pairs per tile.
    int64_t emitting = 0;             // Positions that emitted any pair.
  };
  std::vector<Chunk> chunks;
  std::vector<uint64_t> cursor;  // [chunks, tiles]
};

// Positions per chunk of BinByTile's parallel passes.
inline constexpr size_t kBinChunk = 8192;

// Bins positions 0 .. count-1 in order: visit(k, emit) calls emit(tile, id)
// for each tile position k reaches (tile < num_tiles). On return tile t's ids
// are (*lists)[(*tile_begin)[t] .. (*tile_begin)[t + 1]), in the order of
// their positions (and of the emits within one); `tile_begin` has
// num_tiles + 1 entries, and `lists` is grown to at least the pairs'
// count (never shrunk). Chunks of positions run on `pool`; each tile's
// list is the chunks' pairs in chunk order (a counting sort), so the result
// does not depend on the thread count. Returns how many positions emitted.
template <typename Visit>
int64_t BinByTile(size_t count, int num_tiles, Visit&& visit, ThreadPool& pool,
                  TileBinScratch* scratch, std::vector<uint64_t>* tile_begin,
                  std::vector<uint32_t>* lists) {
  const int64_t num_chunks = static_cast<int64_t>((count + kBinChunk - 1) / kBinChunk);
  std::vector<TileBinScratch::Chunk>& chunks = scratch->chunks;
  if (chunks.size() < static_cast<size_t>(num_chunks)) chunks.resize(num_chunks);
  pool.ParallelFor(0, num_chunks, 1, [&](int64_t c0, int64_t c1) {
    for (int64_t c = c0; c < c1; ++c) {
      TileBinScratch::Chunk& chunk = chunks[c];
      chunk.histogram.assign(num_tiles, 0);
      chunk.pairs.clear();
      chunk.emitting = 0;
      const size_t begin = static_cast<size_t>(c) * kBinChunk;
      const size_t end = std::min(count, begin + kBinChunk);
      uint32_t* histogram = chunk.histogram.data();
      for (size_t k = begin; k < end; ++k) {
        const size_t before = chunk.pairs.size();
        visit(k, [&](uint32_t tile, uint32_t id) {
          chunk.pairs.push_back({tile, id});
          ++histogram[tile];
        });
        if (chunk.pairs.size() > before) ++chunk.emitting;
      }
    }
  });
  tile_begin->assign(static_cast<size_t>(num_tiles) + 1, 0);
  std::vector<uint64_t>& cursor = scratch->cursor;
  cursor.resize(static_cast<size_t>(num_tiles) * num_chunks);
  uint64_t total = 0;
  for (int t = 0; t < num_tiles; ++t) {
    (*tile_begin)[t] = total;
    for (int64_t c = 0; c < num_chunks; ++c) {
      cursor[static_cast<size_t>(c) * num_tiles + t] = total;
      total += chunks[c].histogram[t];
    }
  }
  (*tile_begin)[num_tiles] = total;
  if (lists->size() < total) lists->resize(total);
  uint32_t* out = lists->data();
  pool.ParallelFor(0, num_chunks, 1, [&](int64_t c0, int64_t c1) {
    for (int64_t c = c0; c < c1; ++c) {
      uint64_t* my_cursor = &cursor[static_cast<size_t>(c) * num_tiles];
      const TileBinScratch::Chunk& chunk = chunks[c];
      for (const TileBinScratch::Chunk::Pair& pair : chunk.pairs) {
        out[my_cursor[pair.tile]++] = pair.id;
      }
    }
  });
  int64_t emitting = 0;
  for (int64_t c = 0; c < num_chunks; ++c) emitting += chunks[c].emitting;
  return emitting;
}

}  // namespace pf::raster

#endif  // POINTFORWARD_ENGINE_RENDER_TILE_BINNING_H_
