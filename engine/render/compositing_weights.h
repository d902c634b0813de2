// The colour-linear part of Render(), recorded: for one camera and time, the
// weight with which each Gaussian's colour enters each pixel.
//
// Render() composites front to back, so pixel p gets
//   rgb_p = sum_i w_ip c_i,  w_ip = alpha_ip prod_{j in front of i} (1 - alpha_jp),
// where alpha_ip is Gaussian i's opacity times its 2D footprint at p. With
// geometry, opacity and time fixed, the rendered image is linear in the
// colours: rgb = A c. ComputeCompositingWeights() records the sparse A of one
// view by the rasterizer's own rules and arithmetic (EWA projection with the
// scene's low-pass, opacity-aware extent, depth order with ties in index
// order, the tile kernel's per-row pixel spans, lanes and exp, alpha clamped
// to 0.99, contributions under 1/255 skipped, a pixel done once its
// transmittance is under 1e-4), so each weight has the bits the render
// blends with, Composite(A, c) reproduces Render()'s premultiplied rgb for
// flat feature colours to the bit on the pixels it records, and
// AccumulateTransposed() is the colour-only backward pass:
// the gradient of sum_p |rgb_p - image_p|^2 / 2 with respect to the colours
// is A^T (A c - image). Least-squares colour fits (recon/colour_refinement.h)
// apply both without re-rendering. The forward rasterizer is not touched.
//
// Single-threaded per view (callers parallelise over views); memory is
// 4 bytes per contributing (pixel, Gaussian) pair (a 16-bit weight and a
// 16-bit slot in its tile's table of Gaussians), 4 per table slot (one per
// Gaussian and tile it contributes to), 14 per pixel, 4 per tile (and, with local
// coordinates, 24 per contributing Gaussian; with omitted colours, 12 more
// per pixel). The weights are stored to 1/65535: Composite(A, c) is the
// render's rgb within half of that per entry and unit colour.
#ifndef POINTFORWARD_ENGINE_RENDER_COMPOSITING_WEIGHTS_H_
#define POINTFORWARD_ENGINE_RENDER_COMPOSITING_WEIGHTS_H_

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "engine/render/gaussian_scene.h"
#include "engine/render/rasterizer.h"

namespace pf {

// Whether pixel (x, y) is on the lattice of 1 pixel in `stride`
// (WeightOptions::pixel_stride): (x + s y) mod stride == 0, s about
// sqrt(stride), so the recorded pixels spread evenly (stride 2: a
// checkerboard). Every pixel for stride 1.
inline bool OnPixelLattice(int x, int y, int stride) {
  if (stride <= 1) return true;
  const int shift = stride == 2 ? 1 : static_cast<int>(std::lround(std::sqrt(double(stride))));
  return (x + shift * y) % stride == 0;
}

// The sparse compositing matrix A of one view, one row per pixel.
struct CompositingWeights {
  int width = 0;
  int height = 0;
  // Rows recorded: the pixels OnPixelLattice(x, y, pixel_stride); the others
  // have no entries (their `alpha` is still the render's).
  int pixel_stride = 1;
  // Scene indices of the Gaussians with any weight in this view, each once,
  // in the order of their first entry (tile by tile, front to back): a
  // tile's Gaussians are neighbours in arrays kept in this (local) order.
  std::vector<uint32_t> gaussians;
  // One recorded pair: its weight in steps of kWeightStep and its slot in
  // the pixel's table (below).
  struct Pair {
    uint16_t slot;
    uint16_t weight;
  };
  // The weight of one step of Pair::weight: w_ip is stored rounded to the
  // nearest step (w_ip <= 0.99, the rasterizer's largest alpha).
  static constexpr float kWeightStep = 1.f / 65535.f;
  // Entries of pixel p = y * width + x are [pixel_begin[p], pixel_begin[p]
  // + pixel_count[p]), front to back (pixels are stored tile by tile, so
  // rows interleave). Entry e of pixel p is Gaussian (local index)
  // table[table_begin[pixel_table[p]] + pairs[e].slot]: the pixels of a tile
  // share one table of the Gaussians they see (a tile whose Gaussians pass
  // 65536 starts another at a pixel), so an entry takes 4 bytes, and the
  // pixels of a table are consecutive in the tile order.
  std::vector<uint32_t> pixel_begin;  // [H * W] (a view holds under 2^32 pairs)
  // [H * W]: each entry blends an alpha of at least 1/255 and a pixel is
  // done once its transmittance is under 1e-4, so a pixel has about 2,350
  // entries at most ((254/255)^2345 < 1e-4).
  std::vector<uint16_t> pixel_count;
  std::vector<uint32_t> pixel_table;  // [H * W] the pixel's table
  std::vector<uint32_t> table_begin;  // [tables + 1] each table's first slot in `table`
  std::vector<uint32_t> table;        // Local indices (into `gaussians`).
  std::vector<Pair> pairs;            // [E]
  std::vector<float> alpha;           // [H * W] 1 - transmittance, as Render()'s alpha
  // [gaussians.size(), 6] each contributing Gaussian's screen frame in this
  // view: centre (mx, my) and the rows (ux, uy), (vx, vy) that map a pixel
  // centre's offset from it to the local coordinates (u, v) of the colour
  // gradients (GaussianScene::colour_gradients); empty unless
  // WeightOptions::local_coords. An entry's (u, v) is a function of its
  // pixel and its Gaussian (LocalCoords), so it is not stored per entry.
  std::vector<float> local_frames;
  // [H * W, 3] per recorded pixel, the colour the entries left out
  // (WeightOptions::min_weight) add to the render with the scene's flat
  // colours (feature channels 0-2): render = A c + omitted where c is those
  // colours. Empty unless WeightOptions::omitted_colours.
  std::vector<float> omitted;

  size_t entries() const { return pairs.size(); }
  // Weight, Table, TableSize, PixelTable, PixelCentre, LocalCoords and
  // FrameCoords are always inlined: the AVX2 build of the normal product
  // (compositing_weights_avx2.cc) calls them too, and an out-of-line copy
  // of its own could stand in for the baseline's.
  // Entry e's weight w_ip (to kWeightStep).
  [[gnu::always_inline]] float Weight(uint64_t e) const {
    return static_cast<float>(pairs[e].weight) * kWeightStep;
  }
  // Table t's slots: local indices, TableSize(t) of them.
  [[gnu::always_inline]] const uint32_t* Table(uint32_t t) const {
    return table.data() + table_begin[t];
  }
  [[gnu::always_inline]] uint32_t TableSize(uint32_t t) const {
    return table_begin[t + 1] - table_begin[t];
  }
  // The table of pixel p's entries: entry e's local index is
  // PixelTable(p)[pairs[e].slot].
  [[gnu::always_inline]] const uint32_t* PixelTable(size_t pixel) const {
    return Table(pixel_table[pixel]);
  }
  // Every entry's local index and weight, in entry order (for consumers
  // that take them as plain arrays, such as the GPU fit's upload).
  void Unpack(std::vector<uint32_t>* local, std::vector<float>* weights) const;
  bool has_local_coords() const { return !local_frames.empty(); }
  // The centre (x + 0.5, y + 0.5) of pixel p = y * width + x.
  [[gnu::always_inline]] void PixelCentre(size_t pixel, float* px, float* py) const {
    *px = static_cast<float>(pixel % static_cast<size_t>(width)) + 0.5f;
    *py = static_cast<float>(pixel / static_cast<size_t>(width)) + 0.5f;
  }
  bool Records(size_t pixel) const {
    return OnPixelLattice(static_cast<int>(pixel % static_cast<size_t>(width)),
                          static_cast<int>(pixel / static_cast<size_t>(width)), pixel_stride);
  }
  // (u, v) of the Gaussian of local index `local` at the pixel whose centre
  // is (px, py) (x + 0.5, y + 0.5): the values Render() gives its colour
  // gradients there.
  [[gnu::always_inline]] void LocalCoords(uint32_t local, float px, float py, float* u,
                                          float* v) const {
    FrameCoords(&local_frames[6 * static_cast<size_t>(local)], px, py, u, v);
  }
  // The same from the Gaussian's 6 floats of local_frames, `f`.
  [[gnu::always_inline]] static void FrameCoords(const float* f, float px, float py, float* u,
                                                 float* v) {
    const float dx = px - f[0], dy = py - f[1];
    *u = f[2] * dx + f[3] * dy;
    *v = f[4] * dx + f[5] * dy;
  }
};

struct WeightOptions {
  float near_plane = 0.01f;  // As RenderOptions::near_plane.
  // Entries with w_ip < min_weight are not recorded (they still attenuate
  // the Gaussians behind them, and count in `alpha`). 0 records A exactly.
  float min_weight = 0.f;
  // Also record CompositingWeights::local_frames (24 bytes per contributing
  // Gaussian).
  bool local_coords = false;
  // Record the entries of 1 pixel in pixel_stride only (OnPixelLattice):
  // about 1 / pixel_stride of the memory, for fits too large for every
  // pixel. Compositing is unchanged: every pixel attenuates as before.
  int pixel_stride = 1;
  // Also record CompositingWeights::omitted (12 bytes per pixel).
  bool omitted_colours = false;
};

// Records A for `scene` seen through `camera` at scene time `timestamp_us`
// (no actor edits; through a rolling shutter each Gaussian from its line's
// pose, as Render()). INVALID_ARGUMENT if the camera has no pixels (or, with
// a rolling shutter, more than kMaxRenderPixels), or the scene has more than
// 2^32 Gaussians or its arrays disagree in size.
absl::StatusOr<CompositingWeights> ComputeCompositingWeights(const GaussianScene& scene,
                                                             const RenderCamera& camera,
                                                             int64_t timestamp_us,
                                                             const WeightOptions& options = {});

// Writes image = A c: `colours` is [a.gaussians.size(), channels] in local
// order, `image` is [H * W, channels].
void Composite(const CompositingWeights& a, const float* colours, int channels, float* image);

// Adds A^T r to `out`: `residual` is [H * W, channels]; `out` is
// [a.gaussians.size(), channels] in local order.
void AccumulateTransposed(const CompositingWeights& a, const float* residual, int channels,
                          float* out);

// The same two products for colours that vary across each Gaussian (the
// render is linear in the centre colours and the gradients too): `params` and
// `out` are [a.gaussians.size(), 3, 3], per RGB channel (colour, g_u, g_v) as
// GaussianScene::colour_gradients; `image` and `residual` are [H * W, 3].
// `a` must have local coordinates (WeightOptions::local_coords).
void CompositeTextured(const CompositingWeights& a, const float* params, float* image);
void AccumulateTransposedTextured(const CompositingWeights& a, const float* residual, float* out);

// Adds A^T M A x to `out`, M the pixels where `mask` ([H * W]) is non-zero:
// textured (`x`, `out` as CompositeTextured's params) when `a` has local
// coordinates, else flat RGB ([a.gaussians.size(), 3]). One pass: each
// pixel's entries are read from memory once and, still in cache, again for
// the transposed product, where Composite then AccumulateTransposed read
// them all twice (the colour fit's iterations are mostly this). Pixels are
// taken tile by tile; the textured product gathers each table's Gaussians
// into arrays of the tile's size, sums its pixels there and adds them to
// `out` when the table's pixels end, so the sums run in that order. The textured
// product has an AVX2 build (compositing_weights_avx2.h), used where the
// render's tile kernel is not the baseline; both give the same bits.
void AccumulateNormal(const CompositingWeights& a, const std::vector<uint8_t>& mask, const float* x,
                      float* out);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RENDER_COMPOSITING_WEIGHTS_H_
