// The LiDAR a scene renders against a recorded sweep: for every recorded
// point, the scene is rendered along the same ray from the sweep's sensor
// at the sweep's time (RenderLidarRays, render/lidar_render.h), and the
// returns are compared with the recorded ones.
#ifndef POINTFORWARD_ENGINE_RECON_LIDAR_EVAL_H_
#define POINTFORWARD_ENGINE_RECON_LIDAR_EVAL_H_

#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "engine/camera/camera_model.h"
#include "engine/recon/view_depth.h"
#include "engine/render/gaussian_scene.h"
#include "engine/render/lidar_render.h"

namespace pf {

// A camera that saw the scene: its model and world_from_camera.
struct SeeingCamera {
  CameraModel model;
  Rigid world_from_camera;
};

struct LidarSweepFigures {
  int64_t timestamp_us = 0;
  int64_t sweep_points = 0;  // Recorded returns within max_range of the sensor.
  // Those of them inside some CONTEXT camera's image (in front of it, in
  // its frame; occlusion not tested): the rays measured below.
  int64_t points = 0;
  double hit_share = 0;  // Share of them the render also returns.
  // |rendered - recorded| range (m) over the rays both return.
  double range_error_median = 0, range_error_p90 = 0;
  // Shares of the rays both return whose rendered return is nearer (early)
  // or farther (late) than the recorded one by more than kSignedTolerance:
  // early returns are surfaces the scene has where the LiDAR saw through
  // (or rays cast from the wrong place), late ones surfaces it lacks.
  double early_share = 0, late_share = 0;
  // Chamfer distance (m): the mean of the two directions' mean distances
  // from each point to the other cloud's nearest (rendered returns against
  // recorded ones; each distance capped at kChamferCap).
  double chamfer = 0;
  double render_seconds = 0;  // RenderLidarRays' wall time.
};

inline constexpr double kChamferCap = 5.0;

// The tolerance of early_share and late_share: the larger of 0.5 m and 5 % of
// the recorded range.
inline double SignedTolerance(double recorded_range) {
  return recorded_range * 0.05 > 0.5 ? recorded_range * 0.05 : 0.5;
}

// The means over `sweeps` of hit_share, the range errors, the early and late
// shares and chamfer;
// points, sweep_points and render_seconds summed; timestamp_us 0. All zero
// for none.
LidarSweepFigures MeanLidarFigures(const std::vector<LidarSweepFigures>& sweeps);

// Renders `scene` along the rays of `sweep`'s points (a sensor at rest at the
// sweep's time) that one of `cameras` had in its image, and measures it
// against them: the rest of the sweep (behind a forward rig, say) is nothing
// the scene could know. Points farther than options.max_range from the
// sensor are left out. FAILED_PRECONDITION when no point is left.
absl::StatusOr<LidarSweepFigures> EvaluateLidarRender(const GaussianScene& scene,
                                                      const LidarSweepData& sweep,
                                                      const std::vector<SeeingCamera>& cameras,
                                                      const LidarRenderOptions& options = {});

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_LIDAR_EVAL_H_
