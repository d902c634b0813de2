// Tests of depth per view: LiDAR projection, completion and the far layer.
#include "worker/engine/recon/view_depth.h"

#include <gtest/gtest.h>

#include <cmath>

namespace pf {
namespace {

const CameraModel kCamera(40, 30, 40, 40, 20, 15);

TEST(ViewDepth, ProjectPointsKeepsTheNearestPerPixel) {
  // Identity pose: camera frame = world. (1, 0.5, 10) projects to
  // u = 40 * 0.1 + 20 = 24, v = 40 * 0.05 + 15 = 17.
  const std::vector<float> points = {1, 0.5f, 10, 2, 1, 20, 0, 0, -5};
  const ImageF depth = ProjectPoints(points, kCamera, Rigid{});
  EXPECT_FLOAT_EQ(depth.at(24, 17), 10.f);  // (2, 1, 20) lands on the same pixel, behind.
  EXPECT_FLOAT_EQ(depth.at(20, 15), 0.f);   // The point behind the camera is dropped.
}

TEST(ViewDepth, CompletionFillsNearbyPixelsOnlyAndPrefersTheNearerSurface) {
  ImageF sparse(40, 30, 1);
  sparse.at(10, 10) = 5.f;
  sparse.at(12, 10) = 50.f;
  CompletionOptions options;
  options.max_distance_px = 4;
  const ImageF dense = CompleteDepth(sparse, options);
  EXPECT_FLOAT_EQ(dense.at(10, 10), 5.f);  // Measured values kept.
  EXPECT_FLOAT_EQ(dense.at(12, 10), 50.f);
  EXPECT_FLOAT_EQ(dense.at(9, 12), 5.f);    // Nearest measurement.
  EXPECT_FLOAT_EQ(dense.at(11, 10), 5.f);   // Tie between both: the nearer surface.
  EXPECT_FLOAT_EQ(dense.at(14, 12), 50.f);  // 2.8 px from (12,10), 4.5 from (10,10).
  EXPECT_FLOAT_EQ(dense.at(30, 25), 0.f);   // Too far from any measurement.
  EXPECT_FLOAT_EQ(dense.at(10, 15), 0.f);   // 5 px away > 4.
}

TEST(ViewDepth, AutomaticRadiusGrowsWithTheImage) {
  EXPECT_EQ(CompletionRadius(144), 12);
  EXPECT_EQ(CompletionRadius(1216), 49);
  ImageF sparse(100, 1216, 1);
  sparse.at(50, 100) = 8.f;
  const ImageF dense = CompleteDepth(sparse, {});  // Automatic radius 49.
  EXPECT_FLOAT_EQ(dense.at(50, 140), 8.f);
  EXPECT_FLOAT_EQ(dense.at(50, 160), 0.f);
}

TEST(ViewDepth, LidarPointsInABoxMoveWithItToTheImageTime) {
  InstanceTrack car;
  car.boxes = {{0, {10, 0, 1}, {4, 2, 2}, Quat{}}, {1000000, {20, 0, 1}, {4, 2, 2}, Quat{}}};
  LidarSweepData sweep;
  sweep.timestamp_us = 0;
  sweep.points = {11, 0.5f, 1.5f,  // In the car at t = 0.
                  30, 0,    0};    // Ground.
  const std::vector<float> moved = PointsAtTime(sweep, {car}, 500000);
  EXPECT_NEAR(moved[0], 16.f, 1e-5);  // The box moved 5 m along x in 0.5 s.
  EXPECT_NEAR(moved[1], 0.5f, 1e-5);
  EXPECT_NEAR(moved[2], 1.5f, 1e-5);
  EXPECT_FLOAT_EQ(moved[3], 30.f);  // Static point stays.
}

TEST(ViewDepth, NearestSweepInTime) {
  std::vector<LidarSweepData> sweeps(3);
  sweeps[0].timestamp_us = 0;
  sweeps[1].timestamp_us = 100;
  sweeps[2].timestamp_us = 300;
  EXPECT_EQ(NearestSweep(sweeps, 180), 1);
  EXPECT_EQ(NearestSweep(sweeps, 260), 2);
  EXPECT_EQ(NearestSweep({}, 0), -1);
}

TEST(ViewDepth, FarLayerPixelsLieOnTheSphere) {
  ContextView view;
  view.camera = kCamera;
  view.world_from_camera.translation = {1, 2, 3};
  view.rgb = ImageF(40, 30, 3);
  FarLayer far;
  far.center = {1, 2, 3};
  far.radius = 100;
  // Centre pixel looks straight along z: depth = radius.
  EXPECT_NEAR(FarDepth(far, kCamera, view.world_from_camera, 20, 15), 100.0, 1e-9);
  ImageF measured(40, 30, 1);
  measured.at(5, 5) = 7.f;
  const ViewDepth depth = WithFarLayer(measured, /*from_lidar=*/true, view, far);
  EXPECT_FLOAT_EQ(depth.depth[5 * 40 + 5], 7.f);
  EXPECT_EQ(depth.source[5 * 40 + 5], uint8_t(DepthSource::kLidar));
  // A corner pixel: its ray (x/z, y/z) = (-19.5/40, -14.5/40) hits the sphere
  // at distance 100, so z = 100 / |ray|.
  const double rx = -19.5 / 40, ry = -14.5 / 40;
  EXPECT_TRUE(depth.is_far(0));
  EXPECT_NEAR(depth.depth[0], 100.0 / std::sqrt(1 + rx * rx + ry * ry), 1e-3);
}

TEST(ViewDepth, BehindSourcesFindTheNearestDeeperBackground) {
  // 40 x 30: columns < 20 at 5 m (foreground), the rest at 20 m, except
  // column 39, far layer at 500 m; row 0 is a slant rising 1 % per pixel
  // (no occlusion: under the 10 % jump within every radius used here).
  ViewDepth depth;
  depth.width = 40;
  depth.height = 30;
  depth.depth.assign(40 * 30, 5.f);
  depth.source.assign(40 * 30, uint8_t(DepthSource::kDepthMap));
  for (int y = 0; y < 30; ++y) {
    for (int x = 20; x < 40; ++x) depth.depth[y * 40 + x] = 20.f;
    depth.depth[y * 40 + 39] = 500.f;
    depth.source[y * 40 + 39] = uint8_t(DepthSource::kFar);
  }
  for (int x = 0; x < 8; ++x) depth.depth[x] = 5.f * (1 + 0.01f * x);
  const BehindSources behind = FindBehindSources(depth, 8);
  ASSERT_EQ(behind.radii, (std::vector<int>{1, 2, 4, 8}));
  ASSERT_EQ(behind.sources.size(), 4u);
  const int left_of_edge = 15 * 40 + 17;  // 3 px from the 20 m background.
  EXPECT_EQ(behind.sources[0][left_of_edge], -1);
  EXPECT_EQ(behind.sources[1][left_of_edge], -1);
  const int32_t found = behind.sources[2][left_of_edge];
  ASSERT_GE(found, 0);
  EXPECT_FLOAT_EQ(depth.depth[found], 20.f);
  EXPECT_LE(std::abs(found % 40 - 17), 4);
  EXPECT_LE(std::abs(found / 40 - 15), 4);
  // At radius 8 the far layer is not reached yet from column 17 (22 px).
  EXPECT_FLOAT_EQ(depth.depth[behind.sources[3][left_of_edge]], 20.f);
  // Next to the far column, the background is the far layer.
  EXPECT_FLOAT_EQ(depth.depth[behind.sources[0][15 * 40 + 38]], 500.f);
  // Far pixels have nothing behind them; nor has the slant, nor the
  // foreground 10 px from the edge at radius 8.
  for (const std::vector<int32_t>& sources : behind.sources) {
    EXPECT_EQ(sources[15 * 40 + 39], -1);
    EXPECT_EQ(sources[3], -1);
  }
  EXPECT_EQ(behind.sources[3][15 * 40 + 10], -1);
  EXPECT_TRUE(FindBehindSources(depth, 0).sources.empty());
}

TEST(ViewDepth, FarLayerEnclosesCamerasAndMeasurements) {
  std::vector<ContextView> views(2);
  views[0].world_from_camera.translation = {0, 0, 0};
  views[1].world_from_camera.translation = {10, 0, 0};
  const FarLayer far = FarLayerFor(views, {80.f, 120.f}, 50);
  EXPECT_NEAR(far.center.x, 5.0, 1e-12);
  EXPECT_NEAR(far.radius, 2 * (5 + 120), 1e-9);
}

TEST(ViewDepth, MeasuredDepthPrefersTheDepthMap) {
  ContextView view;
  view.camera = kCamera;
  view.depth = ImageF(40, 30, 1);
  view.depth.at(1, 1) = 3.f;
  view.depth.at(2, 1) = std::nanf("");
  LidarSweepData sweep;
  sweep.points = {0, 0, 10};
  bool from_lidar = true;
  const ImageF measured = MeasuredDepth(view, {sweep}, {}, {}, &from_lidar);
  EXPECT_FALSE(from_lidar);
  EXPECT_FLOAT_EQ(measured.at(1, 1), 3.f);
  EXPECT_FLOAT_EQ(measured.at(2, 1), 0.f);  // Non-finite means unknown.
  view.depth = ImageF();
  const ImageF lidar = MeasuredDepth(view, {sweep}, {}, {}, &from_lidar);
  EXPECT_TRUE(from_lidar);
  EXPECT_FLOAT_EQ(lidar.at(20, 15), 10.f);
  EXPECT_FLOAT_EQ(lidar.at(22, 16), 10.f);  // Completed around the measurement.
}

}  // namespace
}  // namespace pf
