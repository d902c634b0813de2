// What one render needs besides the Gaussians, shared by the CPU rasterizer
// (rasterizer.cc) and the CUDA one (cuda_rasterizer.cu): the camera as the
// projection reads it and, per owner (0 background, k instance k), the
// camera-from-owner transform at the render's time with the actor edits
// applied, the camera centre in the owner's frame, and whether it is drawn.
#ifndef POINTFORWARD_ENGINE_RENDER_RASTER_FRAME_H_
#define POINTFORWARD_ENGINE_RENDER_RASTER_FRAME_H_

#include <cstdint>
#include <vector>

#include "absl/status/status.h"
#include "engine/render/gaussian_scene.h"
#include "engine/render/rasterizer.h"
#include "engine/render/splat_projection.h"

namespace pf::raster {

// A rigid transform in float: p' = r * p + t, r row-major.
struct Transform {
  float r[9];
  float t[3];
};

struct RenderFrame : ProjectionCamera {
  int tiles_x = 0, tiles_y = 0;
  std::vector<Transform> camera_from_owner;  // [K+1]
  std::vector<float> eye_in_owner;           // [K+1, 3]
  std::vector<uint8_t> owner_live;           // [K+1]
};

// Fills `frame` for rendering a scene with `instances` (and time origin
// `time_origin_us`) through `camera` at `timestamp_us` with `edits`.
// INVALID_ARGUMENT if the camera has no pixels or more than
// kMaxRenderPixels, or an edit names an unknown instance or gives a
// trajectory without boxes.
absl::Status SetUpRenderFrame(const std::vector<InstanceTrack>& instances, int64_t time_origin_us,
                              const RenderCamera& camera, int64_t timestamp_us,
                              const std::vector<ActorEdit>& edits, float near_plane,
                              RenderFrame* frame);

}  // namespace pf::raster

#endif  // POINTFORWARD_ENGINE_RENDER_RASTER_FRAME_H_
