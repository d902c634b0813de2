// Tests of depth per view: LiDAR projection, completion and the far layer.
#include "engine/recon/view_depth.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "engine/recon/depth_completion.h"

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

TEST(ViewDepth, ProjectPointsDropsAPointOnTheCameraPlane) {
  // (1000, 0, 2e-6) projects to u = 40 * 1000 / 2e-6 = 2e10, beyond int's
  // range (a LiDAR return off the ego body, beside the camera): dropped
  // without a cast (the sanitizer tree would abort on one), the others kept.
  const std::vector<float> points = {1000, 0, 2e-6f, -1000, 5, 2e-6f, 1, 0.5f, 10};
  const ImageF depth = ProjectPoints(points, kCamera, Rigid{});
  int set = 0;
  for (float d : depth.pixels) set += d != 0.f;
  EXPECT_EQ(set, 1);
  EXPECT_FLOAT_EQ(depth.at(24, 17), 10.f);
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
  std::vector<int32_t> sources;
  EXPECT_EQ(CompleteDepth(sparse, options, &sources).pixels, dense.pixels);
  EXPECT_EQ(sources[10 * 40 + 10], 10 * 40 + 10);  // Measured: itself.
  EXPECT_EQ(sources[12 * 40 + 9], 10 * 40 + 10);
  EXPECT_EQ(sources[10 * 40 + 11], 10 * 40 + 10);
  EXPECT_EQ(sources[12 * 40 + 14], 10 * 40 + 12);
  EXPECT_EQ(sources[25 * 40 + 30], -1);
}

// CompleteDepth's contract computed the plain way: every measurement in the
// 3 x 3 cells of max_distance around the pixel's cell, cell by cell in
// raster order and each cell's measurements in raster order; the nearest,
// then the least depth within 1.5 px of its distance, the first on ties.
ImageF CompleteByScanningCells(const ImageF& sparse, int max_distance,
                               std::vector<int32_t>* sources) {
  const int w = sparse.width, h = sparse.height, cell = max_distance;
  const int gw = (w + cell - 1) / cell, gh = (h + cell - 1) / cell;
  ImageF dense = sparse;
  sources->assign(static_cast<size_t>(w) * h, -1);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (sparse.at(x, y) > 0.f) {
        (*sources)[y * w + x] = y * w + x;
        continue;
      }
      std::vector<int> candidates;  // In the order of the cells.
      for (int gy = std::max(0, y / cell - 1); gy <= std::min(gh - 1, y / cell + 1); ++gy)
        for (int gx = std::max(0, x / cell - 1); gx <= std::min(gw - 1, x / cell + 1); ++gx)
          for (int sy = gy * cell; sy < std::min(h, (gy + 1) * cell); ++sy)
            for (int sx = gx * cell; sx < std::min(w, (gx + 1) * cell); ++sx)
              if (sparse.at(sx, sy) > 0.f) candidates.push_back(sy * w + sx);
      auto d2 = [&](int s) {
        return double(s % w - x) * (s % w - x) + double(s / w - y) * (s / w - y);
      };
      double nearest = std::numeric_limits<double>::infinity();
      for (int s : candidates) nearest = std::min(nearest, d2(s));
      if (nearest > double(max_distance) * max_distance) continue;
      const double limit = std::pow(std::sqrt(nearest) + 1.5, 2);
      float best = std::numeric_limits<float>::infinity();
      for (int s : candidates) {
        if (d2(s) <= limit && sparse.pixels[s] < best) {
          best = sparse.pixels[s];
          (*sources)[y * w + x] = s;
        }
      }
      dense.at(x, y) = best;
    }
  }
  return dense;
}

TEST(ViewDepth, CompletionIsTheNearestThenNearerSurfaceOfTheCellsAround) {
  // Sparse maps like projected LiDAR rings (rows of measurements with gaps)
  // plus scattered points, depths on a coarse grid so that many are equal,
  // a quarter empty; image sizes not a multiple of the cell: every value and
  // source equals the plain scan's.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0, 1);
  for (const auto& [w, h, radius] :
       {std::array{97, 61, 12}, std::array{64, 48, 5}, std::array{50, 77, 9}}) {
    SCOPED_TRACE(::testing::Message() << w << "x" << h << " radius " << radius);
    ImageF sparse(w, h, 1);
    for (int y = 3; y < h; y += 7)
      for (int x = 0; x < w; ++x)
        if (u(rng) < 0.4) sparse.at(x, y) = static_cast<float>(1 + std::floor(8 * u(rng)));
    for (int k = 0; k < w * h / 60; ++k)
      sparse.at(static_cast<int>(u(rng) * w), static_cast<int>(u(rng) * h)) =
          static_cast<float>(1 + std::floor(8 * u(rng)));
    for (int y = h / 2; y < h; ++y)  // A quarter with no measurement.
      for (int x = 0; x < w / 2; ++x) sparse.at(x, y) = 0.f;
    CompletionOptions options;
    options.max_distance_px = radius;
    std::vector<int32_t> sources, expected_sources;
    const ImageF dense = CompleteDepth(sparse, options, &sources);
    const ImageF expected = CompleteByScanningCells(sparse, radius, &expected_sources);
    EXPECT_EQ(dense.pixels, expected.pixels);
    EXPECT_EQ(sources, expected_sources);
    int filled = 0, unknown = 0;
    for (size_t i = 0; i < sources.size(); ++i) {
      filled += sources[i] >= 0 && sparse.pixels[i] == 0.f;
      unknown += sources[i] < 0;
    }
    EXPECT_GT(filled, w * h / 3);
    EXPECT_GT(unknown, 0);
  }
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
  const ViewDepth depth = WithFarLayer(measured, /*completed=*/true, view, far);
  EXPECT_FLOAT_EQ(depth.depth[5 * 40 + 5], 7.f);
  EXPECT_EQ(depth.source[5 * 40 + 5], uint8_t(DepthSource::kCompleted));
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

// FindBehindSources' contract computed the plain way, pixel by pixel: the
// window of each radius as the previous one's at the 3 x 3 offsets -step,
// 0, +step (rows outer, clamped to the image), the pixel's own first, the
// first of equal depths kept.
BehindSources BehindSourcesPlainly(const ViewDepth& depth, int band_px, double min_jump) {
  BehindSources out;
  const int w = depth.width, h = depth.height;
  std::vector<int32_t> deepest(static_cast<size_t>(w) * h);
  for (size_t i = 0; i < deepest.size(); ++i) deepest[i] = static_cast<int32_t>(i);
  int previous = 0;
  for (int radius = 1; radius <= band_px; radius *= 2) {
    const int step = radius - previous;
    std::vector<int32_t> next(deepest.size()), sources(deepest.size(), -1);
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        int32_t best = deepest[y * w + x];
        for (int dy : {-step, 0, step}) {
          for (int dx : {-step, 0, step}) {
            const int j = std::clamp(y + dy, 0, h - 1) * w + std::clamp(x + dx, 0, w - 1);
            if (depth.depth[deepest[j]] > depth.depth[best]) best = deepest[j];
          }
        }
        next[y * w + x] = best;
        if (depth.depth[best] > (1.0 + min_jump) * depth.depth[y * w + x]) {
          sources[y * w + x] = best;
        }
      }
    }
    deepest = next;
    out.radii.push_back(radius);
    out.sources.push_back(sources);
    previous = radius;
  }
  return out;
}

TEST(ViewDepth, BehindSourcesAreThePlainWindowRecursions) {
  // Depths on a coarse grid (many equal), blocks of foreground on a
  // background; widths under, at and past the largest step, so every lane
  // group and image border is taken: every source equals the plain one's.
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0, 1);
  for (const auto& [w, h, band] : {std::array{97, 61, 32}, std::array{13, 9, 16},
                                   std::array{64, 40, 64}, std::array{5, 70, 8}}) {
    SCOPED_TRACE(::testing::Message() << w << "x" << h << " band " << band);
    ViewDepth depth;
    depth.width = w;
    depth.height = h;
    depth.depth.resize(static_cast<size_t>(w) * h);
    depth.source.assign(depth.depth.size(), uint8_t(DepthSource::kDepthMap));
    for (float& d : depth.depth) d = static_cast<float>(10 + 5 * std::floor(4 * u(rng)));
    for (int k = 0; k < 6; ++k) {
      const int x0 = static_cast<int>(u(rng) * w), y0 = static_cast<int>(u(rng) * h);
      for (int y = y0; y < std::min(h, y0 + 6); ++y)
        for (int x = x0; x < std::min(w, x0 + 7); ++x) depth.depth[y * w + x] = 3.f;
    }
    const BehindSources behind = FindBehindSources(depth, band, 0.1);
    const BehindSources expected = BehindSourcesPlainly(depth, band, 0.1);
    EXPECT_EQ(behind.radii, expected.radii);
    ASSERT_EQ(behind.sources.size(), expected.sources.size());
    int found = 0;
    for (size_t k = 0; k < expected.sources.size(); ++k) {
      EXPECT_EQ(behind.sources[k], expected.sources[k]) << "radius " << expected.radii[k];
      for (int32_t source : expected.sources[k]) found += source >= 0;
    }
    EXPECT_GT(found, w * h / 4);
  }
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
  // A dense map (a rendered or stereo one: unknown only in a whole region)
  // is taken as it is.
  ContextView view;
  view.camera = kCamera;
  view.depth = ImageF(40, 30, 1);
  for (float& d : view.depth.pixels) d = 3.f;
  for (int x = 0; x < 40; ++x) view.depth.at(x, 0) = 0.f;  // "Sky": stays unknown.
  view.depth.at(2, 1) = std::nanf("");
  LidarSweepData sweep;
  sweep.points = {0, 0, 10};
  MeasuredSource source = MeasuredSource::kNone;
  const ImageF measured = MeasuredDepth(view, {sweep}, {}, {}, &source);
  EXPECT_EQ(source, MeasuredSource::kDepthMap);
  EXPECT_FALSE(IsCompleted(source));
  EXPECT_FLOAT_EQ(measured.at(1, 1), 3.f);
  EXPECT_FLOAT_EQ(measured.at(5, 0), 0.f);
  EXPECT_FLOAT_EQ(measured.at(2, 1), 0.f);  // Non-finite means unknown.
  view.depth = ImageF();
  const ImageF lidar = MeasuredDepth(view, {sweep}, {}, {}, &source);
  EXPECT_EQ(source, MeasuredSource::kLidar);
  EXPECT_TRUE(IsCompleted(source));
  EXPECT_FLOAT_EQ(lidar.at(20, 15), 10.f);
  EXPECT_FLOAT_EQ(lidar.at(22, 16), 10.f);  // Completed around the measurement.
  view.timestamp_us = 5;
  EXPECT_FLOAT_EQ(MeasuredDepth(view, {}, {}, {}, &source).at(20, 15), 0.f);
  EXPECT_EQ(source, MeasuredSource::kNone);
}

// --completion ip-basic: IP-Basic's depth (no upward extension) wherever it
// has one, the nearest measurement's elsewhere.
TEST(ViewDepth, IpBasicCompletionTakesIpBasicsDepthAndTheNearestElsewhere) {
  ContextView view;
  view.camera = kCamera;  // The world is the camera frame.
  LidarSweepData sweep;
  // A wall leaning away, z = 8 + 0.2 * y_cam, sampled every 3rd pixel of
  // rows 12-27, so the rows above stay beyond IP-Basic without extension.
  for (int v = 12; v < 28; v += 3) {
    for (int u = 1; u < 40; u += 3) {
      const double x = (u + 0.5 - 20) / 40, y = (v + 0.5 - 15) / 40;
      const double z = 8 / (1 - 0.2 * y);
      sweep.points.insert(sweep.points.end(), {float(x * z), float(y * z), float(z)});
    }
  }
  CompletionOptions options;
  options.ground_fill = false;
  const ImageF nearest = MeasuredDepth(view, {sweep}, {}, options);
  options.method = CompletionOptions::Method::kIpBasic;
  const ImageF ip_basic = MeasuredDepth(view, {sweep}, {}, options);
  const ImageF projected = ProjectPoints(sweep.points, view.camera, view.world_from_camera);
  IpBasicOptions no_extension;
  no_extension.extrapolate = false;
  const ImageF dense = CompleteDepthIpBasic(projected, no_extension);
  int from_ip_basic = 0, from_nearest = 0, differ = 0;
  for (size_t i = 0; i < dense.pixels.size(); ++i) {
    if (dense.pixels[i] > 0.f) {
      EXPECT_FLOAT_EQ(ip_basic.pixels[i], dense.pixels[i]) << i;
      ++from_ip_basic;
    } else {
      EXPECT_FLOAT_EQ(ip_basic.pixels[i], nearest.pixels[i]) << i;
      from_nearest += nearest.pixels[i] > 0.f;
    }
    differ += std::abs(ip_basic.pixels[i] - nearest.pixels[i]) > 1e-4f;
  }
  EXPECT_GT(from_ip_basic, 40 * 12);
  EXPECT_GT(from_nearest, 0);  // Above row 12, within the nearest fill's radius.
  EXPECT_GT(differ, 0);
}

// A camera at `height` over the world origin, looking along +x with a level
// horizon (camera x = world -y, camera y = world -z, camera z = world x).
Rigid LevelCameraLookingAlongX(double height) {
  Rigid pose;
  pose.rotation = Mat3::FromColumns({0, -1, 0}, {0, 0, -1}, {1, 0, 0});
  pose.translation = {0, 0, height};
  return pose;
}

// Rings of ground points z = slope * x + lift around a sensor at (0, 0,
// 1.9), from `near` to `far` metres, over the front half circle.
LidarSweepData GroundRings(double near, double far, double slope = 0, double lift = 0) {
  LidarSweepData sweep;
  sweep.sensor_origin = {0, 0, 1.9};
  for (double r = near; r <= far + 1e-9; r += 1.0) {
    for (double a = -90; a <= 90; a += 0.5) {
      const double x = r * std::cos(a * M_PI / 180), y = r * std::sin(a * M_PI / 180);
      sweep.points.insert(sweep.points.end(), {float(x), float(y), float(slope * x + lift)});
    }
  }
  return sweep;
}

TEST(ViewDepth, GroundPlaneFitFindsATiltedRoadAmongWallsAndCars) {
  // A road rising 3 % ahead, a wall across it at x = 20 and a car's side at
  // y = 3: the plane is the road's, not the wall's nor the car's.
  LidarSweepData sweep = GroundRings(3, 50, 0.03, 0.1);
  for (double y = -10; y <= 10; y += 0.1)
    for (double z = 0.7; z <= 5; z += 0.1)
      sweep.points.insert(sweep.points.end(), {20.f, float(y), float(z)});
  for (double x = 6; x <= 10; x += 0.05)
    for (double z = 0.4; z <= 1.5; z += 0.05)
      sweep.points.insert(sweep.points.end(), {float(x), 3.f, float(z)});
  const GroundPlane ground = FitGroundPlane(sweep);
  ASSERT_TRUE(ground.valid);
  const Vec3 truth = Normalized(Vec3{-0.03, 0, 1});
  EXPECT_GT(Dot(ground.normal, truth), std::cos(0.2 * M_PI / 180));
  // The plane passes through (0, 0, 0.1) and (40, 0, 1.3).
  EXPECT_NEAR(Dot(ground.normal, Vec3{0, 0, 0.1}), ground.offset, 0.01);
  EXPECT_NEAR(Dot(ground.normal, Vec3{40, 0, 1.3}), ground.offset, 0.01);
  EXPECT_NEAR(ground.reach, 50.0, 1.5);  // Up to 60 m of reach is searched.
  EXPECT_GT(ground.inliers, 10000u);

  // Too few points, or only a wall: no plane.
  LidarSweepData sparse = GroundRings(3, 4);
  sparse.points.resize(3 * 40);
  EXPECT_FALSE(FitGroundPlane(sparse).valid);
  LidarSweepData wall;
  wall.sensor_origin = {0, 0, 1.9};
  for (double y = -10; y <= 10; y += 0.1)
    for (double z = -2; z <= 1.5; z += 0.1)
      wall.points.insert(wall.points.end(), {20.f, float(y), float(z)});
  EXPECT_FALSE(FitGroundPlane(wall).valid);
}

TEST(ViewDepth, GroundFillSetsRoadPixelsWithinItsReach) {
  GroundPlane ground;
  ground.valid = true;
  ground.normal = {0, 0, 1};
  ground.offset = 0;
  ground.reach = 20;
  const Rigid pose = LevelCameraLookingAlongX(1.5);
  // Row r (v = r + 0.5) goes down (v - 15) / 40 per unit ahead, so it meets
  // z = 0 at z depth 1.5 * 40 / (v - 15).
  auto road = [](int row) { return 1.5 * 40 / (row + 0.5 - 15); };
  auto at = [](int x, int y) { return y * 40 + x; };
  ImageF depth(40, 30, 1);
  std::vector<int32_t> sources(40 * 30, -1);
  // Measured: a point 0.75 m above the road at (20, 25), one on the road at
  // (20, 26). Both kept.
  depth.at(20, 25) = 3.f;
  sources[at(20, 25)] = at(20, 25);
  depth.at(20, 26) = float(road(26));
  sources[at(20, 26)] = at(20, 26);
  // Completed from the road point, 9 % off the road: snapped to the road.
  depth.at(20, 27) = float(road(26));
  sources[at(20, 27)] = at(20, 26);
  // Completed from the road point but 17 % off (beyond 15 %): kept.
  depth.at(20, 24) = float(road(26));
  sources[at(20, 24)] = at(20, 26);
  // Completed from the point above the road: another surface, kept.
  depth.at(20, 28) = 3.f;
  sources[at(20, 28)] = at(20, 25);
  const int64_t filled =
      FillFromGround(ground, Vec3{0, 0, 1.9}, LinePoses(kCamera, pose), sources, &depth);
  EXPECT_NEAR(depth.at(20, 29), road(29), 1e-4);  // Unknown: the road.
  EXPECT_NEAR(depth.at(20, 27), road(27), 1e-4);
  EXPECT_FLOAT_EQ(depth.at(20, 24), float(road(26)));
  EXPECT_FLOAT_EQ(depth.at(20, 28), 3.f);
  EXPECT_FLOAT_EQ(depth.at(20, 25), 3.f);
  EXPECT_FLOAT_EQ(depth.at(20, 26), float(road(26)));
  // Row 16 meets the road 40 m ahead, beyond its 20 m reach; row 10 looks
  // up: both stay unknown.
  EXPECT_FLOAT_EQ(depth.at(20, 16), 0.f);
  EXPECT_FLOAT_EQ(depth.at(20, 10), 0.f);
  int64_t set = 0;
  for (float d : depth.pixels) set += d > 0.f ? 1 : 0;
  EXPECT_EQ(filled, set - 4);  // All but the two measured pixels and the two kept.
  // No plane, or a camera under it: nothing set.
  const std::vector<int32_t> none(40 * 30, -1);
  ImageF untouched(40, 30, 1);
  EXPECT_EQ(FillFromGround(GroundPlane{}, Vec3{}, LinePoses(kCamera, pose), none, &untouched), 0);
  EXPECT_EQ(FillFromGround(ground, Vec3{}, LinePoses(kCamera, LevelCameraLookingAlongX(-1)), none,
                           &untouched),
            0);
  for (float d : untouched.pixels) EXPECT_EQ(d, 0.f);
}

TEST(ViewDepth, LidarDepthReachesTheRoadBelowTheLowestRing) {
  // Rings from 6 m on: the road closer than that, at the bottom of a level
  // camera 1.5 m up, has no LiDAR point; the ground fill gives it the road's
  // depth, where without it the bottom rows are unknown (far layer).
  const CameraModel camera(160, 120, 160, 160, 80, 60);
  ContextView view;
  view.camera = camera;
  view.world_from_camera = LevelCameraLookingAlongX(1.5);
  const LidarSweepData sweep = GroundRings(6, 30);
  CompletionOptions options;
  options.ground_fill = false;
  MeasuredSource source = MeasuredSource::kNone;
  const ImageF without = MeasuredDepth(view, {sweep}, {}, options, &source);
  EXPECT_EQ(source, MeasuredSource::kLidar);
  EXPECT_FLOAT_EQ(without.at(80, 119), 0.f);
  options.ground_fill = true;
  int64_t ground_pixels = 0;
  const ImageF with = MeasuredDepth(view, {sweep}, {}, options, &source, &ground_pixels);
  EXPECT_NEAR(with.at(80, 119), 1.5 * 160 / 59.5, 1e-3);
  EXPECT_NEAR(with.at(10, 118), 1.5 * 160 / 58.5, 1e-3);
  EXPECT_GE(ground_pixels, 160 * 4);
  // Between rings, completion copies the nearest ring's depth (up to half a
  // ring's spacing off); with the ground fill every road pixel has its own,
  // scaled by the mean measured-to-plane ratio around it, which here (a flat
  // road) is 1 but for the measurements' places inside their pixels (each up
  // to half a pixel, 1/40 of the depth at row 80, off the centre).
  // Above the horizon nothing is set but what completion spread from the
  // farthest ring.
  const ImageF sparse = ProjectPoints(GroundRings(6, 30).points, camera, view.world_from_camera);
  double worst_without = 0, worst_with = 0, mean_without = 0, mean_with = 0;
  int pixels = 0;
  for (int y = 80; y < 100; ++y) {
    const double road = 1.5 * 160 / (y + 0.5 - 60);
    for (int x = 40; x < 120; ++x) {
      if (sparse.at(x, y) > 0.f) {
        EXPECT_EQ(with.at(x, y), sparse.at(x, y));  // Measured: kept.
        continue;
      }
      const double error_without = std::abs(without.at(x, y) - road) / road;
      const double error_with = std::abs(with.at(x, y) - road) / road;
      worst_without = std::max(worst_without, error_without);
      worst_with = std::max(worst_with, error_with);
      mean_without += error_without;
      mean_with += error_with;
      ++pixels;
    }
  }
  mean_without /= pixels;
  mean_with /= pixels;
  EXPECT_GT(worst_without, 0.02);
  EXPECT_LT(worst_with, 0.015);
  EXPECT_LT(mean_with, 0.006);
  EXPECT_LT(mean_with, 0.4 * mean_without) << mean_without;
  for (int y = 0; y < 50; ++y)
    for (int x = 0; x < 160; ++x) EXPECT_EQ(with.at(x, y), 0.f);
}

// A sparse depth map in the manifest (LiDAR written as depth maps) is
// completed as the LiDAR itself is: between rings and below the lowest one
// the road gets its own depth from the ground plane fitted to the map's
// points, where before it was taken as final (95 % unknown: the far layer).
TEST(ViewDepth, ASparseDepthMapIsCompletedAsLidarIs) {
  // 640 x 480: a pixel is 1.6 mrad, so lifting a point through its pixel's
  // centre moves it under 5 cm at 30 m.
  const CameraModel camera(640, 480, 640, 640, 320, 240);
  ContextView view;
  view.camera = camera;
  view.world_from_camera = LevelCameraLookingAlongX(1.5);
  const LidarSweepData sweep = GroundRings(6, 30);
  view.depth = ProjectPoints(sweep.points, camera, view.world_from_camera);
  ASSERT_TRUE(IsSparseDepth(view.depth));
  MeasuredSource source = MeasuredSource::kNone;
  int64_t ground_pixels = 0;
  GroundPlane ground;
  const ImageF from_map = MeasuredDepth(view, {}, {}, {}, &source, &ground_pixels, &ground);
  EXPECT_EQ(source, MeasuredSource::kSparseDepthMap);
  EXPECT_TRUE(IsCompleted(source));
  // The plane fitted to the map's points lifted to the world is the road's.
  ASSERT_TRUE(ground.valid);
  EXPECT_NEAR(ground.normal.z, 1.0, 1e-3);
  EXPECT_NEAR(ground.offset, 0.0, 0.01);
  EXPECT_GE(ground_pixels, 640 * 60);
  // Below the lowest ring (6 m: row 400) and between rings (6-12 m: rows
  // 320-400) every road pixel has its own depth; the nearest ring's copy is
  // up to half a ring's spacing off.
  double worst = 0;
  for (int y = 320; y < 480; ++y) {
    const double road = 1.5 * 640 / (y + 0.5 - 240);
    for (int x = 160; x < 480; ++x) {
      if (view.depth.at(x, y) > 0.f) {
        EXPECT_EQ(from_map.at(x, y), view.depth.at(x, y));  // Measured: kept.
        continue;
      }
      worst = std::max(worst, std::abs(from_map.at(x, y) - road) / road);
    }
  }
  EXPECT_LT(worst, 0.005);
  // Above the horizon: nothing but what completion spread from the farthest
  // ring (row 272, radius 19 px).
  for (int y = 0; y < 240; ++y)
    for (int x = 0; x < 640; ++x) ASSERT_EQ(from_map.at(x, y), 0.f) << x << "," << y;
}

}  // namespace
}  // namespace pf
