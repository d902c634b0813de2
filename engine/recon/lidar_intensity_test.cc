// Tests of LiDAR intensity on reconstructed Gaussians: the returns around a
// Gaussian in its owner's frame, the coarser grids between sparse rings.
#include "engine/recon/lidar_intensity.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace pf {
namespace {

// A sweep at `timestamp_us` of rings across a flat road (z = 0): points every
// 2.5 cm in x from 0 to 20 m, rings at y = 0, 1, ..., 4 m; intensity 10 before
// x = 10 m and 50 after (a painted band).
LidarSweepData RoadSweep(int64_t timestamp_us) {
  LidarSweepData sweep;
  sweep.timestamp_us = timestamp_us;
  for (int ring = 0; ring <= 4; ++ring) {
    for (int i = 0; i <= 800; ++i) {
      const double x = 0.025 * i;
      sweep.points.insert(sweep.points.end(), {float(x), float(ring), 0.f});
      sweep.intensities.push_back(x < 10 ? 10.f : 50.f);
    }
  }
  return sweep;
}

GaussianScene Gaussians(const std::vector<Vec3>& means, const std::vector<uint32_t>& owners) {
  GaussianScene scene;
  scene.num_channels = 4;
  scene.Resize(means.size());
  for (size_t i = 0; i < means.size(); ++i) {
    for (int a = 0; a < 3; ++a) scene.means[3 * i + a] = float(means[i][a]);
    scene.owners[i] = owners[i];
    scene.features[4 * i + 3] = -1.f;  // Overwritten, also where nothing is near.
  }
  return scene;
}

float Intensity(const GaussianScene& scene, size_t i) { return scene.features[4 * i + 3]; }

TEST(LidarIntensity, AGaussianTakesTheReturnsAroundItAndTheCoarseGridsBetweenRings) {
  const LidarSweepData road = RoadSweep(0);
  LidarSweepData unknown = RoadSweep(0);  // No intensities: left out.
  unknown.intensities.clear();
  GaussianScene scene = Gaussians({{3, 2, 0},      // On a ring, in the first band.
                                   {15, 1, 0.05},  // On a ring, in the second, 5 cm up.
                                   {5, 2.5, 0},    // Between rings: the 0.8 m grid.
                                   {5, 30, 0}},    // Beyond every grid's reach.
                                  {0, 0, 0, 0});
  const LidarIntensityStats stats = FuseLidarIntensity({&road, &unknown}, 3, &scene);
  EXPECT_EQ(stats.points, 5 * 801);
  EXPECT_EQ(stats.assigned, 3);
  EXPECT_EQ(stats.finest, 2);
  EXPECT_FLOAT_EQ(Intensity(scene, 0), 10.f);
  EXPECT_FLOAT_EQ(Intensity(scene, 1), 50.f);
  EXPECT_FLOAT_EQ(Intensity(scene, 2), 10.f);
  EXPECT_EQ(Intensity(scene, 3), 0.f);
  // Across the band's edge (x = 9.8 to 10.2 m, every centimetre) the finest
  // grid rises from one band's intensity to the other's over about a cell.
  std::vector<Vec3> across;
  for (int k = 0; k <= 40; ++k) across.push_back({9.8 + 0.01 * k, 1, 0});
  GaussianScene edge = Gaussians(across, std::vector<uint32_t>(across.size(), 0));
  FuseLidarIntensity({&road}, 3, &edge);
  EXPECT_FLOAT_EQ(Intensity(edge, 0), 10.f);
  EXPECT_FLOAT_EQ(Intensity(edge, 40), 50.f);
  int between = 0;
  for (size_t k = 1; k < across.size(); ++k) {
    EXPECT_GE(Intensity(edge, k), Intensity(edge, k - 1)) << k;
    between += Intensity(edge, k) > 10.5f && Intensity(edge, k) < 49.5f;
  }
  EXPECT_GE(between, 3);
  EXPECT_LE(between, 8);
}

TEST(LidarIntensity, AnActorsReturnsGoToItsGaussiansInItsCanonicalFrame) {
  // An actor 2 m long and wide, 1.5 m high, on the road at x = 3 at t = 0
  // and at x = 13 at t = 1 s; the sweep at 1 s sees its side (intensity 99)
  // at x = 12.5-13.5, y = 1, z = 0.5-1.
  InstanceTrack track;
  track.id = "car";
  track.boxes.push_back({0, {3, 2, 0.75}, {2, 2, 1.5}, Quat{}});
  track.boxes.push_back({1000000, {13, 2, 0.75}, {2, 2, 1.5}, Quat{}});
  LidarSweepData sweep = RoadSweep(1000000);
  for (int i = 0; i <= 20; ++i) {
    for (int k = 0; k <= 10; ++k) {
      sweep.points.insert(sweep.points.end(),
                          {float(12.5 + 0.05 * i), 1.05f, float(0.5 + 0.05 * k)});
      sweep.intensities.push_back(99.f);
    }
  }
  // The actor's Gaussian where the side is in its canonical frame (x = 3),
  // and a static one at the side's world place at 1 s (x = 13): the actor's
  // returns reach the first, only the road's the second.
  GaussianScene scene = Gaussians({{3, 1.05, 0.75}, {13, 1.05, 0.75}}, {1, 0});
  scene.instances.push_back(track);
  const LidarIntensityStats stats = FuseLidarIntensity({&sweep}, 3, &scene);
  EXPECT_EQ(stats.points, 5 * 801 + 21 * 11);
  EXPECT_FLOAT_EQ(Intensity(scene, 0), 99.f);
  EXPECT_FLOAT_EQ(Intensity(scene, 1), 50.f);
}

}  // namespace
}  // namespace pf
