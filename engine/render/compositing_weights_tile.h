// One tile of ComputeCompositingWeights (compositing_weights.h): the tile
// kernel's compositing (raster_tile_kernel.h: per-row spans, pixel groups
// starting at each span's first pixel, lane arithmetic) over W lanes, each
// blended pair of a pixel on the lattice recorded. compositing_weights.cc
// instantiates it with the baseline's W = 4, compositing_weights_avx2.cc
// with W = 8 under -mavx2 and no fused multiply-adds; every lane computes
// what the scalar specification says, so both record the same bits, and the
// pairs come in the same order (splat by splat, pixel by pixel). Include
// only from those two files.
#ifndef POINTFORWARD_ENGINE_RENDER_COMPOSITING_WEIGHTS_TILE_H_
#define POINTFORWARD_ENGINE_RENDER_COMPOSITING_WEIGHTS_TILE_H_

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "engine/render/raster_tile.h"
#include "engine/render/raster_tile_kernel.h"
#include "engine/render/splat_projection.h"

namespace pf::weights_tile {

// The widest lane count the tile buffers are padded for: the last row's
// lanes past the tile read and write back (unchanged) the padding, as the
// tile kernel's do.
inline constexpr int kMaxLanes = 8;
inline constexpr int kPadded = raster::kTilePixels + kMaxLanes;

// A blended pair of the tile: the splat's visible index, its weight and the
// pixel's index in the tile.
struct Entry {
  uint32_t gaussian;
  float weight;
  uint8_t pixel;
};

// One tile's splats and buffers.
struct Tile {
  int x_begin = 0, y_begin = 0, x_end = 0, y_end = 0;  // Pixels [begin, end).
  const uint32_t* list = nullptr;                      // Visible indices, front to back.
  uint64_t list_size = 0;
  const raster::SplatGeometry* visible = nullptr;
  // [visible, 3] flat colours, or null: no omitted colours are summed.
  const float* visible_colour = nullptr;
  float min_weight = 0.f;                 // Pairs under it are omitted, not recorded.
  float* trans = nullptr;                 // [kPadded] transmittance, 1 at the start.
  const int32_t* recorded = nullptr;      // [kPadded] -1 on the lattice, else 0.
  float (*omitted)[kPadded] = nullptr;    // [3][kPadded] with visible_colour.
  std::vector<Entry>* entries = nullptr;  // Appended to.
};

// How many splats of a tile's list ahead the loop prefetches.
inline constexpr uint64_t kPrefetchAhead = 8;

}  // namespace pf::weights_tile

namespace pf {
namespace {

// Composites `tile` front to back over W lanes until every pixel is done.
template <int W>
inline void RecordTileLanes(const weights_tile::Tile& tile) {
  using F = typename raster::Lanes<W>::F;
  using I = typename raster::Lanes<W>::I;
  using raster::kMaxAlpha;
  using raster::kMinAlpha;
  using raster::kMinTransmittance;
  using raster::kTile;
  static_assert(W <= weights_tile::kMaxLanes);
  const int x_begin = tile.x_begin, y_begin = tile.y_begin;
  const int x_end = tile.x_end, y_end = tile.y_end;
  F lane;
  for (int l = 0; l < W; ++l) lane[l] = static_cast<float>(l);
  int active = (x_end - x_begin) * (y_end - y_begin);  // Pixels not done yet.
  for (uint64_t k = 0; k < tile.list_size && active > 0; ++k) {
    // A tile's splats lie far apart in depth order: ask for one ahead.
    if (k + weights_tile::kPrefetchAhead < tile.list_size) {
      const uint32_t ahead = tile.list[k + weights_tile::kPrefetchAhead];
      __builtin_prefetch(&tile.visible[ahead]);
      if (tile.visible_colour != nullptr)
        __builtin_prefetch(&tile.visible_colour[3 * size_t(ahead)]);
    }
    const uint32_t i = tile.list[k];
    const raster::SplatGeometry& g = tile.visible[i];
    const float det = g.ca * g.cc - g.cb * g.cb;
    const float inv_ca = 1.f / g.ca;
    const int row0 = std::max(y_begin, static_cast<int>(std::ceil(g.my - g.ext_y - 0.5f)));
    const int row1 = std::min(y_end - 1, static_cast<int>(std::floor(g.my + g.ext_y - 0.5f)));
    const F opacity = F{} + g.opacity;
    const float dx_origin = x_begin + 0.5f - g.mx;  // dx at tile column 0.
    I done{};
    for (int row = row0; row <= row1; ++row) {
      const float dy = row + 0.5f - g.my;
      const float disc = g.ca * g.span_d2 - det * dy * dy;
      if (!(disc >= 0.f)) continue;
      const float half = std::sqrt(disc) * inv_ca;
      const float mid = g.mx - 0.5f - g.cb * dy * inv_ca;
      const int col0 = std::max(x_begin, static_cast<int>(std::ceil(std::max(mid - half, -1e9f))));
      const int col1 =
          std::min(x_end - 1, static_cast<int>(std::floor(std::min(mid + half, 1e9f))));
      if (col0 > col1) continue;
      const float row_term = g.cc * dy * dy;
      const float cross = 2.f * g.cb * dy;
      const float lx0 = static_cast<float>(col0 - x_begin);
      const float lx1 = static_cast<float>(col1 - x_begin);
      const int row_base = (row - y_begin) * kTile;
      for (int gx = col0 - x_begin; gx <= col1 - x_begin; gx += W) {
        const int p = row_base + gx;
        const F lx = lane + static_cast<float>(gx);
        const F tp = raster::Load<F>(tile.trans + p);
        const I live = (lx >= lx0) & (lx <= lx1) & (tp >= kMinTransmittance);
        if (raster::MoveMask<W>(live) == 0) continue;
        const F dx = lx + dx_origin;
        const F d2 = g.ca * dx * dx + cross * dx + row_term;
        F alpha = opacity * raster::FastExp2<W>(d2 * raster::kMinusHalfLog2e);
        alpha = alpha < kMaxAlpha ? alpha : F{} + kMaxAlpha;
        const I blend = live & (alpha >= kMinAlpha);
        if (raster::MoveMask<W>(blend) == 0) continue;
        const F weight = alpha * tp;
        const F next = blend ? tp * (1.f - alpha) : tp;
        raster::Store(tile.trans + p, next);
        done += blend & (next < kMinTransmittance);  // -1 per newly done pixel.
        // Blended on the lattice: an entry at min_weight or more, else an
        // omitted colour.
        const I on_lattice = blend & raster::Load<I>(tile.recorded + p);
        unsigned bits = raster::MoveMask<W>(on_lattice & (weight >= tile.min_weight));
        for (; bits != 0; bits &= bits - 1) {
          const int l = __builtin_ctz(bits);
          tile.entries->push_back({i, weight[l], static_cast<uint8_t>(p + l)});
        }
        if (tile.visible_colour != nullptr) {
          const I left_out = on_lattice & (weight < tile.min_weight);
          if (raster::MoveMask<W>(left_out) != 0) {
            const float* colour = &tile.visible_colour[3 * size_t(i)];
            const F w = left_out ? weight : F{};
            for (int c = 0; c < 3; ++c) {
              raster::Store(tile.omitted[c] + p,
                            raster::Load<F>(tile.omitted[c] + p) + w * colour[c]);
            }
          }
        }
      }
    }
    for (int l = 0; l < W; ++l) active += done[l];
  }
}

}  // namespace
}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RENDER_COMPOSITING_WEIGHTS_TILE_H_
