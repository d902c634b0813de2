// The synthetic spinning LiDAR (see synth_lidar.h).
#include "engine/synth/synth_lidar.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "common/thread_pool.h"
#include "engine/synth/synth_shading.h"

namespace pf {
namespace {

// Returns the distance from `p` to box [lo, hi] (0 inside).
double DistanceToBox(const Vec3& p, const Vec3& lo, const Vec3& hi) {
  Vec3 d;
  for (int a = 0; a < 3; ++a) d[a] = std::max({lo[a] - p[a], 0.0, p[a] - hi[a]});
  return Norm(d);
}

}  // namespace

Vec3 LidarBeamDirection(const LidarConfig& config, int beam, int azimuth) {
  constexpr double kDeg = std::numbers::pi / 180.0;
  const double elevation =
      config.beams == 1
          ? config.min_elevation_deg * kDeg
          : (config.min_elevation_deg +
             (config.max_elevation_deg - config.min_elevation_deg) * beam / (config.beams - 1)) *
                kDeg;
  const double yaw = 2 * std::numbers::pi * azimuth / config.azimuths;
  return {std::cos(elevation) * std::cos(yaw), std::cos(elevation) * std::sin(yaw),
          std::sin(elevation)};
}

LidarPoints SimulateLidar(const SceneSnapshot& snapshot, const Rigid& world_from_sensor,
                          const LidarConfig& config) {
  const Vec3 origin = world_from_sensor.translation;
  // Only primitives within range can return.
  Candidates near;
  for (size_t i = 0; i < snapshot.scene->boxes.size(); ++i) {
    const StaticBox& box = snapshot.scene->boxes[i];
    if (DistanceToBox(origin, box.lo, box.hi) < config.max_range) {
      near.statics.push_back(static_cast<int>(i));
    }
  }
  for (size_t i = 0; i < snapshot.vehicles.size(); ++i) {
    const PlacedVehicle& v = snapshot.vehicles[i];
    if (DistanceToBox(origin, v.lo, v.hi) < config.max_range) {
      near.vehicles.push_back(static_cast<int>(i));
    }
  }

  // Cast into fixed slots (one per ray), then compact: the order does not
  // depend on the threads.
  const int64_t rays = static_cast<int64_t>(config.beams) * config.azimuths;
  std::vector<float> slots(static_cast<size_t>(rays) * 4);
  std::vector<int32_t> slot_instance(static_cast<size_t>(rays), -1);  // -1: no return.
  DefaultThreadPool().ParallelFor(0, config.azimuths, 64, [&](int64_t begin, int64_t end) {
    for (int64_t a = begin; a < end; ++a) {
      for (int b = 0; b < config.beams; ++b) {
        const Vec3 local_dir = LidarBeamDirection(config, b, static_cast<int>(a));
        const Vec3 dir = world_from_sensor.rotation * local_dir;
        const RayHit hit = CastRay(snapshot, near, origin, dir, config.max_range);
        if (!hit.hit) continue;
        const size_t slot = static_cast<size_t>(a) * config.beams + b;
        const Vec3 p = local_dir * hit.distance;
        const double incidence = std::abs(Dot(hit.normal, dir));
        slots[slot * 4 + 0] = static_cast<float>(p.x);
        slots[slot * 4 + 1] = static_cast<float>(p.y);
        slots[slot * 4 + 2] = static_cast<float>(p.z);
        slots[slot * 4 + 3] = static_cast<float>(
            std::clamp(Luminance(hit.albedo) * (0.3 + 0.7 * incidence), 0.0, 1.0));
        slot_instance[slot] = hit.instance;
      }
    }
  });
  LidarPoints out;
  for (size_t slot = 0; slot < slot_instance.size(); ++slot) {
    if (slot_instance[slot] < 0) continue;
    out.points.insert(out.points.end(), slots.begin() + slot * 4, slots.begin() + slot * 4 + 4);
    out.instance.push_back(slot_instance[slot]);
  }
  return out;
}

}  // namespace pf
