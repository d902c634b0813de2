// The LiDAR a scene renders against a recorded sweep: for every recorded
// point, the scene is rendered along the same ray from the sweep's sensor
// at the sweep's time (RenderLidarRays, render/lidar_render.h), and the
// returns are compared with the recorded ones.
#ifndef POINTFORWARD_ENGINE_RECON_LIDAR_EVAL_H_
#define POINTFORWARD_ENGINE_RECON_LIDAR_EVAL_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "engine/camera/camera_model.h"
#include "engine/recon/view_depth.h"
#include "engine/render/gaussian_scene.h"
#include "engine/render/lidar_render.h"
#include "engine/render/lidar_spec.h"

namespace pf {

// A camera that saw the scene: its model and world_from_camera.
struct SeeingCamera {
  CameraModel model;
  Rigid world_from_camera;
};

// The rendered LiDAR's figures over the rays of one beam.
struct LidarBeamFigures {
  double elevation_deg = 0;
  int64_t points = 0;    // Measured rays (recorded returns a camera saw).
  double hit_share = 0;  // Share of them the render also returns.
  double range_error_median = 0, range_error_p90 = 0;  // Over the rays both return.
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

  // Intensity, where the scene has a LiDAR intensity channel and the sweep
  // recorded intensities: over the rays both return on one surface (range
  // error within SignedTolerance), the median |rendered - recorded|, and the
  // same for the best constant (the median of their recorded intensities),
  // the figure to beat. In the clip's units; 0 rays otherwise.
  int64_t intensity_rays = 0;
  double intensity_error_median = 0, intensity_constant_error_median = 0;

  // Where the sweep is one spinning head's (SweepBeams): per beam, from the
  // highest down; empty otherwise, and beams_note says why.
  std::vector<LidarBeamFigures> beams;
  std::string beams_note;
  // Drops, where the sweep is one head's: its (beam, firing azimuth) cells
  // whose ray a camera saw (30 m out) and the shares of them the LiDAR
  // returned nothing for, the render returned nothing for, and where the two
  // agree (both a return or both a drop); cells 0 otherwise.
  int64_t cells = 0;
  double recorded_drop_share = 0, rendered_drop_share = 0, drop_agreement = 0;
};

// The beams of a recorded sweep, when it is one spinning head's: the spec
// EstimateLidarSpec finds from the points in the sensor frame (z up), which
// must place 99 % of them and whose elevation RMS must be under a tenth of the
// smallest gap between beams. INVALID_ARGUMENT saying which test failed
// otherwise (a sweep merged from several sensors, or from a frame not at the
// head).
absl::StatusOr<LidarSpec> SweepBeams(const std::vector<float>& sensor_xyz, double max_range);

inline constexpr double kChamferCap = 5.0;

// The tolerance of early_share and late_share: the larger of 0.5 m and 5 % of
// the recorded range.
inline double SignedTolerance(double recorded_range) {
  return recorded_range * 0.05 > 0.5 ? recorded_range * 0.05 : 0.5;
}

// The means over `sweeps` of hit_share, the range errors, the early and late
// shares and chamfer; of the drop shares over the sweeps with cells; of the
// intensity errors over the sweeps with intensity rays; of each
// beam's figures when every sweep has the same number of beams (empty
// otherwise); points, sweep_points, cells, intensity_rays and render_seconds summed;
// timestamp_us 0. All zero for none.
LidarSweepFigures MeanLidarFigures(const std::vector<LidarSweepFigures>& sweeps);

// Renders `scene` along the rays of `sweep`'s points (a sensor at rest at the
// sweep's time) that one of `cameras` had in its image, and measures it
// against them: the rest of the sweep (behind a forward rig, say) is nothing
// the scene could know. Points farther than options.max_range from the
// sensor are left out. Where the sweep is one head's (SweepBeams), also per
// beam, and the drops: the render along the centre of every (beam, firing
// azimuth) cell a camera saw. FAILED_PRECONDITION when no point is left.
absl::StatusOr<LidarSweepFigures> EvaluateLidarRender(const GaussianScene& scene,
                                                      const LidarSweepData& sweep,
                                                      const std::vector<SeeingCamera>& cameras,
                                                      const LidarRenderOptions& options = {});

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_LIDAR_EVAL_H_
