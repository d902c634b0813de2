// Binning Gaussians into screen tiles, in parallel, keeping their order:
// the forward rasterizer's and its backward pass's tile lists
// (rasterizer.cc, raster_backward.cc).
#ifndef POINTFORWARD_ENGINE_RENDER_TILE_BINNING_H_
#define POINTFORWARD_ENGINE_RENDER_TILE_BINNING_H_

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "common/thread_pool.h"

namespace pf::raster {

// Buffers of BinByTile, kept by callers that bin again and again.
struct TileBinScratch {
  struct Chunk {
    std::vector<uint32_t> tiles;      // Tile of each emitted pair.
    std::vector<uint32_t> ids;        // Id of each emitted pair.
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
      chunk.tiles.clear();
      chunk.ids.clear();
      chunk.emitting = 0;
      const size_t begin = static_cast<size_t>(c) * kBinChunk;
      const size_t end = std::min(count, begin + kBinChunk);
      for (size_t k = begin; k < end; ++k) {
        const size_t before = chunk.ids.size();
        visit(k, [&](uint32_t tile, uint32_t id) {
          chunk.tiles.push_back(tile);
          chunk.ids.push_back(id);
          ++chunk.histogram[tile];
        });
        if (chunk.ids.size() > before) ++chunk.emitting;
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
      for (size_t k = 0; k < chunk.ids.size(); ++k) out[my_cursor[chunk.tiles[k]]++] = chunk.ids[k];
    }
  });
  int64_t emitting = 0;
  for (int64_t c = 0; c < num_chunks; ++c) emitting += chunks[c].emitting;
  return emitting;
}

}  // namespace pf::raster

#endif  // POINTFORWARD_ENGINE_RENDER_TILE_BINNING_H_
