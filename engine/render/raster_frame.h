// What one render needs besides the Gaussians, shared by the CPU rasterizer
// (rasterizer.cc) and the CUDA one (cuda_rasterizer.cu): the camera as the
// projection reads it and, per owner (0 background, k instance k), the
// camera-from-owner transform at the render's time with the actor edits
// applied, the camera centre in the owner's frame, and whether it is drawn.
#ifndef POINTFORWARD_ENGINE_RENDER_RASTER_FRAME_H_
#define POINTFORWARD_ENGINE_RENDER_RASTER_FRAME_H_

#include <cstdint>
#include <optional>
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

// Poses a rolling-shutter frame keeps per owner, at evenly spaced fractions
// of the readout (the first line 0, the last 1); between them, linearly.
inline constexpr int kReadoutSamples = 33;

struct RenderFrame : ProjectionCamera {
  int tiles_x = 0, tiles_y = 0;
  std::vector<Transform> camera_from_owner;  // [K+1]
  std::vector<float> eye_in_owner;           // [K+1, 3]
  std::vector<uint8_t> owner_live;           // [K+1]
  // With a rolling shutter: the readout, and camera_from_owner at the
  // kReadoutSamples fractions of it ([K+1, kReadoutSamples]); empty without.
  std::optional<RollingShutter::Readout> readout;
  std::vector<Transform> readout_camera_from_owner;
};

// The fraction of the readout (0 first line, 1 last) at which the line
// through pixel-space point (x, y) is read.
inline float ReadoutFraction(const RenderFrame& frame, float x, float y) {
  return ReadoutFractionOf<float>(*frame.readout, frame.width, frame.height, x, y);
}

// camera_from_owner of `owner` at readout fraction `f` (a rolling-shutter
// frame's).
inline Transform ReadoutCameraFromOwner(const RenderFrame& frame, uint32_t owner, float f) {
  const float s = f * (kReadoutSamples - 1);
  const int k = s >= kReadoutSamples - 1 ? kReadoutSamples - 2 : static_cast<int>(s);
  const float w = s - static_cast<float>(k);
  const Transform& a = frame.readout_camera_from_owner[owner * kReadoutSamples + k];
  const Transform& b = frame.readout_camera_from_owner[owner * kReadoutSamples + k + 1];
  Transform out;
  for (int j = 0; j < 9; ++j) out.r[j] = a.r[j] + w * (b.r[j] - a.r[j]);
  for (int j = 0; j < 3; ++j) out.t[j] = a.t[j] + w * (b.t[j] - a.t[j]);
  return out;
}

// Projects Gaussian `i` through rolling-shutter `frame` whole from the pose
// (and the actors at the time) of the line its centre is read on: from the
// middle of the readout (else its first or last line), then from the line
// the centre landed on. False when it cannot be seen.
inline bool ProjectSplatAtItsLine(const GaussianScene& scene, size_t i, const RenderFrame& frame,
                                  SplatGeometry* g) {
  const uint32_t owner = scene.owners[i];
  float f = -1;
  for (float guess : {0.5f, 0.f, 1.f}) {
    const Transform cam = ReadoutCameraFromOwner(frame, owner, guess);
    if (ProjectSplatGeometry(scene, i, frame, cam.r, cam.t, g)) {
      f = ReadoutFraction(frame, g->mx, g->my);
      break;
    }
  }
  if (f < 0) return false;
  const Transform cam = ReadoutCameraFromOwner(frame, owner, f);
  return ProjectSplatGeometry(scene, i, frame, cam.r, cam.t, g);
}

// Fills `frame` for rendering a scene with `instances` (and time origin
// `time_origin_us`) through `camera` at `timestamp_us` with `edits` (with a
// rolling shutter, the readout's poses too: the actors at each line's time);
// lifespans fade at that time held within `fade_span`.
// INVALID_ARGUMENT if the camera has no pixels or more than
// kMaxRenderPixels, or an edit names an unknown instance or gives a
// trajectory without boxes.
absl::Status SetUpRenderFrame(const std::vector<InstanceTrack>& instances, int64_t time_origin_us,
                              const FadeSpan& fade_span, const RenderCamera& camera,
                              int64_t timestamp_us, const std::vector<ActorEdit>& edits,
                              float near_plane, RenderFrame* frame);

}  // namespace pf::raster

#endif  // POINTFORWARD_ENGINE_RENDER_RASTER_FRAME_H_
