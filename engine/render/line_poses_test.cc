// LinePoses: a global shutter's bits are CameraModel::Project's and
// LiftPixel's; through a rolling shutter a point projects onto the line that
// reads it and lifts back from that line's pose.
#include "engine/render/line_poses.h"

#include <cmath>

#include "gtest/gtest.h"

namespace pf {
namespace {

CameraModel Pinhole() { return CameraModel(160, 120, 150, 150, 80, 60); }

// A camera looking along +x (OpenCV axes: x right = -y world, y down = -z).
Rigid LookingAlongX(const Vec3& at) {
  Rigid pose;
  pose.rotation = Mat3::FromColumns({0, -1, 0}, {0, 0, -1}, {1, 0, 0});
  pose.translation = at;
  return pose;
}

TEST(LinePoses, AGlobalShutterGivesTheCameraModelsBits) {
  const CameraModel camera = Pinhole();
  const Rigid pose = LookingAlongX({1, 2, 1.5});
  const LinePoses lines(camera, pose);
  EXPECT_FALSE(lines.rolling());
  for (const Vec3& p : {Vec3{12, 1, 1}, Vec3{30, 7, -2}, Vec3{5, 2.5, 1.7}}) {
    double u, v, u0, v0;
    Vec3 in_camera;
    ASSERT_TRUE(lines.Project(p, &u, &v, &in_camera));
    ASSERT_TRUE(camera.Project(pose.Inverse() * p, &u0, &v0));
    EXPECT_EQ(u, u0);
    EXPECT_EQ(v, v0);
    Vec3 lifted, lifted0;
    ASSERT_TRUE(lines.Lift(u, v, in_camera.z, &lifted));
    ASSERT_TRUE(LiftPixel(camera, pose, u, v, in_camera.z, &lifted0));
    EXPECT_EQ(lifted.x, lifted0.x);
    EXPECT_EQ(lifted.y, lifted0.y);
    EXPECT_EQ(lifted.z, lifted0.z);
  }
  Vec3 behind;
  double u, v;
  EXPECT_FALSE(lines.Project({-5, 2, 1.5}, &u, &v, &behind));
}

TEST(LinePoses, EachReadoutOrdersItsLines) {
  using Readout = RollingShutter::Readout;
  EXPECT_DOUBLE_EQ(ReadoutFraction(Readout::kTopToBottom, 160, 120, 3, 0.5), 0);
  EXPECT_DOUBLE_EQ(ReadoutFraction(Readout::kTopToBottom, 160, 120, 3, 119.5), 1);
  EXPECT_DOUBLE_EQ(ReadoutFraction(Readout::kBottomToTop, 160, 120, 3, 119.5), 0);
  EXPECT_DOUBLE_EQ(ReadoutFraction(Readout::kLeftToRight, 160, 120, 80, 7), 79.5 / 159);
  EXPECT_DOUBLE_EQ(ReadoutFraction(Readout::kRightToLeft, 160, 120, 0.5, 7), 1);
  EXPECT_DOUBLE_EQ(ReadoutFraction(Readout::kRightToLeft, 160, 120, -20, 7), 1);  // Clamped.
}

// The camera drives 1.5 m forward and turns 2 degrees while its lines are
// read: every point projects to a pixel whose own line's pose sees it there,
// and lifting that pixel with the depth returned gives the point back.
TEST(LinePoses, ARollingShutterPointLandsOnTheLineThatReadsIt) {
  const CameraModel camera = Pinhole();
  const Rigid start = LookingAlongX({0, 0, 1.5});
  Rigid end = start;
  end.translation = end.translation + Vec3{1.5, 0.2, 0};
  const double turn = 2 * M_PI / 180 / 2;
  end.rotation = ToMatrix(Quat{std::cos(turn), 0, 0, std::sin(turn)}) * start.rotation;
  for (RollingShutter::Readout readout :
       {RollingShutter::Readout::kTopToBottom, RollingShutter::Readout::kBottomToTop,
        RollingShutter::Readout::kLeftToRight, RollingShutter::Readout::kRightToLeft}) {
    const LinePoses lines(camera, start, RollingShutter{readout, 40000, end});
    ASSERT_TRUE(lines.rolling());
    EXPECT_NEAR(lines.TimeOffsetUs(0.25), 10000, 1e-9);
    double worst_pixel = 0, worst_lift = 0, moved = 0;
    for (double x = 6; x <= 40; x += 2.5) {
      for (double y = -6; y <= 6; y += 1.5) {
        for (double z = -1; z <= 4; z += 1.25) {
          const Vec3 p{x, y, z};
          double u, v;
          Vec3 in_camera;
          if (!lines.Project(p, &u, &v, &in_camera)) continue;
          if (u < 0 || v < 0 || u > camera.width() || v > camera.height()) continue;
          // Seen from the pose of the line at (u, v), p is at (u, v).
          double u1, v1;
          ASSERT_TRUE(camera.Project(lines.WorldFromCameraAt(u, v).Inverse() * p, &u1, &v1));
          worst_pixel = std::max(worst_pixel, std::hypot(u1 - u, v1 - v));
          Vec3 lifted;
          ASSERT_TRUE(lines.Lift(u, v, in_camera.z, &lifted));
          worst_lift = std::max(worst_lift, Norm(lifted - p) / in_camera.z);
          // The first line's pose would put it elsewhere.
          double u0, v0;
          ASSERT_TRUE(camera.Project(start.Inverse() * p, &u0, &v0));
          moved = std::max(moved, std::hypot(u0 - u, v0 - v));
          // LineFromMiddle moves a middle-line camera point to its line.
          const Vec3 middle = lines.MiddleWorldFromCamera().Inverse() * p;
          const Vec3 onto = lines.LineFromMiddle(lines.Fraction(u, v)) * middle;
          const Vec3 direct = lines.WorldFromCameraAt(u, v).Inverse() * p;
          EXPECT_LT(Norm(onto - direct), 1e-5 * (1 + Norm(p)));
        }
      }
    }
    EXPECT_LT(worst_pixel, 0.005);
    EXPECT_LT(worst_lift, 2e-4);
    EXPECT_GT(moved, 5);  // The readout matters at this speed.
  }
}

}  // namespace
}  // namespace pf
