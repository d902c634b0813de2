// Tests of the procedural scene: determinism, option checks, trajectories
// and the camera rig.
#include "engine/synth/synth_scene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace pf {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

SynthScene Generate(uint64_t seed, int cameras = 3) {
  SynthOptions options;
  options.seed = seed;
  options.num_cameras = cameras;
  auto scene = GenerateSynthScene(options);
  EXPECT_TRUE(scene.ok()) << scene.status();
  return *scene;
}

TEST(SynthScene, SameSeedGivesSameScene) {
  const SynthScene a = Generate(7), b = Generate(7);
  ASSERT_EQ(a.boxes.size(), b.boxes.size());
  for (size_t i = 0; i < a.boxes.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(a.boxes[i].lo[k], b.boxes[i].lo[k]);
      EXPECT_EQ(a.boxes[i].hi[k], b.boxes[i].hi[k]);
    }
    EXPECT_EQ(a.boxes[i].texture_seed, b.boxes[i].texture_seed);
  }
  ASSERT_EQ(a.vehicles.size(), b.vehicles.size());
  for (size_t i = 0; i < a.vehicles.size(); ++i) {
    EXPECT_EQ(a.vehicles[i].speed, b.vehicles[i].speed);
    EXPECT_EQ(a.vehicles[i].start_position.x, b.vehicles[i].start_position.x);
  }
}

TEST(SynthScene, SensorOptionsDoNotChangeTheWorld) {
  SynthOptions options;
  options.seed = 12;
  SynthOptions other = options;
  other.width = 100;
  other.height = 50;
  other.num_frames = 3;
  other.num_cameras = 5;
  const auto a = GenerateSynthScene(options), b = GenerateSynthScene(other);
  ASSERT_TRUE(a.ok() && b.ok());
  ASSERT_EQ(a->boxes.size(), b->boxes.size());
  for (size_t i = 0; i < a->boxes.size(); ++i) EXPECT_EQ(a->boxes[i].hi.z, b->boxes[i].hi.z);
  ASSERT_EQ(a->vehicles.size(), b->vehicles.size());
  for (size_t i = 0; i < a->vehicles.size(); ++i) {
    EXPECT_EQ(a->vehicles[i].BoxToWorldAt(1.0).translation.x,
              b->vehicles[i].BoxToWorldAt(1.0).translation.x);
  }
  EXPECT_EQ(a->ego_speed, b->ego_speed);
}

TEST(SynthScene, DifferentSeedsGiveDifferentScenes) {
  const SynthScene a = Generate(1), b = Generate(2);
  EXPECT_NE(a.road.junction_x, b.road.junction_x);
  EXPECT_NE(a.vehicles[0].start_position.x, b.vehicles[0].start_position.x);
}

TEST(SynthScene, HasEveryKindOfPrimitive) {
  const SynthScene scene = Generate(3);
  int pavements = 0, buildings_left = 0, buildings_right = 0, poles = 0;
  for (const StaticBox& box : scene.boxes) {
    EXPECT_LT(box.lo.x, box.hi.x);
    EXPECT_LT(box.lo.y, box.hi.y);
    EXPECT_LT(box.lo.z, box.hi.z);
    if (box.kind == StaticKind::kPavement) ++pavements;
    if (box.kind == StaticKind::kPole) ++poles;
    if (box.kind == StaticKind::kBuilding && box.lo.y > 0) ++buildings_left;
    if (box.kind == StaticKind::kBuilding && box.hi.y < 0) ++buildings_right;
  }
  EXPECT_EQ(pavements, 4);
  EXPECT_GT(buildings_left, 5);
  EXPECT_GT(buildings_right, 5);
  EXPECT_GT(poles, 10);
  EXPECT_GE(scene.vehicles.size(), 3u);
}

TEST(SynthScene, RejectsOptionsOutOfRange) {
  SynthOptions options;
  options.width = 8;
  absl::Status status = ValidateSynthOptions(options);
  EXPECT_TRUE(absl::IsInvalidArgument(status));
  EXPECT_NE(std::string(status.message()).find("width"), std::string::npos) << status;
  options = SynthOptions();
  options.num_cameras = 0;
  status = GenerateSynthScene(options).status();
  EXPECT_NE(std::string(status.message()).find("cameras"), std::string::npos) << status;
  options = SynthOptions();
  options.num_frames = 601;
  EXPECT_NE(std::string(ValidateSynthOptions(options).message()).find("frames"), std::string::npos);
}

TEST(SynthScene, VehiclesMoveAtTheirSpeed) {
  const SynthScene scene = Generate(5);
  const double t = 1.9;
  for (const Vehicle& v : scene.vehicles) {
    const Rigid a = v.BoxToWorldAt(0), b = v.BoxToWorldAt(t);
    const double moved = Norm(b.translation - a.translation);
    EXPECT_GT(moved, 5.0) << v.id;
    // A chord of the arc: at most the path length, and close to it.
    EXPECT_LE(moved, v.speed * t + 1e-9) << v.id;
    EXPECT_GT(moved, 0.99 * v.speed * t) << v.id;
    EXPECT_DOUBLE_EQ(a.translation.z, v.size.z / 2);
    // The velocity points along the box x axis.
    const double h = 1e-5;
    const Vec3 velocity =
        (v.BoxToWorldAt(1.0 + h).translation - v.BoxToWorldAt(1.0 - h).translation) / (2 * h);
    const Vec3 axis = v.BoxToWorldAt(1.0).rotation.Col(0);
    EXPECT_NEAR(Dot(velocity, axis), v.speed, 1e-4) << v.id;
    EXPECT_NEAR(Norm(Cross(velocity, axis)), 0.0, 1e-4) << v.id;
  }
}

TEST(SynthScene, VehiclesCrossOncomeAndLead) {
  const SynthScene scene = Generate(9);
  bool crossing = false, oncoming = false, ahead = false;
  for (const Vehicle& v : scene.vehicles) {
    const Vec3 heading = v.BoxToWorldAt(0).rotation.Col(0);
    if (std::abs(heading.y) > 0.9) crossing = true;
    if (heading.x < -0.9 && v.start_position.x > scene.ego_start_x) oncoming = true;
    if (heading.x > 0.9 && std::abs(v.start_position.y - scene.ego_lane_y) < 0.1) ahead = true;
  }
  EXPECT_TRUE(crossing);
  EXPECT_TRUE(oncoming);
  EXPECT_TRUE(ahead);
}

TEST(SynthScene, FootprintOverlapTest) {
  const Vec3 car{4, 2, 1.5};
  const Rigid origin{Mat3::Identity(), {0, 0, 0.75}};
  EXPECT_TRUE(FootprintsOverlap(origin, car, {Mat3::Identity(), {3.9, 0, 0.75}}, car));
  EXPECT_FALSE(FootprintsOverlap(origin, car, {Mat3::Identity(), {4.1, 0, 0.75}}, car));
  EXPECT_TRUE(FootprintsOverlap(origin, car, {Mat3::Identity(), {4.1, 0, 0.75}}, car, 0.2));
  EXPECT_FALSE(FootprintsOverlap(origin, car, {Mat3::Identity(), {0, 2.05, 0.75}}, car));
  // Turned by 90 degrees: half length 2 along y now.
  const Rigid turned{YawRotation(std::numbers::pi / 2), {0, 2.9, 0.75}};
  EXPECT_TRUE(FootprintsOverlap(origin, car, turned, car));
  EXPECT_FALSE(FootprintsOverlap(origin, car, {turned.rotation, {0, 3.1, 0.75}}, car));
  // Diagonal neighbours whose axis-aligned bounds would overlap but which
  // do not touch.
  const Rigid diagonal{YawRotation(std::numbers::pi / 4), {2.6, 2.0, 0.75}};
  EXPECT_FALSE(FootprintsOverlap(origin, car, diagonal, {2, 1, 1.5}));
  EXPECT_TRUE(FootprintsOverlap(origin, car, {diagonal.rotation, {2.4, 1.8, 0.75}}, {2, 1, 1.5}));
}

TEST(SynthScene, VehiclesNeverCollideInTheClip) {
  for (uint64_t seed = 0; seed < 60; ++seed) {
    const SynthScene scene = Generate(seed);
    for (double t = 0; t <= 2.0; t += 0.1) {
      for (size_t i = 0; i < scene.vehicles.size(); ++i) {
        for (size_t j = i + 1; j < scene.vehicles.size(); ++j) {
          const Vehicle &a = scene.vehicles[i], &b = scene.vehicles[j];
          EXPECT_FALSE(FootprintsOverlap(a.BoxToWorldAt(t), a.size, b.BoxToWorldAt(t), b.size))
              << "seed " << seed << " t " << t << ": " << a.id << " and " << b.id;
        }
      }
      // Every vehicle stays on the road surface (off the pavements).
      for (const Vehicle& v : scene.vehicles) {
        const Vec3 c = v.BoxToWorldAt(t).translation;
        const bool on_main = std::abs(c.y) < scene.road.half_width - 0.9;
        const bool on_cross =
            std::abs(c.x - scene.road.junction_x) < scene.road.junction_half_width - 0.9;
        EXPECT_TRUE(on_main || on_cross) << "seed " << seed << " " << v.id;
      }
    }
  }
}

TEST(SynthScene, ThreeCameraRigLooksLeftFrontRight) {
  const SynthScene scene = Generate(1);
  ASSERT_EQ(scene.cameras.size(), 3u);
  EXPECT_EQ(scene.cameras[0].id, "cam_left");
  EXPECT_EQ(scene.cameras[1].id, "cam_front");
  EXPECT_EQ(scene.cameras[2].id, "cam_right");
  EXPECT_NEAR(scene.cameras[0].yaw, 40 * kDeg, 1e-12);
  EXPECT_NEAR(scene.cameras[1].yaw, 0, 1e-12);
  EXPECT_NEAR(scene.cameras[2].yaw, -40 * kDeg, 1e-12);
  const CameraModel& model = scene.cameras[1].model;
  EXPECT_DOUBLE_EQ(model.cx(), 768 / 2.0);
  EXPECT_DOUBLE_EQ(model.cy(), 576 / 2.0);
  // 75 degrees horizontal field of view.
  EXPECT_NEAR(2 * std::atan(model.width() / 2.0 / model.fx()), 75 * kDeg, 1e-9);

  // The left camera's optical axis points forward-left, its x axis to the
  // right of that, its y axis down (OpenCV).
  const Rigid pose = scene.WorldFromCamera(0, 0.0);
  const Vec3 forward = pose.rotation.Col(2), right = pose.rotation.Col(0),
             down = pose.rotation.Col(1);
  EXPECT_NEAR(std::atan2(forward.y, forward.x), 40 * kDeg, 1e-9);
  EXPECT_LT(forward.z, 0);  // Pitched slightly down.
  EXPECT_NEAR(Dot(right, Vec3{0, 0, 1}), 0, 1e-12);
  EXPECT_LT(down.z, -0.99);
  EXPECT_NEAR(Determinant(pose.rotation), 1.0, 1e-12);
  // Cameras ride with the ego.
  const Rigid later = scene.WorldFromCamera(1, 1.0);
  const Rigid now = scene.WorldFromCamera(1, 0.0);
  EXPECT_NEAR(later.translation.x - now.translation.x, scene.ego_speed, 1e-9);
  EXPECT_NEAR(now.translation.z, 1.55, 1e-12);
}

TEST(SynthScene, OtherCameraCountsSpreadInYaw) {
  const SynthScene scene = Generate(1, 5);
  ASSERT_EQ(scene.cameras.size(), 5u);
  for (size_t i = 1; i < scene.cameras.size(); ++i) {
    EXPECT_NEAR(scene.cameras[i - 1].yaw - scene.cameras[i].yaw, 40 * kDeg, 1e-12);
    EXPECT_NE(scene.cameras[i - 1].id, scene.cameras[i].id);
  }
  EXPECT_NEAR(scene.cameras[2].yaw, 0, 1e-12);
  const SynthScene one = Generate(1, 1);
  EXPECT_EQ(one.cameras[0].id, "cam_front");
  EXPECT_EQ(one.cameras[0].yaw, 0);
}

TEST(SynthScene, FramesAtTenHertzWithContextProtocol) {
  const SynthScene scene = Generate(1);
  const std::vector<int64_t> t = scene.FrameTimestampsUs();
  ASSERT_EQ(t.size(), 20u);
  EXPECT_EQ(t[0], 0);
  EXPECT_EQ(t[19], 1900000);
  int context = 0;
  for (int64_t us : t) context += IsContextTimestamp(us);
  EXPECT_EQ(context, 4);
  EXPECT_TRUE(IsContextTimestamp(1500000));
  EXPECT_FALSE(IsContextTimestamp(1600000));
}

}  // namespace
}  // namespace pf
