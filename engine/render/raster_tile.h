// The compositing kernel of the rasterizer: one 16x16 tile, its Gaussians in
// depth order, front to back. Internal to rasterizer.cc; compiled three
// times, for the x86-64 baseline (4 lanes, SSE2), AVX2 (8 lanes) and AVX-512
// (16 lanes), and chosen at run time (TileKernelName() says which).
#ifndef POINTFORWARD_ENGINE_RENDER_RASTER_TILE_H_
#define POINTFORWARD_ENGINE_RENDER_RASTER_TILE_H_

#include <cstddef>
#include <cstdint>

namespace pf::raster {

inline constexpr int kTile = 16;
inline constexpr int kTilePixels = kTile * kTile;
inline constexpr float kMinAlpha = 1.f / 255.f;
inline constexpr float kMaxAlpha = 0.99f;
inline constexpr float kMinTransmittance = 1e-4f;
inline constexpr int kTilePadding = 16;
// Floats between two channels of a tile accumulator: 256 pixels plus 16, so
// the channels of one pixel do not all fall into the same cache sets (a
// 1 KiB stride would, and 4 KiB aliasing would stall the stores).
inline constexpr int kChannelStride = kTilePixels + 16;

// One projected Gaussian, as the compositing loop reads it (one cache line).
struct Projected {
  float mx, my;      // Pixel-space centre.
  float ca, cb, cc;  // Conic: d^2 = ca dx^2 + 2 cb dx dy + cc dy^2.
  float opacity;     // Time-faded opacity.
  float span_d2;     // d^2 bound for spans and tile tests (1/255 level + margin).
  float ext_x;       // Half width of the ellipse's bounding box, pixels.
  float ext_y;       // Half height.
  float depth;       // Camera z.
  float rgb[3];      // Colour from SH (only when the scene has SH).
  uint32_t owner;
  uint32_t pad[2];
};
static_assert(sizeof(Projected) == 64);

// One tile's work. The accumulators are tile-local, channel-major:
// acc[c * kChannelStride + p] with p = y * 16 + x inside the tile; every
// buffer has
// kTilePadding floats of slack after its end (the kernel reads and writes
// back, unchanged, up to that many entries past the last pixel).
struct TileJob {
  const Projected* projected = nullptr;
  const uint32_t* indices = nullptr;  // [num_indices] Gaussians, front to back.
  size_t num_indices = 0;
  int x_begin = 0, y_begin = 0, x_end = 0, y_end = 0;  // Pixels, [begin, end).
  const float* features = nullptr;                     // [N, stride]
  int stride = 0;
  int count = 0;        // Feature channels accumulated into acc.
  bool sh_rgb = false;  // Also accumulate Projected::rgb into acc_rgb.
  // [N, 6] screen-space colour gradients of the projected Gaussians
  // (ScreenColourGradients in splat_projection.h), or null for flat colours:
  // channels 0..2 then blend feat[c] + g[2c] dx + g[2c + 1] dy, (dx, dy) the
  // pixel centre's offset from the Gaussian's.
  const float* gradients = nullptr;
  // Tile-local buffers, filled by the kernel.
  float* transmittance = nullptr;  // [256]
  float* acc = nullptr;            // [count, kChannelStride]
  float* acc_rgb = nullptr;        // [3, kChannelStride]
  float* acc_depth = nullptr;      // [256]
  float* best_weight = nullptr;    // [256]
  uint32_t* best_owner = nullptr;  // [256]
  int64_t tested = 0;              // Pairs evaluated.
  int64_t contributing = 0;        // Pairs blended.
};

// Composites `job` (4 lanes, x86-64 baseline).
void CompositeTileBaseline(TileJob* job);
// Composites `job` with 8 AVX2 lanes; only call when the CPU has AVX2.
void CompositeTileAvx2(TileJob* job);
// Composites `job` with 16 AVX-512 lanes; only call when the CPU has
// AVX-512F.
void CompositeTileAvx512(TileJob* job);

// The blend peak of `pf bench raster`: what the compositing arithmetic alone
// reaches on this CPU. One Gaussian of the peak loop: centre, conic,
// opacity and colour, as Projected has them.
struct PeakGaussian {
  float mx, my, ca, cb, cc, opacity;
  float rgb[3];
};
// Blends `count` Gaussians, front to back, over every pixel of one tile
// (pixel centres x + 0.5, y + 0.5 in tile coordinates) with no spans, masks,
// cut-offs or early exit, each group of pixels' transmittance and RGB kept
// in registers, and writes them to `out` ([4, 256]: transmittance, r, g, b).
// Every build gives the same bits. BlendPeakTile() runs the widest build
// this CPU has, whatever CompositeTile() uses: the machine's peak.
void BlendPeakTileBaseline(const PeakGaussian* gaussians, int count, float* out);
void BlendPeakTileAvx2(const PeakGaussian* gaussians, int count, float* out);
void BlendPeakTileAvx512(const PeakGaussian* gaussians, int count, float* out);
void BlendPeakTile(const PeakGaussian* gaussians, int count, float* out);
// Returns the kernel BlendPeakTile() runs: "avx512", "avx2" or "baseline".
const char* BlendPeakKernelName();

// Composites `job` with the kernel PF_RENDER_KERNEL names (baseline, avx2,
// avx512) if this CPU runs it, else with AVX2 if it has it, else the
// baseline. Every kernel gives the same bits.
void CompositeTile(TileJob* job);
// Returns "avx512", "avx2" or "baseline": the kernel CompositeTile() uses.
const char* TileKernelName();
// Makes CompositeTile() use the kernel named (tests); nullptr goes back to
// the default. False, changing nothing, when this CPU or build lacks it.
bool UseTileKernelForTesting(const char* name);

}  // namespace pf::raster

#endif  // POINTFORWARD_ENGINE_RENDER_RASTER_TILE_H_
