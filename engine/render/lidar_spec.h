// A spinning LiDAR described by its beams: the rays of one sweep, the sweep
// a scene renders along them (a point record in the clip's LiDAR format and
// a range image), and the beams estimated from a recorded sweep.
//
// Sensor frame: x forward, y left, z up. Column k of a sweep (k = 0 ..
// columns - 1) fires at azimuth 180 - (k + 0.5) x azimuth_resolution_deg
// degrees from x towards y, at sweep fraction (k + 0.5) / columns: the sensor
// spins clockwise seen from above, starting behind it, so a range image reads
// like a panorama (left of the sensor left of the middle, straight ahead in
// the middle). Row b is beam b of `beam_elevations_deg`, in the order given.
#ifndef POINTFORWARD_ENGINE_RENDER_LIDAR_SPEC_H_
#define POINTFORWARD_ENGINE_RENDER_LIDAR_SPEC_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "engine/render/gaussian_scene.h"
#include "engine/render/lidar_render.h"

namespace pf {

struct LidarSpec {
  std::vector<double> beam_elevations_deg;  // One per beam, each in (-90, 90).
  double azimuth_resolution_deg = 0.2;      // Between columns; 360 / it columns.
  double rotation_hz = 10;                  // Sweeps per second.
  double max_range_m = 250;                 // Farther: no return.
};

// OK, or INVALID_ARGUMENT naming the member under `field` ("lidars[0].spec"):
// 1-1024 beams, elevations finite in (-90, 90), a resolution in [0.01, 10]
// degrees, a rate in (0, 100] Hz, a range in (0, 10000] m.
absl::Status CheckLidarSpec(const LidarSpec& spec, const std::string& field);

// The number of columns of a sweep: 360 / azimuth_resolution_deg, rounded.
int LidarColumns(const LidarSpec& spec);

// The rays of one sweep, row by row (beam-major): ray b x columns + k is beam
// b at column k. `spec` must pass CheckLidarSpec.
std::vector<LidarRay> LidarSpecRays(const LidarSpec& spec);

// The pose of a sensor moving from the sweep pose's start to its end at
// `fraction` of the sweep: centres linear, rotations slerped.
Rigid SweepPoseAt(const LidarSweepPose& pose, double fraction);

// One rendered sweep: a return per ray of LidarSpecRays(spec).
struct RenderedSweep {
  LidarSpec spec;
  LidarSweepPose pose;
  std::vector<LidarReturn> returns;  // Beam-major, rows x columns.
  double render_seconds = 0;
  int64_t hits = 0;
};

// Renders `scene` along every ray of `spec` from a sensor moving over `pose`,
// actors changed by `edits` (RenderLidarRays, max range from the spec).
// Errors are CheckLidarSpec's under `field` and the render's.
absl::StatusOr<RenderedSweep> RenderLidarSweep(const GaussianScene& scene, const LidarSpec& spec,
                                               const LidarSweepPose& pose,
                                               const std::vector<ActorEdit>& edits = {},
                                               const std::string& field = "spec");

// Writes the sweep's returns to `path` as the clip's LiDAR record
// (float32 little-endian x, y, z, intensity per return; misses left out),
// atomically. Points are in the sensor frame at the sweep's start (the
// pose a clip's LidarSweep.world_from_sensor gives): each return placed
// along its ray from the sensor where it was when the ray fired, then
// brought into that frame. The intensity is the return's (LidarReturn: the
// scene's LiDAR intensity channel, 0 for a scene without one).
absl::Status WriteSweepPoints(const std::string& path, const RenderedSweep& sweep);

// Writes the sweep as a range image EXR to `path`, atomically: rows x
// columns (row b = beam b, column k as above), float channels `range`
// (metres along the ray, 0 without a return), `intensity` (as above, 0
// without a return) and
// `hit` (1 or 0); header attributes pf:beamElevationsDeg (float[]),
// pf:azimuthResolutionDeg, pf:rotationHz, pf:maxRangeM (double),
// pf:worldFromSensorStart and pf:worldFromSensorEnd (m44d, row-major
// column-vector convention), pf:timestampUs (string, the sweep's start).
absl::Status WriteRangeImageExr(const std::string& path, const RenderedSweep& sweep);

// The beams of a spinning LiDAR estimated from one recorded sweep, points in
// its sensor frame (x, y, z per point; at least 1000 within [min_range,
// max_range]): each point's elevation seen from `origin` (the beams' common
// centre in the sensor frame: zero for most logs; PandaSet's head lies
// elsewhere), a histogram at 0.02 degrees, beams at the peaks holding at
// least 0.2 % of the points and 0.15 degrees apart, each refined to the mean
// elevation of the points within half the gap to its neighbours; azimuth
// resolution the median gap between successive azimuths of the points of
// the fullest beam. Sorted from the highest beam down.
struct EstimatedLidarSpec {
  LidarSpec spec;
  std::vector<int64_t> points_per_beam;  // Beside spec.beam_elevations_deg.
  int64_t points = 0;                    // Used, within the range bounds.
  // RMS of each used point's elevation from its beam's, degrees.
  double elevation_rms_deg = 0;
};
absl::StatusOr<EstimatedLidarSpec> EstimateLidarSpec(const std::vector<float>& xyz,
                                                     const Vec3& origin = {}, double min_range = 1,
                                                     double max_range = 250);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RENDER_LIDAR_SPEC_H_
