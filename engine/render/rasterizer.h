// Tile-based EWA splatting of a GaussianScene on the CPU.
//
// Render() projects every live Gaussian (EWA Jacobian, the scene's low-pass
// dilation (GaussianScene::low_pass), opacity-aware extent), bins them into 16x16 tiles, sorts each
// tile by depth and composites front to back (alpha clamped to 0.99,
// contributions under 1/255 skipped, a pixel stops once transmittance < 1e-4).
// Time t' scales opacity by exp(-0.5 ((t' - t) / (sigma + 1))^2) and moves
// instance Gaussians from canonical space by the instance's box at t'
// (linear centre, slerp rotation between the two nearest boxes; before the
// first box or after the last, the end box is held). A scene with colour
// gradients shades its first three channels across each Gaussian
// (GaussianScene::colour_gradients, splat_projection.h). Through a
// rolling-shutter camera each Gaussian is projected whole from the pose (and
// with the actors at the time) of the line its centre is read on: found by
// projecting it from the middle of the readout, then once more from the line
// that gives (one fixed-point step).
#ifndef POINTFORWARD_ENGINE_RENDER_RASTERIZER_H_
#define POINTFORWARD_ENGINE_RENDER_RASTERIZER_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "common/geometry.h"
#include "engine/camera/camera_model.h"
#include "engine/render/gaussian_scene.h"

namespace pf {

// A rolling-shutter camera's readout (RenderCamera::rolling_shutter): the
// first line is read at the camera's pose and the render's time, the last at
// world_from_camera_end, readout_us later; the lines between at the pose and
// time the same fraction of the way (InterpolateRigid).
struct RollingShutter {
  enum class Readout { kTopToBottom, kBottomToTop, kLeftToRight, kRightToLeft };
  Readout readout = Readout::kTopToBottom;
  int64_t readout_us = 0;
  Rigid world_from_camera_end;
};

// The fraction of `readout` (0 the first line, 1 the last, clamped) at which
// the line through pixel-space point (x, y) of a width x height image is
// read: line k of n at k / (n - 1), its centre at k + 0.5. In the precision
// of T (float for the rasterizer, double for reconstruction).
template <typename T>
T ReadoutFractionOf(RollingShutter::Readout readout, int width, int height, T x, T y) {
  const T rows = static_cast<T>(height - 1 > 0 ? height - 1 : 1);
  const T columns = static_cast<T>(width - 1 > 0 ? width - 1 : 1);
  const T half = static_cast<T>(0.5);
  T f = 0;
  switch (readout) {
    case RollingShutter::Readout::kTopToBottom:
      f = (y - half) / rows;
      break;
    case RollingShutter::Readout::kBottomToTop:
      f = 1 - (y - half) / rows;
      break;
    case RollingShutter::Readout::kLeftToRight:
      f = (x - half) / columns;
      break;
    case RollingShutter::Readout::kRightToLeft:
      f = 1 - (x - half) / columns;
      break;
  }
  return f < 0 ? T(0) : (T(1) < f ? T(1) : f);
}

// A camera to render through: its model and pose (of the first line read,
// with a rolling shutter).
struct RenderCamera {
  CameraModel model;
  Rigid world_from_camera;
  std::optional<RollingShutter> rolling_shutter;
};

// A per-render change to one actor.
struct ActorEdit {
  enum class Kind { kRemove, kTrajectory };
  Kind kind = Kind::kRemove;
  std::string instance_id;      // InstanceTrack::id.
  std::vector<TrackBox> boxes;  // kTrajectory: the new track, sorted by time.
};

struct RenderOptions {
  bool features = true;      // Fill RenderBuffers::features.
  bool depth = true;         // Fill depth.
  bool instance = true;      // Fill instance ids.
  float near_plane = 0.01f;  // Gaussians closer than this (z, metres) are culled.
};

// Counters of one render, for the benchmark.
struct RasterStats {
  int64_t gaussians_visible = 0;   // Projected and inside the image.
  int64_t pairs_tested = 0;        // Gaussian-pixel pairs evaluated.
  int64_t pairs_contributing = 0;  // Pairs that changed the pixel.
  // Wall milliseconds of Render()'s passes on the CPU (0 from a GPU):
  // projection, depth sort and binning, compositing with the outputs' writes.
  double project_ms = 0;
  double sort_bin_ms = 0;
  double composite_ms = 0;
};

// Per-pixel outputs, row-major [H, W, ...].
struct RenderBuffers {
  int width = 0;
  int height = 0;
  int channels = 0;             // N_c of the scene.
  std::vector<float> features;  // [H, W, C] premultiplied by alpha (empty if not asked)
  std::vector<float> rgb;       // [H, W, 3] premultiplied by alpha
  std::vector<float> alpha;     // [H, W]
  // [H, W] expected z depth normalised by alpha: sum(w_i z_i) / sum(w_i);
  // 0 where alpha == 0.
  std::vector<float> depth;
  std::vector<uint32_t> instance;  // [H, W] owner of the largest contributor; 0 background/empty
  RasterStats stats;
};

// What Render() (and ComputeCompositingWeights()) require of a scene, checked
// in O(n) without reading the values: num_channels in [3, 256], sh_degree in
// [-1, 3], fewer than 2^32 Gaussians, every array of the size size() implies,
// every owner an instance of the scene. INVALID_ARGUMENT naming the field.
absl::Status CheckRenderable(const GaussianScene& scene);

// Most pixels one render may have (2^31): beyond, its buffers' sizes no
// longer fit the rasterizer's indices.
inline constexpr int64_t kMaxRenderPixels = int64_t{1} << 31;

// Renders `scene` through `camera` at scene time `timestamp_us` with `edits`
// applied. INVALID_ARGUMENT if an edit names an unknown instance or the
// camera has no pixels or more than kMaxRenderPixels. Deterministic for the same input and thread
// count; uses DefaultThreadPool().
absl::StatusOr<RenderBuffers> Render(const GaussianScene& scene, const RenderCamera& camera,
                                     int64_t timestamp_us, const std::vector<ActorEdit>& edits,
                                     const RenderOptions& options = {});

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RENDER_RASTERIZER_H_
