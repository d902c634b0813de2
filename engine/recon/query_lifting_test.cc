// Tests of lifting: queries and their Plücker rays; normals.
#include "engine/recon/query_lifting.h"

#include <gtest/gtest.h>

#include <cmath>

namespace pf {
namespace {

Rigid SomePose() {
  Rigid pose;
  const double a = 0.3;
  pose.rotation.m = {{{std::cos(a), 0, std::sin(a)}, {0, 1, 0}, {-std::sin(a), 0, std::cos(a)}}};
  pose.translation = {2, -1, 0.5};
  return pose;
}

TEST(QueryLifting, QueryHasPointColourAndPluckerRay) {
  ContextView view;
  view.camera = CameraModel(8, 6, 10, 10, 4, 3);
  view.world_from_camera = SomePose();
  view.rgb = ImageF(8, 6, 3);
  view.rgb.at(5, 2, 0) = 0.25f;
  view.rgb.at(5, 2, 1) = 0.5f;
  view.rgb.at(5, 2, 2) = 0.75f;
  ViewDepth depth;
  depth.width = 8;
  depth.height = 6;
  depth.depth.assign(48, 4.f);
  depth.source.assign(48, 0);
  Query12 q;
  ASSERT_TRUE(LiftQuery(view, depth, 5, 2, &q));
  EXPECT_FLOAT_EQ(q[3], 0.25f);
  EXPECT_FLOAT_EQ(q[5], 0.75f);
  const Vec3 p{q[0], q[1], q[2]}, d{q[6], q[7], q[8]}, m{q[9], q[10], q[11]};
  const Vec3 o = view.world_from_camera.translation;
  EXPECT_NEAR(Norm(d), 1.0, 1e-6);
  // The point lies on the ray: (p - o) parallel to d, and p x d = m.
  EXPECT_NEAR(Norm(Cross(p - o, d)), 0.0, 1e-5);
  const Vec3 pm = Cross(p, d);
  EXPECT_NEAR(pm.x, m.x, 1e-5);
  EXPECT_NEAR(pm.y, m.y, 1e-5);
  EXPECT_NEAR(pm.z, m.z, 1e-5);
  EXPECT_FALSE(LiftQuery(view, depth, 8, 0, &q));
}

TEST(QueryLifting, NormalsOfAPlaneFaceTheCamera) {
  // Camera at the origin looking along +z at the plane y = 2 (the ground
  // in OpenCV axes): depth z = 2 f / (v - cy) below the horizon.
  ContextView view;
  view.camera = CameraModel(32, 32, 20, 20, 16, 0);
  view.rgb = ImageF(32, 32, 3);
  ViewDepth depth;
  depth.width = depth.height = 32;
  depth.depth.resize(32 * 32);
  depth.source.assign(32 * 32, 0);
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x) depth.depth[y * 32 + x] = float(2.0 * 20 / (y + 0.5));
  const LiftedView lifted = LiftView(view, depth);
  for (int i : {5 * 32 + 5, 16 * 32 + 16, 31 * 32 + 31, 0}) {
    ASSERT_TRUE(lifted.valid[i]);
    EXPECT_NEAR(lifted.points[3 * i + 1], 2.0, 1e-4);  // On the plane.
    EXPECT_NEAR(lifted.normals[3 * i + 0], 0.0, 1e-3);
    EXPECT_NEAR(lifted.normals[3 * i + 1], -1.0, 1e-3);  // Up (-y), towards the camera.
    EXPECT_NEAR(lifted.normals[3 * i + 2], 0.0, 1e-3);
  }
}

// Pixels on the ego vehicle's body are never lifted, and their neighbours'
// normals do not lean on them.
TEST(QueryLifting, EgoBodyPixelsAreNotLifted) {
  ContextView view;
  view.camera = CameraModel(16, 16, 20, 20, 8, 8);
  view.rgb = ImageF(16, 16, 3);
  view.ego.assign(16 * 16, 0);
  for (int x = 0; x < 16; ++x) view.ego[12 * 16 + x] = view.ego[13 * 16 + x] = 1;  // Rows 12-13.
  ViewDepth depth;
  depth.width = depth.height = 16;
  depth.depth.assign(16 * 16, 5.f);
  for (int x = 0; x < 16; ++x) depth.depth[12 * 16 + x] = depth.depth[13 * 16 + x] = 1.f;
  depth.source.assign(16 * 16, 0);
  const LiftedView lifted = LiftView(view, depth);
  int valid = 0;
  for (uint8_t v : lifted.valid) valid += v;
  EXPECT_EQ(valid, 16 * 14);
  for (int x = 0; x < 16; ++x) {
    EXPECT_FALSE(lifted.valid[12 * 16 + x]);
    EXPECT_FALSE(lifted.valid[13 * 16 + x]);
  }
  // Row 11, next to the body, lies on the 5 m plane: it faces the camera.
  const int i = 11 * 16 + 8;
  ASSERT_TRUE(lifted.valid[i]);
  EXPECT_NEAR(lifted.normals[3 * i + 2], -1.0, 1e-3);
}

}  // namespace
}  // namespace pf
