// The colour-linear part of Render(), recorded: for one camera and time, the
// weight with which each Gaussian's colour enters each pixel.
//
// Render() composites front to back, so pixel p gets
//   rgb_p = sum_i w_ip c_i,  w_ip = alpha_ip prod_{j in front of i} (1 - alpha_jp),
// where alpha_ip is Gaussian i's opacity times its 2D footprint at p. With
// geometry, opacity and time fixed, the rendered image is linear in the
// colours: rgb = A c. ComputeCompositingWeights() records the sparse A of one
// view by the rasterizer's own rules (EWA projection with the scene's
// low-pass, opacity-aware extent, depth order with ties in index order, the
// same per-row pixel spans, alpha clamped to 0.99, contributions under 1/255
// skipped, a pixel done once its transmittance is under 1e-4), so
// Composite(A, c) reproduces Render()'s premultiplied rgb for feature colours
// (to float rounding: the rasterizer's exp is a polynomial), and
// AccumulateTransposed() is the colour-only backward pass: the gradient of
// sum_p |rgb_p - image_p|^2 / 2 with respect to the colours is
// A^T (A c - image). Least-squares colour fits (recon/colour_refinement.h)
// apply both without re-rendering. The forward rasterizer is not touched.
//
// Single-threaded per view (callers parallelise over views); memory is
// 8 bytes per contributing (pixel, Gaussian) pair (16 with local
// coordinates) plus 16 per pixel.
#ifndef POINTFORWARD_WORKER_ENGINE_RENDER_COMPOSITING_WEIGHTS_H_
#define POINTFORWARD_WORKER_ENGINE_RENDER_COMPOSITING_WEIGHTS_H_

#include <cstddef>
#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "worker/engine/render/gaussian_scene.h"
#include "worker/engine/render/rasterizer.h"

namespace pf {

// The sparse compositing matrix A of one view, one row per pixel.
struct CompositingWeights {
  int width = 0;
  int height = 0;
  // Scene indices of the Gaussians with any weight in this view, ascending.
  std::vector<uint32_t> gaussians;
  // Entries of pixel p = y * width + x are [pixel_begin[p], pixel_end[p]),
  // front to back (pixels are stored tile by tile, so rows interleave).
  std::vector<uint64_t> pixel_begin;  // [H * W]
  std::vector<uint32_t> pixel_count;  // [H * W]
  std::vector<uint32_t> local;        // [E] index into `gaussians`
  std::vector<float> weights;         // [E] w_ip
  std::vector<float> alpha;           // [H * W] 1 - transmittance, as Render()'s alpha
  // [E, 2] the expected local coordinates (u, v) of each entry's pixel on
  // its Gaussian (GaussianScene::colour_gradients); empty unless
  // WeightOptions::local_coords.
  std::vector<float> coords;

  size_t entries() const { return weights.size(); }
};

struct WeightOptions {
  float near_plane = 0.01f;  // As RenderOptions::near_plane.
  // Entries with w_ip < min_weight are not recorded (they still attenuate
  // the Gaussians behind them, and count in `alpha`). 0 records A exactly.
  float min_weight = 0.f;
  // Also record CompositingWeights::coords (8 more bytes per entry).
  bool local_coords = false;
};

// Records A for `scene` seen through `camera` at scene time `timestamp_us`
// (no actor edits). INVALID_ARGUMENT if the camera has no pixels or the scene
// has more than 2^32 Gaussians or its arrays disagree in size.
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
// `a` must have coords.
void CompositeTextured(const CompositingWeights& a, const float* params, float* image);
void AccumulateTransposedTextured(const CompositingWeights& a, const float* residual, float* out);

// Adds A^T M A x to `out`, M the pixels where `mask` ([H * W]) is non-zero:
// textured (`x`, `out` as CompositeTextured's params) when `a` has coords,
// else flat RGB ([a.gaussians.size(), 3]). One pass: each pixel's entries
// are read from memory once and, still in cache, again for the transposed
// product, where Composite then AccumulateTransposed read them all twice
// (the colour fit's iterations are mostly this).
void AccumulateNormal(const CompositingWeights& a, const std::vector<uint8_t>& mask, const float* x,
                      float* out);

}  // namespace pf

#endif  // POINTFORWARD_WORKER_ENGINE_RENDER_COMPOSITING_WEIGHTS_H_
