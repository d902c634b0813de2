// AccumulateNormal's textured product and the recording's tile loop
// (compositing_weights.h) built with AVX2, for CPUs that have it:
// compositing_weights_avx2.cc, compiled with -mavx2 and no fused
// multiply-adds on x86-64 builds only. The same bits as the baseline in
// compositing_weights.cc; both walk the pixels with ForEachMaskedPixelByTile
// and record tiles with RecordTileLanes. Include only from those two files.
#ifndef POINTFORWARD_ENGINE_RENDER_COMPOSITING_WEIGHTS_AVX2_H_
#define POINTFORWARD_ENGINE_RENDER_COMPOSITING_WEIGHTS_AVX2_H_

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "engine/render/compositing_weights.h"
#include "engine/render/compositing_weights_tile.h"
#include "engine/render/raster_tile.h"

namespace pf {

// Internal linkage: the AVX2 file's copies of these must never stand in for
// the baseline's (raster_tile_kernel.h does the same).
namespace {

// Calls body(begin, count, px, py) for every pixel p of `a` where mask[p] is
// non-zero (its entries [begin, begin + count), its centre (px, py)), tile by
// tile and row by row within a tile: the order the entries are stored in, so
// a tile's Gaussians stay in cache. (Each caller's lambda makes its own
// instance, built with that caller's instruction set.)
template <typename Body>
inline void ForEachMaskedPixelByTile(const CompositingWeights& a, const std::vector<uint8_t>& mask,
                                     Body&& body) {
  constexpr size_t kTile = static_cast<size_t>(raster::kTile);
  const size_t width = static_cast<size_t>(a.width), height = static_cast<size_t>(a.height);
  for (size_t tile_y = 0; tile_y < height; tile_y += kTile) {
    for (size_t tile_x = 0; tile_x < width; tile_x += kTile) {
      for (size_t y = tile_y; y < std::min(height, tile_y + kTile); ++y) {
        for (size_t p = y * width + tile_x; p < y * width + std::min(width, tile_x + kTile); ++p) {
          if (!mask[p]) continue;
          float px, py;
          a.PixelCentre(p, &px, &py);
          body(a.pixel_begin[p], static_cast<uint64_t>(a.pixel_count[p]), px, py);
        }
      }
    }
  }
}

// Entry e's weight w and its products with the local coordinates (u, v) at
// pixel centre (px, py), and the offset of its Gaussian's 9 parameters.
struct TexturedEntry {
  float w, wu, wv;
  size_t offset;
};
inline TexturedEntry TexturedEntryAt(const CompositingWeights& a, uint64_t e, float px, float py) {
  float u, v;
  a.LocalCoords(e, px, py, &u, &v);
  const float w = a.weights[e];
  return {w, w * u, w * v, static_cast<size_t>(a.local[e]) * 9};
}

}  // namespace

// Adds A^T M A x to `out` for weights `a` with local coordinates; `x` and
// `out` are [a.gaussians.size(), 3, 3], M the pixels where `mask` is non-zero.
void AccumulateNormalTexturedAvx2(const CompositingWeights& a, const std::vector<uint8_t>& mask,
                                  const float* x, float* out);

// RecordTileLanes<8>(tile).
void RecordTileAvx2(const weights_tile::Tile& tile);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RENDER_COMPOSITING_WEIGHTS_AVX2_H_
