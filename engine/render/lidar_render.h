// LiDAR returns rendered from a Gaussian scene: the range along each ray of a
// spinning LiDAR where the scene's accumulated opacity is at least 0.5.
//
// Rays are grouped into azimuth sectors; each sector is rendered by the
// rasterizer as a pinhole view looking along the sector's middle azimuth
// (at the mean elevation of its rays), at the sensor pose and scene time of
// the sector's mean time in the sweep (poses interpolated between the sweep's
// start and end: linear centre, slerp rotation), so moving actors are at that
// time. A ray reads the pixel it lands in: a return when alpha >= min_alpha
// and the expected depth (sum w z / sum w) puts it within max_range; its
// range is that depth over the ray's z in the view, the depth bilinear
// between the 4 pixel centres around the ray where they are returns within
// 3 % of each other (one surface), else the pixel's own. The expected depth
// mixes surfaces across a depth edge inside one pixel (a return there lies
// between them); a median depth is not rendered. A return's intensity is the
// scene's LiDAR intensity channel (GaussianScene::lidar_intensity_channel)
// blended at the ray's pixel, over its alpha; 0 for a scene without one.
#ifndef POINTFORWARD_ENGINE_RENDER_LIDAR_RENDER_H_
#define POINTFORWARD_ENGINE_RENDER_LIDAR_RENDER_H_

#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "common/geometry.h"
#include "engine/render/gaussian_scene.h"
#include "engine/render/rasterizer.h"

namespace pf {

// One ray in the sensor frame (x forward, y left, z up).
struct LidarRay {
  Vec3 direction;             // Need not be unit length; not zero.
  double sweep_fraction = 0;  // When in the sweep the ray fires, [0, 1].
};

// Where the sensor is during the sweep.
struct LidarSweepPose {
  Rigid world_from_sensor_start, world_from_sensor_end;
  int64_t start_us = 0, end_us = 0;  // Scene times of the sweep's start and end.
};

struct LidarRenderOptions {
  int sectors = 24;              // Azimuth sectors over the full circle, [4, 720].
  double pixels_per_degree = 8;  // Resolution of each sector's render, (0, 100].
  double min_alpha = 0.5;        // Accumulated opacity that makes a return.
  double max_range = 250;        // Farther (the far layer, the sky): no return, metres.
};

struct LidarReturn {
  bool hit = false;
  float range = 0;      // Metres along the ray (0 without a return).
  float intensity = 0;  // The scene's LiDAR intensity (0 without a return or channel).
};

// The sensor's pose at `fraction` of the sweep: centre linear, rotation
// slerped between the start and the end.
Rigid SweepPoseAt(const LidarSweepPose& pose, double fraction);

// The return of each ray of `rays`, actors moved or removed by `edits`.
// INVALID_ARGUMENT for a zero direction, a sweep fraction outside [0, 1],
// or options out of range.
absl::StatusOr<std::vector<LidarReturn>> RenderLidarRays(const GaussianScene& scene,
                                                         const std::vector<LidarRay>& rays,
                                                         const LidarSweepPose& pose,
                                                         const LidarRenderOptions& options = {},
                                                         const std::vector<ActorEdit>& edits = {});

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RENDER_LIDAR_RENDER_H_
