// The backward pass of the rasterizer: the gradient of a loss with respect
// to every differentiable parameter of a Gaussian, given the loss's gradient
// with respect to the outputs of one Render().
//
// Render() (rasterizer.h) composites, at pixel p, the Gaussians of p's tile
// front to back:
//   alpha_i = min(0.99, o_i exp(-d_i^2 / 2)),  skipped below 1/255,
//   w_i = alpha_i T_i,  T_{i+1} = T_i (1 - alpha_i),  stop once T < 1e-4,
//   rgb = sum w_i c_i,  features = sum w_i f_i,  alpha = 1 - T,
//   depth = sum w_i z_i / alpha,
// with d_i^2 the conic of the EWA projection (splat_projection.h) and c_i the
// colour (flat, or with GaussianScene::colour_gradients the centre colour
// plus the gradients at the pixel's local coordinates). RenderBackward()
// walks the same tiles with the same Gaussians in the same depth order:
// per pixel front to back, keeping each contribution's alpha and
// transmittance, then back to front with the sums of what lies behind, as
// the 3DGS backward does. Each (tile, Gaussian) pair's screen-space
// gradient is kept in its own slot and the slots are summed per Gaussian in
// tile order, so the result does not depend on the thread count or timing.
// The projection is then differentiated per Gaussian: conic, centre and
// colour-gradient frame through the covariance, the EWA Jacobian (every
// camera model: the distortion's Jacobian and its own derivative taken by
// central differences of Lens, as the forward takes the Jacobian), the
// rotation and scales, to the mean, log-scales, rotation (of any norm),
// opacity logit, features and colour gradients.
//
// Not differentiated: the 0.99 clamp and the 1/255 and 1e-4 cut-offs (their
// gradient is zero or a step), the Jacobian's clamp outside the image, the
// instance ids, time and lifespan, the box poses, the camera's intrinsics (its
// pose: CameraMotionGradient below). Scenes with SH colour
// are rejected (their colours are not features).
#ifndef POINTFORWARD_ENGINE_RENDER_RASTER_BACKWARD_H_
#define POINTFORWARD_ENGINE_RENDER_RASTER_BACKWARD_H_

#include <array>
#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "engine/render/gaussian_scene.h"
#include "engine/render/rasterizer.h"

namespace pf {

// The differentiable parameters of a scene's Gaussians, in GaussianScene's
// layouts (colour_gradients empty for a scene without them). As gradients:
// dL/d each parameter.
template <typename T>
struct GaussianParams {
  std::vector<T> means;             // [N, 3]
  std::vector<T> rotations;         // [N, 4]
  std::vector<T> log_scales;        // [N, 3]
  std::vector<T> opacity_logits;    // [N]
  std::vector<T> features;          // [N, C]
  std::vector<T> colour_gradients;  // [N, 6] or empty
};
using SceneGradients = GaussianParams<float>;

// dL/d each output of one render, in RenderBuffers' layouts; an empty
// vector is a zero gradient. `features` needs RenderOptions::features and
// `depth` RenderOptions::depth.
template <typename T>
struct OutputGradients {
  std::vector<T> rgb;       // [H, W, 3]
  std::vector<T> alpha;     // [H, W]
  std::vector<T> depth;     // [H, W]
  std::vector<T> features;  // [H, W, C]
};
using RenderOutputGradients = OutputGradients<float>;

// Counters of one backward pass.
struct BackwardStats {
  int64_t gaussians_visible = 0;
  int64_t pairs = 0;               // (tile, Gaussian) pairs walked.
  int64_t pairs_contributing = 0;  // Gaussian-pixel pairs blended.
  // Bytes of the pass's own arrays at their peak (screen-space records, tile
  // lists, per-pair and per-Gaussian gradient slots, the result).
  int64_t working_bytes = 0;
};

// Per Gaussian, what one backward pass saw of it on screen (densification
// reads it, as 3DGS reads the gradient of the projected means).
struct ScreenGradients {
  std::vector<uint8_t> visible;  // [N] 1 where the view projects the Gaussian.
  std::vector<float> centre;     // [N, 2] dL/d (projected centre), per pixel; 0 where not visible.
};

// The gradient of the loss whose output gradients are `grads` through
// Render(scene, camera, timestamp_us, edits, options). INVALID_ARGUMENT for
// what Render() rejects, a rolling-shutter camera, a scene with SH colour,
// or a gradient of the wrong size (naming it). Deterministic; uses
// DefaultThreadPool(). `screen`, when given, receives the screen-space
// centre gradients.
absl::StatusOr<SceneGradients> RenderBackward(const GaussianScene& scene,
                                              const RenderCamera& camera, int64_t timestamp_us,
                                              const std::vector<ActorEdit>& edits,
                                              const RenderOutputGradients& grads,
                                              const RenderOptions& options = {},
                                              BackwardStats* stats = nullptr,
                                              ScreenGradients* screen = nullptr);

// A small motion of a camera in its own frame: rotation vector w (radians,
// camera axes) then translation t (metres); the moved camera's
// world_from_camera is the camera's times Rigid{RotationFromVector(w), t}
// (MovedCamera).
using CameraMotion = std::array<double, 6>;
RenderCamera MovedCamera(const RenderCamera& camera, const CameraMotion& motion);

// dL/d motion at zero motion: how the loss whose scene gradients are
// `grads` (RenderBackward()'s, for the same camera, time, edits and
// options) changes as the camera moves. Moving the camera is moving every
// Gaussian the other way, so this is exact: each Gaussian's mean and
// rotation gradients, taken into the camera's frame, summed. Deterministic.
// INVALID_ARGUMENT for what Render() rejects, a rolling-shutter camera or
// gradients of another size.
absl::StatusOr<CameraMotion> CameraMotionGradient(const GaussianScene& scene,
                                                  const RenderCamera& camera, int64_t timestamp_us,
                                                  const std::vector<ActorEdit>& edits,
                                                  const SceneGradients& grads,
                                                  const RenderOptions& options = {});

namespace testing {

// The same render and backward pass in double precision, with the
// parameters taken from `params` instead of the scene's arrays (the scene
// gives everything else), for checks against central differences. `rgb`,
// `alpha`, `depth` and `features` are the forward outputs (RenderBuffers'
// layouts, features and depth as `options` asks).
struct DoubleRender {
  std::vector<double> rgb, alpha, depth, features;
  GaussianParams<double> grads;
};
absl::StatusOr<DoubleRender> RenderBackwardInDouble(
    const GaussianScene& scene, const GaussianParams<double>& params, const RenderCamera& camera,
    int64_t timestamp_us, const OutputGradients<double>& grads, const RenderOptions& options = {});

// CameraMotionGradient in double, with the parameters taken from `params`.
absl::StatusOr<CameraMotion> CameraMotionGradientInDouble(
    const GaussianScene& scene, const GaussianParams<double>& params, const RenderCamera& camera,
    int64_t timestamp_us, const GaussianParams<double>& grads, const RenderOptions& options = {});

// The scene's parameters in double.
GaussianParams<double> ParamsInDouble(const GaussianScene& scene);

}  // namespace testing
}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RENDER_RASTER_BACKWARD_H_
