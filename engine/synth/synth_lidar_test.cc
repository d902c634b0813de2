// Tests of the synthetic LiDAR: beams, and points that lie on surfaces.
#include "engine/synth/synth_lidar.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace pf {
namespace {

TEST(SynthLidar, BeamDirectionsSpanTheConfiguredFan) {
  const LidarConfig config;
  const double deg = std::numbers::pi / 180;
  const Vec3 first = LidarBeamDirection(config, 0, 0);
  EXPECT_NEAR(first.x, std::cos(25 * deg), 1e-12);
  EXPECT_NEAR(first.y, 0, 1e-12);
  EXPECT_NEAR(first.z, -std::sin(25 * deg), 1e-12);
  const Vec3 left = LidarBeamDirection(config, config.beams - 1, config.azimuths / 4);
  EXPECT_NEAR(left.x, 0, 1e-12);
  EXPECT_NEAR(left.y, std::cos(10 * deg), 1e-12);
  EXPECT_NEAR(left.z, std::sin(10 * deg), 1e-12);
}

TEST(SynthLidar, PointsLieOnTheSurfacesTheyHit) {
  SynthOptions options;
  options.seed = 3;
  auto scene = GenerateSynthScene(options);
  ASSERT_TRUE(scene.ok());
  const double t = 0.5;
  const SceneSnapshot snapshot = SnapshotAt(*scene, t);
  const Rigid world_from_sensor = scene->WorldFromLidar(t);
  const LidarConfig config;
  const LidarPoints sweep = SimulateLidar(snapshot, world_from_sensor, config);
  ASSERT_GT(sweep.size(), 10000u);
  ASSERT_EQ(sweep.points.size(), 4 * sweep.size());
  int ground = 0, vehicle = 0;
  for (size_t i = 0; i < sweep.size(); ++i) {
    const Vec3 p{sweep.points[4 * i], sweep.points[4 * i + 1], sweep.points[4 * i + 2]};
    const double range = Norm(p);
    ASSERT_LE(range, config.max_range + 1e-3);
    ASSERT_GT(range, 0.5);
    const float intensity = sweep.points[4 * i + 3];
    ASSERT_GE(intensity, 0.f);
    ASSERT_LE(intensity, 1.f);
    // Re-cast the ray through the point: the same surface at the same range.
    const Vec3 dir = world_from_sensor.rotation * (p / range);
    const RayHit hit = CastRay(snapshot, world_from_sensor.translation, dir);
    ASSERT_TRUE(hit.hit);
    ASSERT_NEAR(hit.distance, range, 1e-4 * range);
    ASSERT_EQ(hit.instance, sweep.instance[i]);
    const Vec3 world = world_from_sensor * p;
    ASSERT_GT(world.z, -1e-3);
    if (std::abs(world.z) < 1e-3) ++ground;
    if (sweep.instance[i] > 0) ++vehicle;
  }
  EXPECT_GT(ground, 1000);
  EXPECT_GT(vehicle, 50);
}

TEST(SynthLidar, GroundReturnsMatchTheBeamGeometry) {
  // With no boxes, every downward beam hits the plane z = 0 at range
  // height / sin(-elevation), and upward beams return nothing.
  SynthOptions options;
  auto scene = GenerateSynthScene(options);
  ASSERT_TRUE(scene.ok());
  scene->boxes.clear();
  scene->vehicles.clear();
  const SceneSnapshot snapshot = SnapshotAt(*scene, 0);
  const Rigid pose = scene->WorldFromLidar(0);
  LidarConfig config;
  config.azimuths = 64;
  const LidarPoints sweep = SimulateLidar(snapshot, pose, config);
  int downward = 0;
  for (int b = 0; b < config.beams; ++b) {
    const Vec3 d = LidarBeamDirection(config, b, 0);
    if (d.z < 0 && pose.translation.z / -d.z < config.max_range) ++downward;
  }
  ASSERT_EQ(sweep.size(), static_cast<size_t>(downward * config.azimuths));
  for (size_t i = 0; i < sweep.size(); ++i) {
    EXPECT_NEAR(sweep.points[4 * i + 2], -pose.translation.z, 1e-4);
  }
}

}  // namespace
}  // namespace pf
