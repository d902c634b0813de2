// Tests for camera models: projection and its inverse for each model.
#include "engine/camera/camera_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "engine/camera/image_pixel.h"
#include "pointforward/v1/clip.pb.h"

namespace pf {
namespace {

void ExpectUnprojectInvertsProject(const CameraModel& cam) {
  int checked = 0;
  for (double x = -1.0; x <= 1.0; x += 0.25) {
    for (double y = -0.6; y <= 0.6; y += 0.2) {
      const Vec3 p{x * 7, y * 7, 7};
      double u, v;
      if (!cam.Project(p, &u, &v)) continue;
      Vec3 ray;
      ASSERT_TRUE(cam.Unproject(u, v, &ray)) << x << "," << y;
      EXPECT_NEAR(ray.x * 7, p.x, 1e-6);
      EXPECT_NEAR(ray.y * 7, p.y, 1e-6);
      ++checked;
    }
  }
  EXPECT_GT(checked, 40);
}

TEST(ImagePixel, FloorsInsideTheImageAndRejectsEverythingElse) {
  int x = -7, y = -7;
  ASSERT_TRUE(PixelInImage(0.0, 0.0, 768, 576, &x, &y));
  EXPECT_EQ(x, 0);
  EXPECT_EQ(y, 0);
  ASSERT_TRUE(PixelInImage(767.999, 575.5, 768, 576, &x, &y));
  EXPECT_EQ(x, 767);
  EXPECT_EQ(y, 575);
  ASSERT_TRUE(PixelInImage(12.5, 3.99, 768, 576, &x, &y));
  EXPECT_EQ(x, 12);
  EXPECT_EQ(y, 3);
  x = y = -7;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  // The borders, just outside, and what a point near the camera plane
  // projects to: far outside int's range, where a cast would be undefined.
  for (const auto& [u, v] : std::vector<std::pair<double, double>>{{768.0, 0.0},
                                                                   {0.0, 576.0},
                                                                   {-1e-9, 10.0},
                                                                   {10.0, -0.5},
                                                                   {2.5e10, 10.0},
                                                                   {-2.5e10, 10.0},
                                                                   {10.0, 1e300},
                                                                   {nan, 10.0},
                                                                   {10.0, nan},
                                                                   {inf, 10.0},
                                                                   {10.0, -inf}}) {
    EXPECT_FALSE(PixelInImage(u, v, 768, 576, &x, &y)) << u << ", " << v;
  }
  EXPECT_EQ(x, -7);  // Untouched when false.
  EXPECT_EQ(y, -7);
}

TEST(CameraModel, PinholeProjectsPrincipalPointAndInverts) {
  const CameraModel cam(640, 480, 500, 510, 320, 240);
  double u, v;
  ASSERT_TRUE(cam.Project({0, 0, 3}, &u, &v));
  EXPECT_DOUBLE_EQ(u, 320);
  EXPECT_DOUBLE_EQ(v, 240);
  ASSERT_TRUE(cam.Project({1, -2, 4}, &u, &v));
  EXPECT_DOUBLE_EQ(u, 320 + 500 * 0.25);
  EXPECT_DOUBLE_EQ(v, 240 - 510 * 0.5);
  EXPECT_FALSE(cam.Project({0, 0, -1}, &u, &v));
  ExpectUnprojectInvertsProject(cam);
}

TEST(CameraModel, OpenCvMatchesTheFormulaAndInverts) {
  CameraModel cam(1920, 1280, 2000, 2000, 960, 640);
  cam.SetOpenCv(-0.3, 0.1, 0.001, -0.002, -0.01);
  double xd, yd;
  const double x = 0.2, y = -0.1, r2 = x * x + y * y;
  cam.Distort(x, y, &xd, &yd);
  const double radial = 1 - 0.3 * r2 + 0.1 * r2 * r2 - 0.01 * r2 * r2 * r2;
  EXPECT_NEAR(xd, x * radial + 2 * 0.001 * x * y - 0.002 * (r2 + 2 * x * x), 1e-15);
  EXPECT_NEAR(yd, y * radial + 0.001 * (r2 + 2 * y * y) + 2 * -0.002 * x * y, 1e-15);
  ExpectUnprojectInvertsProject(cam);
  // Far off-axis points beyond the monotonic radius are not projected.
  double u, v;
  EXPECT_FALSE(cam.Project({100, 0, 1}, &u, &v));
}

TEST(CameraModel, FisheyeIsEquidistant) {
  CameraModel cam(1000, 1000, 300, 300, 500, 500);
  cam.SetFisheye(0, 0, 0, 0);
  double u, v;
  // 45 degrees off axis: distorted radius is theta = pi / 4.
  ASSERT_TRUE(cam.Project({1, 0, 1}, &u, &v));
  EXPECT_NEAR(u, 500 + 300 * M_PI / 4, 1e-9);
  cam.SetFisheye(0.05, -0.01, 0.002, -0.0003);
  ExpectUnprojectInvertsProject(cam);
}

TEST(CameraModel, FromProtoRejectsBadIntrinsicsNamingTheField) {
  pointforward::v1::Camera camera;
  camera.set_id("front");
  camera.set_width(10);
  camera.set_height(10);
  camera.mutable_intrinsics()->set_fx(0);
  camera.mutable_intrinsics()->set_fy(5);
  auto model = CameraModelFromProto(camera);
  ASSERT_FALSE(model.ok());
  EXPECT_NE(model.status().message().find("camera 'front'.intrinsics"), std::string::npos);
}

TEST(CameraModel, LiftPixelInvertsProjection) {
  CameraModel camera(64, 48, 50, 52, 31.5, 24.2);
  camera.SetOpenCv(-0.1, 0.01, 0.001, -0.002, 0.0);
  Rigid pose;  // Turned 0.3 rad about y, then moved.
  const double a = 0.3;
  pose.rotation.m = {{{std::cos(a), 0, std::sin(a)}, {0, 1, 0}, {-std::sin(a), 0, std::cos(a)}}};
  pose.translation = {2, -1, 0.5};
  const Rigid camera_from_world = pose.Inverse();
  for (double u : {3.5, 20.25, 60.5}) {
    for (double v : {1.5, 30.75}) {
      Vec3 world;
      ASSERT_TRUE(LiftPixel(camera, pose, u, v, 7.5, &world));
      const Vec3 pc = camera_from_world * world;
      EXPECT_NEAR(pc.z, 7.5, 1e-9);
      double pu, pv;
      ASSERT_TRUE(camera.Project(pc, &pu, &pv));
      EXPECT_NEAR(pu, u, 1e-6);
      EXPECT_NEAR(pv, v, 1e-6);
    }
  }
  Vec3 unused;
  EXPECT_FALSE(LiftPixel(camera, pose, 10, 10, 0.0, &unused));
}

}  // namespace
}  // namespace pf
