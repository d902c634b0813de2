// A spinning LiDAR for the synthetic scene: beams at fixed elevations swept
// over the full azimuth circle, each ray cast into the scene at one time (no
// rolling shutter). Points come back in the sensor frame (x forward, y left,
// z up) with an intensity from the surface's brightness and incidence angle.
#ifndef POINTFORWARD_ENGINE_SYNTH_SYNTH_LIDAR_H_
#define POINTFORWARD_ENGINE_SYNTH_SYNTH_LIDAR_H_

#include <cstdint>
#include <vector>

#include "common/geometry.h"
#include "engine/synth/synth_ray_caster.h"

namespace pf {

struct LidarConfig {
  int beams = 32;
  int azimuths = 1024;
  double min_elevation_deg = -25.0;
  double max_elevation_deg = 10.0;
  double max_range = 80.0;  // Metres; farther surfaces give no return.
};

// One sweep. Rays without a return are left out.
struct LidarPoints {
  std::vector<float> points;      // [N, 4] x, y, z (sensor frame, metres), intensity in [0, 1]
  std::vector<int32_t> instance;  // [N] Vehicle::instance_id hit, 0 for the static world
  size_t size() const { return instance.size(); }
};

// Returns the unit direction (sensor frame) of beam `beam` at azimuth index
// `azimuth` (0 is straight ahead, increasing to the left).
Vec3 LidarBeamDirection(const LidarConfig& config, int beam, int azimuth);

// Casts every beam of one sweep from `world_from_sensor` into `snapshot`.
// Points are ordered by azimuth, then beam.
LidarPoints SimulateLidar(const SceneSnapshot& snapshot, const Rigid& world_from_sensor,
                          const LidarConfig& config = {});

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_SYNTH_SYNTH_LIDAR_H_
