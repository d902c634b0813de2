// Tests of box membership, canonicalisation and dynamic masks against
// hand-computed points.
#include "engine/recon/scene_graph.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace pf {
namespace {

// A yaw rotation about world z by `degrees`.
Quat Yaw(double degrees) {
  const double half = 0.5 * degrees * M_PI / 180.0;
  return {std::cos(half), 0, 0, std::sin(half)};
}

TEST(SceneGraph, PointInRotatedBox) {
  TrackBox box;
  box.center = {10, 0, 1};
  box.size = {4, 2, 2};                         // Length 4 along the box x axis.
  box.rotation = Yaw(90);                       // Box x axis is world +y.
  EXPECT_TRUE(PointInBox({10, 1.9, 1}, box));   // 1.9 m along the box's length.
  EXPECT_FALSE(PointInBox({11.9, 0, 1}, box));  // 1.9 m across: outside (half width 1).
  EXPECT_TRUE(PointInBox({10.9, 0, 1}, box));
  EXPECT_FALSE(PointInBox({10, 0, 2.1}, box));
  EXPECT_TRUE(PointInBox({10, 0, 2.1}, box, {0.2, 0.0}));  // Grown by a margin.
  EXPECT_TRUE(PointInBox({10, 0, 0.05}, box));
  EXPECT_FALSE(PointInBox({10, 0, 0.05}, box, {0.2, 0.1}));  // The floor is raised.
  EXPECT_TRUE(PointInBox({10, 2.15, 1}, box, kMembershipMargin));
}

// A track of boxes 4x2x2 at `centres` (t = 0, 1, 2 s ...) turned by `yaws`.
InstanceTrack TrackThrough(const std::vector<Vec3>& centres, const std::vector<double>& yaws) {
  InstanceTrack track;
  track.id = "car";
  for (size_t i = 0; i < centres.size(); ++i) {
    TrackBox box;
    box.timestamp_us = static_cast<int64_t>(i) * 1000000;
    box.center = centres[i];
    box.size = {4, 2, 2};
    box.rotation = Yaw(yaws[i]);
    track.boxes.push_back(box);
  }
  return track;
}

TEST(SceneGraph, StillTracksAreThoseWhoseBoxesStayWithinTheTolerance) {
  const Vec3 c{10, 5, 1};
  EXPECT_TRUE(IsStillTrack(TrackThrough({c, c, c}, {30, 30, 30})));
  // 4 cm and 1.5 degrees of annotation jitter: still.
  EXPECT_TRUE(IsStillTrack(TrackThrough({c, c + Vec3{0.04, 0, 0}, c}, {30, 31.5, 30})));
  // 6 cm, or 2.5 degrees, from the first box: moving.
  EXPECT_FALSE(IsStillTrack(TrackThrough({c, c, c + Vec3{0, 0.06, 0}}, {30, 30, 30})));
  EXPECT_FALSE(IsStillTrack(TrackThrough({c, c, c}, {30, 32.5, 30})));
  // A quaternion and its negation are one rotation.
  InstanceTrack flipped = TrackThrough({c, c}, {30, 30});
  Quat& q = flipped.boxes[1].rotation;
  q = {-q.w, -q.x, -q.y, -q.z};
  EXPECT_TRUE(IsStillTrack(flipped));
  // One box is held at every time; no boxes own nothing.
  EXPECT_TRUE(IsStillTrack(TrackThrough({c}, {30})));
  EXPECT_FALSE(IsStillTrack(InstanceTrack{}));
}

TEST(SceneGraph, MovingTracksLeaveTheStillOnesOut) {
  const Vec3 c{10, 5, 1};
  InstanceTrack parked = TrackThrough({c, c}, {30, 30});
  parked.id = "parked";
  InstanceTrack driving = TrackThrough({c, c + Vec3{2, 0, 0}}, {30, 30});
  driving.id = "driving";
  InstanceTrack turning = TrackThrough({c, c}, {30, 45});
  turning.id = "turning";
  const std::vector<InstanceTrack> moving = MovingTracks({parked, driving, turning});
  ASSERT_EQ(moving.size(), 2u);
  EXPECT_EQ(moving[0].id, "driving");
  EXPECT_EQ(moving[1].id, "turning");
  EXPECT_TRUE(MovingTracks({parked}).empty());
}

TEST(SceneGraph, StillInstancesTakeTheStaticGaussiansInTheirFirstBox) {
  // One moving instance already in the scene (owner 1) and two still tracks
  // appended (owners 2 and 3). Gaussian 0 is static inside the first still
  // box (within its 0.15 m margin), 1 inside the second, 2 inside the first
  // but on the far layer, 3 outside both, 4 inside the first but the moving
  // instance's, 5 on the road under the first box (below its raised floor).
  GaussianScene scene;
  scene.num_channels = 3;
  scene.instances.push_back(TrackThrough({{0, 0, 1}, {5, 0, 1}}, {0, 0}));
  const std::vector<Vec3> means = {{10, 5, 2.1}, {-10, 5, 1},  {10, 5, 1},
                                   {0, 20, 1},   {10, 5.5, 1}, {10, 5, 0.02}};
  scene.Resize(means.size());
  for (size_t i = 0; i < means.size(); ++i) {
    for (int a = 0; a < 3; ++a) scene.means[3 * i + a] = static_cast<float>(means[i][a]);
  }
  scene.owners[4] = 1;
  const std::vector<InstanceTrack> still = {TrackThrough({{10, 5, 1}, {10, 5, 1}}, {90, 90}),
                                            TrackThrough({{-10, 5, 1}, {-10, 5, 1}}, {0, 0})};
  const std::vector<uint8_t> far = {0, 0, 1};  // Shorter than the scene: the rest not far.
  const std::vector<float> means_before = scene.means;
  const std::vector<int64_t> taken = AdoptStillInstances(still, far, &scene);
  EXPECT_EQ(taken, (std::vector<int64_t>{1, 1}));
  EXPECT_EQ(scene.owners, (std::vector<uint32_t>{2, 3, 0, 0, 1, 0}));
  ASSERT_EQ(scene.instances.size(), 3u);
  EXPECT_EQ(scene.instances[1].boxes[0].center.x, 10);
  EXPECT_EQ(scene.instances[2].boxes[0].center.x, -10);
  EXPECT_EQ(scene.means, means_before);  // The first box is the canonical frame.
}

TEST(SceneGraph, CanonicalisationMatchesHandComputedPoint) {
  InstanceTrack track;
  TrackBox first;
  first.timestamp_us = 0;
  first.center = {0, 0, 0};
  first.size = {4, 2, 2};
  first.rotation = Quat{};
  TrackBox later = first;
  later.timestamp_us = 1000000;
  later.center = {10, 5, 0};
  later.rotation = Yaw(90);
  track.boxes = {first, later};
  // At t = 1 s the box's +x points along world +y; a point 1 m ahead of the
  // box centre is (10, 6, 0.5). In the canonical (first) box it is 1 m along
  // +x: (1, 0, 0.5).
  const Vec3 p = CanonicalFromWorld(track, 1000000) * Vec3{10, 6, 0.5};
  EXPECT_NEAR(p.x, 1.0, 1e-9);
  EXPECT_NEAR(p.y, 0.0, 1e-9);
  EXPECT_NEAR(p.z, 0.5, 1e-9);
  // Halfway in time: centre (5, 2.5, 0), yaw 45 degrees. The point 1 m ahead
  // is (5 + cos45, 2.5 + sin45, 0).
  const double s = std::sqrt(0.5);
  const Vec3 q = CanonicalFromWorld(track, 500000) * Vec3{5 + s, 2.5 + s, 0};
  EXPECT_NEAR(q.x, 1.0, 1e-9);
  EXPECT_NEAR(q.y, 0.0, 1e-9);
  // The formula p~ = R_1 R_t^T (p - c_t) + c_1 with a non-trivial first box.
  track.boxes[0].center = {1, 2, 3};
  track.boxes[0].rotation = Yaw(-90);
  const Vec3 r = CanonicalFromWorld(track, 1000000) * Vec3{10, 6, 0.5};
  // R_t^T (p - c_t) = (1, 0, 0.5); R_1 (yaw -90) maps x to -y: (0, -1, 0.5).
  EXPECT_NEAR(r.x, 1.0, 1e-9);
  EXPECT_NEAR(r.y, 1.0, 1e-9);
  EXPECT_NEAR(r.z, 3.5, 1e-9);
}

TEST(SceneGraph, OwnerIsOneBasedAndTimeDependent) {
  InstanceTrack a;
  a.boxes = {{0, {0, 0, 0}, {2, 2, 2}, Quat{}}, {1000000, {10, 0, 0}, {2, 2, 2}, Quat{}}};
  InstanceTrack b;
  b.boxes = {{0, {0, 5, 0}, {2, 2, 2}, Quat{}}};
  const std::vector<InstanceTrack> tracks = {a, b};
  EXPECT_EQ(OwnerAt({0, 0, 0}, tracks, 0), 1u);
  EXPECT_EQ(OwnerAt({0, 0, 0}, tracks, 1000000), 0u);  // The car moved on.
  EXPECT_EQ(OwnerAt({5, 0, 0}, tracks, 500000), 1u);
  EXPECT_EQ(OwnerAt({0, 5.5, 0}, tracks, 700000), 2u);  // b holds its only box.
  EXPECT_EQ(OwnerAt({0, 3, 0}, tracks, 0), 0u);
}

TEST(SceneGraph, BoxesAtAgreesWithPointInBoxEverywhere) {
  // Rotated boxes of several shapes and margins (a raised and a lowered
  // floor); points around them, many within a few centimetres of faces and
  // corners: Owner (which skips the exact test beyond each box's farthest
  // corner) names the first box PointInBox accepts, every time.
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<InstanceTrack> tracks(4);
  for (size_t k = 0; k < tracks.size(); ++k) {
    const double half = 0.5 * (0.3 + k), axis = std::sqrt(1 - 0.25);
    const Quat tilted{std::cos(half), 0.5 * std::sin(half), 0, axis * std::sin(half)};
    tracks[k].boxes = {{0, {2.0 * k, 0.5 * k, 0.2 * k}, {4.0 + k, 1.5 + 0.5 * k, 1.0 + k}, tilted}};
  }
  int inside = 0, near_surface = 0;
  for (const BoxMargin margin : {BoxMargin{}, kMembershipMargin, BoxMargin{0.3, -0.4}}) {
    const BoxesAt boxes(tracks, 0);
    for (int i = 0; i < 20000; ++i) {
      const TrackBox& box = tracks[i % tracks.size()].boxes[0];
      // A corner or face point of a box, pushed by up to 5 cm, or anywhere.
      const Vec3 corner{0.5 * box.size.x * (u(rng) > 0 ? 1 : u(rng)),
                        0.5 * box.size.y * (u(rng) > 0 ? 1 : -1),
                        0.5 * box.size.z * (u(rng) > 0 ? 1 : u(rng))};
      const Vec3 p = i % 3 == 0 ? Vec3{8 * u(rng), 8 * u(rng), 4 * u(rng)}
                                : box.center + ToMatrix(box.rotation) * corner +
                                      Vec3{0.05 * u(rng), 0.05 * u(rng), 0.05 * u(rng)};
      uint32_t expected = 0;
      for (size_t k = 0; k < tracks.size() && expected == 0; ++k) {
        if (PointInBox(p, tracks[k].boxes[0], margin)) expected = static_cast<uint32_t>(k + 1);
      }
      ASSERT_EQ(boxes.Owner(p, margin), expected) << p.x << " " << p.y << " " << p.z;
      inside += expected != 0;
      near_surface += i % 3 != 0;
    }
  }
  EXPECT_GT(inside, 10000);
  EXPECT_LT(inside, 50000);
  EXPECT_GT(near_surface, 30000);
}

TEST(SceneGraph, DynamicMaskCoversTheProjectedBox) {
  // Camera at the origin looking along world +z (identity pose), 100 x 100,
  // f = 100: a 2 x 2 x 2 box at z = 10 spans x, y in [-1, 1] -> pixels
  // [40, 60).
  const CameraModel camera(100, 100, 100, 100, 50, 50);
  InstanceTrack track;
  track.boxes = {{0, {0, 0, 10}, {2, 2, 2}, Quat{}}};
  const std::vector<uint8_t> mask = DynamicMask(camera, Rigid{}, {track}, 0);
  ASSERT_EQ(mask.size(), 10000u);
  EXPECT_EQ(mask[50 * 100 + 50], 1);
  EXPECT_EQ(mask[41 * 100 + 41], 1);
  EXPECT_EQ(mask[58 * 100 + 58], 1);
  EXPECT_EQ(mask[50 * 100 + 35], 0);
  EXPECT_EQ(mask[30 * 100 + 50], 0);
  int covered = 0;
  for (uint8_t m : mask) covered += m != 0;
  // The front face (z = 9) spans 2 / 9 * 100 = 22.2 px: ~22^2 pixels.
  EXPECT_NEAR(covered, 22 * 22, 60);
}

// The owner (1-based) of the box the ray o + s d, s >= 0, enters first (the
// test's own slab test, in each box's frame), 0 if none.
uint8_t OwnerAlongRay(const Vec3& origin, const Vec3& ray, const std::vector<TrackBox>& boxes) {
  double best = 1e300;
  uint8_t owner = 0;
  for (size_t k = 0; k < boxes.size(); ++k) {
    const Mat3 to_box = Transpose(ToMatrix(boxes[k].rotation));
    const Vec3 o = to_box * (origin - boxes[k].center), d = to_box * ray;
    double enter = 0, leave = 1e300;
    for (int a = 0; a < 3; ++a) {
      const double half = 0.5 * boxes[k].size[a];
      if (d[a] == 0) {
        if (std::abs(o[a]) > half) leave = -1;
        continue;
      }
      const double s0 = (-half - o[a]) / d[a], s1 = (half - o[a]) / d[a];
      enter = std::max(enter, std::min(s0, s1));
      leave = std::min(leave, std::max(s0, s1));
    }
    if (enter <= leave && enter < best) {
      best = enter;
      owner = static_cast<uint8_t>(k + 1);
    }
  }
  return owner;
}

TEST(SceneGraph, DynamicMaskNamesTheNearestBoxOfEveryRay) {
  // Boxes in front of a pinhole and an OpenCV camera, some overlapping on
  // screen, one partly off the image, one around the camera's plane, one
  // behind it: the mask (which tests only the pixels a box's corners can
  // reach, through a pinhole) names for every pixel the box each ray enters
  // first (away from the boxes' outlines, where rounding decides).
  CameraModel pinhole(80, 60, 60, 60, 40, 30);
  CameraModel distorted(80, 60, 60, 60, 40, 30);
  distorted.SetOpenCv(-0.2, 0.05, 0, 0, 0);
  const Rigid world_from_camera{ToMatrix(Yaw(20)), {0.5, -0.3, 0.2}};
  std::vector<InstanceTrack> tracks(6);
  const std::vector<std::pair<Vec3, Vec3>> placed = {
      {{0, 0, 12}, {8, 6, 4}},    {{1.5, 0.5, 8}, {1, 1, 2}}, {{7, 0, 9}, {2, 2, 2}},
      {{2.5, 0, 0.3}, {3, 2, 1}}, {{0, 0, -6}, {2, 2, 2}},    {{-4, -2, 20}, {10, 6, 5}}};
  for (size_t k = 0; k < tracks.size(); ++k) {
    const Vec3 centre = world_from_camera * placed[k].first;
    tracks[k].boxes = {{0, centre, placed[k].second, Yaw(15.0 * k)}};
  }
  std::vector<TrackBox> boxes;
  for (const InstanceTrack& track : tracks) boxes.push_back(track.boxes[0]);
  for (const CameraModel* camera : {&pinhole, &distorted}) {
    const std::vector<uint8_t> mask = DynamicMask(*camera, world_from_camera, tracks, 0);
    int compared = 0, owned = 0;
    for (int y = 0; y < 60; ++y) {
      for (int x = 0; x < 80; ++x) {
        Vec3 ray;
        ASSERT_TRUE(camera->Unproject(x + 0.5, y + 0.5, &ray));
        const Vec3 world_ray = world_from_camera.rotation * ray;
        // Rays within a pixel's width of another owner are left out.
        bool edge = false;
        const uint8_t centre = OwnerAlongRay(world_from_camera.translation, world_ray, boxes);
        for (const auto [dx, dy] : {std::pair{0.3, 0.0}, {-0.3, 0.0}, {0.0, 0.3}, {0.0, -0.3}}) {
          Vec3 near_ray;
          ASSERT_TRUE(camera->Unproject(x + 0.5 + dx, y + 0.5 + dy, &near_ray));
          edge |= OwnerAlongRay(world_from_camera.translation,
                                world_from_camera.rotation * near_ray, boxes) != centre;
        }
        if (edge) continue;
        ASSERT_EQ(mask[static_cast<size_t>(y) * 80 + x], centre) << x << " " << y;
        ++compared;
        owned += centre != 0;
      }
    }
    EXPECT_GT(compared, 3000);
    EXPECT_GT(owned, 1500);
    EXPECT_LT(owned, compared - 500);
  }
}

TEST(SceneGraph, BoxBehindTheCameraIsNotInTheMask) {
  const CameraModel camera(100, 100, 100, 100, 50, 50);
  InstanceTrack track;
  track.boxes = {{0, {0, 0, -10}, {2, 2, 2}, Quat{}}};
  const std::vector<uint8_t> mask = DynamicMask(camera, Rigid{}, {track}, 0);
  for (uint8_t m : mask) ASSERT_EQ(m, 0);
}

}  // namespace
}  // namespace pf
