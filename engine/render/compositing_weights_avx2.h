// AccumulateNormal's textured product and the recording's tile loop
// (compositing_weights.h) built with AVX2, for CPUs that have it:
// compositing_weights_avx2.cc, compiled with -mavx2 and no fused
// multiply-adds on x86-64 builds only. The same bits as the baseline in
// compositing_weights.cc; both walk the pixels with ForEachMaskedPixelByTable
// and record tiles with RecordTileLanes. Include only from those two files.
#ifndef POINTFORWARD_ENGINE_RENDER_COMPOSITING_WEIGHTS_AVX2_H_
#define POINTFORWARD_ENGINE_RENDER_COMPOSITING_WEIGHTS_AVX2_H_

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include "engine/render/compositing_weights.h"
#include "engine/render/compositing_weights_tile.h"
#include "engine/render/raster_tile.h"

namespace pf {

// A table's Gaussians (CompositingWeights::table) gathered for the pixels
// that share it, in slot order: their 9 parameters, their screen frames (6
// floats) and their share of the product (9); room for the view's largest
// table, allocated by the caller (no std::vector code is built with AVX2:
// an out-of-line copy of its could stand in for the baseline's).
struct TableScratch {
  float* x;
  float* frames;
  float* out;
};

// Internal linkage: the AVX2 file's copies of these must never stand in for
// the baseline's (raster_tile_kernel.h does the same).
namespace {

// For the textured normal product: walks the pixels of `a` where mask[p] is
// non-zero tile by tile and row by row within a tile (the order the entries
// are stored in); at each table's first such pixel, gathers the table's
// Gaussians' parameters from `x` ([a.gaussians.size(), 9]) and screen frames
// into `scratch`, calls body(begin, count, px, py) for each of its pixels (its
// entries [begin, begin + count), centre (px, py)), whose sums go to
// scratch.out by slot, and adds those to `out` ([a.gaussians.size(), 9]) when
// the table's pixels end. So a pixel's entries read their Gaussians from
// arrays the size of one tile's, not from the whole view's. (Each caller's
// lambda makes its own instance, built with that caller's instruction set.)
template <typename Body>
inline void ForEachMaskedPixelByTable(const CompositingWeights& a, const std::vector<uint8_t>& mask,
                                      const float* x, float* out, const TableScratch& scratch,
                                      Body&& body) {
  constexpr size_t kTile = static_cast<size_t>(raster::kTile);
  const size_t width = static_cast<size_t>(a.width), height = static_cast<size_t>(a.height);
  uint32_t current = UINT32_MAX;
  auto flush = [&] {
    if (current == UINT32_MAX) return;
    const uint32_t* table = a.Table(current);
    const float* sums = scratch.out;
    for (uint32_t s = 0, m = a.TableSize(current); s < m; ++s) {
      float* dst = out + 9 * static_cast<size_t>(table[s]);
      for (int j = 0; j < 9; ++j) dst[j] += sums[9 * s + j];
    }
  };
  auto gather = [&](uint32_t t) {
    const uint32_t* table = a.Table(t);
    const uint32_t m = a.TableSize(t);
    for (uint32_t s = 0; s < m; ++s) {
      const size_t l = table[s];
      std::memcpy(scratch.x + 9 * size_t(s), x + 9 * l, 9 * sizeof(float));
      std::memcpy(scratch.frames + 6 * size_t(s), a.local_frames.data() + 6 * l, 6 * sizeof(float));
    }
    if (m > 0) std::memset(scratch.out, 0, 9 * size_t(m) * sizeof(float));
    current = t;
  };
  for (size_t tile_y = 0; tile_y < height; tile_y += kTile) {
    for (size_t tile_x = 0; tile_x < width; tile_x += kTile) {
      for (size_t y = tile_y; y < std::min(height, tile_y + kTile); ++y) {
        for (size_t p = y * width + tile_x; p < y * width + std::min(width, tile_x + kTile); ++p) {
          if (!mask[p]) continue;
          if (a.pixel_table[p] != current) {
            flush();
            gather(a.pixel_table[p]);
          }
          float px, py;
          a.PixelCentre(p, &px, &py);
          body(a.pixel_begin[p], static_cast<uint64_t>(a.pixel_count[p]), px, py);
        }
      }
    }
  }
  flush();
}

// Entry e's weight w and its products with the local coordinates (u, v) at
// pixel centre (px, py), and the offset of its Gaussian's 9 parameters in
// the gathered table (TableScratch::x and ::out).
struct TexturedEntry {
  float w, wu, wv;
  size_t offset;
};
inline TexturedEntry TexturedEntryAt(const CompositingWeights& a, const TableScratch& scratch,
                                     uint64_t e, float px, float py) {
  const size_t slot = a.pairs[e].slot;
  float u, v;
  CompositingWeights::FrameCoords(scratch.frames + 6 * slot, px, py, &u, &v);
  const float w = a.Weight(e);
  return {w, w * u, w * v, slot * 9};
}

}  // namespace

// Adds A^T M A x to `out` for weights `a` with local coordinates; `x` and
// `out` are [a.gaussians.size(), 3, 3], M the pixels where `mask` is non-zero.
void AccumulateNormalTexturedAvx2(const CompositingWeights& a, const std::vector<uint8_t>& mask,
                                  const float* x, float* out, const TableScratch& scratch);

// RecordTileLanes<8>(tile).
void RecordTileAvx2(const weights_tile::Tile& tile);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RENDER_COMPOSITING_WEIGHTS_AVX2_H_
