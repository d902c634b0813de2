// Tests of LiDAR rendering: ranges to known surfaces, drops where nothing
// is, moving sensors and actors.
#include "engine/render/lidar_render.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "engine/render/lidar_testing.h"

namespace pf {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A box room around the origin: walls of opaque discs 5 cm apart at
// x = +-`half_x`, y = +-`half_y`, from z = -2 to z = 3 (no floor or ceiling).
GaussianScene Room(double half_x, double half_y) {
  GaussianScene scene;
  scene.low_pass = 0.1f;
  auto add = [&](const Vec3& p, const Vec3& normal_axis) {
    const size_t i = scene.size();
    scene.Resize(i + 1);
    scene.means[3 * i] = float(p.x), scene.means[3 * i + 1] = float(p.y);
    scene.means[3 * i + 2] = float(p.z);
    // Discs 4 cm wide, 1 mm thick along the wall's normal.
    for (int a = 0; a < 3; ++a) {
      scene.log_scales[3 * i + a] = std::log(normal_axis[a] != 0 ? 0.001f : 0.04f);
    }
    scene.opacity_logits[i] = 4.f;  // 0.98.
    for (int c = 0; c < 3; ++c) scene.features[3 * i + c] = 0.5f;
  };
  constexpr double kStep = 0.05;
  for (double z = -2; z <= 3; z += kStep) {
    for (double y = -half_y; y <= half_y; y += kStep) {
      add({half_x, y, z}, {1, 0, 0});
      add({-half_x, y, z}, {1, 0, 0});
    }
    for (double x = -half_x; x <= half_x; x += kStep) {
      add({x, half_y, z}, {0, 1, 0});
      add({x, -half_y, z}, {0, 1, 0});
    }
  }
  return scene;
}

// The distance along unit direction `d` from `origin` to the room's walls
// (z within [-2, 3]), or -1.
double RoomRange(double half_x, double half_y, const Vec3& origin, const Vec3& d) {
  double best = -1;
  for (int axis = 0; axis < 2; ++axis) {
    const double half = axis == 0 ? half_x : half_y;
    for (double side : {-half, half}) {
      const double component = axis == 0 ? d.x : d.y;
      if (std::abs(component) < 1e-12) continue;
      const double t = (side - (axis == 0 ? origin.x : origin.y)) / component;
      if (t <= 0) continue;
      const Vec3 p = origin + t * d;
      if (std::abs(p.x) > half_x + 1e-9 || std::abs(p.y) > half_y + 1e-9) continue;
      if (p.z < -2 || p.z > 3) continue;
      if (best < 0 || t < best) best = t;
    }
  }
  return best;
}

// 16 beams from -15 to +15 degrees, 360 azimuths, fired over the sweep.
std::vector<LidarRay> SpinningRays() {
  std::vector<LidarRay> rays;
  for (int a = 0; a < 360; ++a) {
    const double azimuth = a * kPi / 180;
    for (int b = 0; b < 16; ++b) {
      const double elevation = (-15 + 2 * b) * kPi / 180;
      rays.push_back({{std::cos(elevation) * std::cos(azimuth),
                       std::cos(elevation) * std::sin(azimuth), std::sin(elevation)},
                      a / 359.0});
    }
  }
  return rays;
}

TEST(LidarRender, RangesAreTheDistanceToTheWallsAllRound) {
  const GaussianScene room = Room(6, 4);
  const std::vector<LidarRay> rays = SpinningRays();
  LidarSweepPose pose;  // At the origin, not moving.
  absl::StatusOr<std::vector<LidarReturn>> returns = RenderLidarRays(room, rays, pose);
  ASSERT_TRUE(returns.ok()) << returns.status();
  ASSERT_EQ(returns->size(), rays.size());
  int hits = 0, missed_truth = 0;
  std::vector<double> errors;
  for (size_t i = 0; i < rays.size(); ++i) {
    const double truth = RoomRange(6, 4, {0, 0, 0}, rays[i].direction);
    ASSERT_GT(truth, 0) << i;  // Every ray meets a wall.
    if (!(*returns)[i].hit) {
      ++missed_truth;
      continue;
    }
    ++hits;
    errors.push_back((*returns)[i].range - truth);
  }
  // Rays up to 15 degrees reach the walls 4-7.2 m away (z from -1.9 to 1.9):
  // every one hits. A render's depth is that of the splats' centres, so on
  // a wall seen at a slant the discs reaching the pixel (4 cm std-dev, the
  // nearest blended first) lie off the ray's own depth: measured median
  // |error| 1.5 cm, worst 3.4 cm.
  EXPECT_EQ(missed_truth, 0);
  EXPECT_EQ(hits, static_cast<int>(rays.size()));
  ASSERT_FALSE(errors.empty());
  std::vector<double> magnitudes;
  for (double e : errors) magnitudes.push_back(std::abs(e));
  std::sort(magnitudes.begin(), magnitudes.end());
  EXPECT_LT(magnitudes[magnitudes.size() / 2], 0.025);
  EXPECT_LT(magnitudes.back(), 0.05);
  for (const LidarReturn& r : *returns) EXPECT_EQ(r.intensity, 0.f);  // No intensity channel.
}

TEST(LidarRender, AReturnsIntensityIsTheChannelOfTheWallItHits) {
  // The room with a fourth channel, the intensity: 10 and 20 on the walls at
  // x = +6 and -6, 30 and 40 at y = +4 and -4.
  GaussianScene room = Room(6, 4);
  testing::AddIntensityChannel(&room, [&](size_t i) {
    const float x = room.means[3 * i], y = room.means[3 * i + 1];
    return std::abs(x) > 5.99f ? (x > 0 ? 10.f : 20.f) : (y > 0 ? 30.f : 40.f);
  });
  const std::vector<LidarRay> rays = SpinningRays();
  absl::StatusOr<std::vector<LidarReturn>> returns = RenderLidarRays(room, rays, {});
  ASSERT_TRUE(returns.ok()) << returns.status();
  int exact = 0, off_corner = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    ASSERT_TRUE((*returns)[i].hit) << i;
    const Vec3 d = rays[i].direction;
    const Vec3 p = RoomRange(6, 4, {0, 0, 0}, d) * (d / Norm(d));
    // Within 10 cm of a corner two walls blend.
    if (std::abs(std::abs(p.x) - 6) < 0.1 && std::abs(std::abs(p.y) - 4) < 0.1) continue;
    ++off_corner;
    const float truth = std::abs(p.x) > 5.999 ? (p.x > 0 ? 10.f : 20.f) : (p.y > 0 ? 30.f : 40.f);
    exact += std::abs((*returns)[i].intensity - truth) < 1e-3f;
  }
  EXPECT_GT(off_corner, 5500);
  EXPECT_EQ(exact, off_corner);
}

TEST(LidarRender, NoReturnWhereNothingIsAndAMovingSensorSeesFromWhereItIs) {
  const GaussianScene room = Room(6, 4);
  // Rays 40 degrees up leave the room over its 3 m walls: no return.
  std::vector<LidarRay> up;
  for (int a = 0; a < 360; a += 10) {
    const double azimuth = a * kPi / 180, elevation = 40 * kPi / 180;
    up.push_back({{std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth),
                   std::sin(elevation)},
                  0.5});
  }
  absl::StatusOr<std::vector<LidarReturn>> returns = RenderLidarRays(room, up, {});
  ASSERT_TRUE(returns.ok()) << returns.status();
  for (const LidarReturn& r : *returns) EXPECT_FALSE(r.hit) << r.range;

  // The sensor moves from x = -2 to x = +2 over the sweep: a ray fired at
  // fraction f starts at x = -2 + 4 f.
  LidarSweepPose moving;
  moving.world_from_sensor_start.translation = {-2, 0, 0};
  moving.world_from_sensor_end.translation = {2, 0, 0};
  moving.end_us = 100000;
  const std::vector<LidarRay> rays = SpinningRays();
  returns = RenderLidarRays(room, rays, moving);
  ASSERT_TRUE(returns.ok()) << returns.status();
  int checked = 0, close = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    const Vec3 d = rays[i].direction;
    const double truth = RoomRange(6, 4, {-2 + 4 * rays[i].sweep_fraction, 0, 0}, d);
    if (truth < 0 || !(*returns)[i].hit) continue;
    ++checked;
    // A sector is rendered from its rays' mean position: 15 degrees of
    // azimuth, 4 m / 24 apart at most from each ray's own.
    close += std::abs((*returns)[i].range - truth) < 0.1;
  }
  EXPECT_GT(checked, 0.99 * rays.size());
  EXPECT_GT(close, 0.97 * checked);
}

TEST(LidarRender, BadInputNamesTheField) {
  const GaussianScene room = Room(2, 2);
  std::vector<LidarRay> rays = {{{0, 0, 0}, 0.5}};
  EXPECT_NE(RenderLidarRays(room, rays, {}).status().message().find("rays[0]: zero"),
            std::string::npos);
  rays = {{{1, 0, 0}, 1.5}};
  EXPECT_NE(RenderLidarRays(room, rays, {}).status().message().find("rays[0]: sweep fraction"),
            std::string::npos);
  LidarRenderOptions options;
  options.sectors = 2;
  EXPECT_NE(RenderLidarRays(room, {}, {}, options).status().message().find("sectors"),
            std::string::npos);
}

}  // namespace
}  // namespace pf
