// Tests for the geometry helpers.
#include "common/geometry.h"

#include <gtest/gtest.h>

namespace pf {
namespace {

TEST(Geometry, QuaternionMatrixRoundTripAndRotatesAsHamilton) {
  // 90 degrees about z: x axis goes to y axis.
  const Quat q{std::cos(M_PI / 4), 0, 0, std::sin(M_PI / 4)};
  const Vec3 v = ToMatrix(q) * Vec3{1, 0, 0};
  EXPECT_NEAR(v.x, 0, 1e-12);
  EXPECT_NEAR(v.y, 1, 1e-12);
  const Quat arbitrary = QuatNormalized({0.3, -0.5, 0.7, 0.2});
  const Quat back = FromMatrix(ToMatrix(arbitrary));
  EXPECT_NEAR(back.w, arbitrary.w, 1e-12);
  EXPECT_NEAR(back.x, arbitrary.x, 1e-12);
  EXPECT_NEAR(back.y, arbitrary.y, 1e-12);
  EXPECT_NEAR(back.z, arbitrary.z, 1e-12);
}

TEST(Geometry, SlerpHalfwayIsHalfTheAngle) {
  const Quat a{1, 0, 0, 0};
  const Quat b{std::cos(M_PI / 4), 0, 0, std::sin(M_PI / 4)};  // 90 deg about z.
  const Quat mid = Slerp(a, b, 0.5);
  EXPECT_NEAR(mid.w, std::cos(M_PI / 8), 1e-12);
  EXPECT_NEAR(mid.z, std::sin(M_PI / 8), 1e-12);
}

TEST(Geometry, RotationFromVectorIsTheQuaternionsRotation) {
  const Vec3 axis = Normalized({0.3, -0.5, 0.7});
  const double angle = 0.8;
  const Quat q{std::cos(angle / 2), std::sin(angle / 2) * axis.x, std::sin(angle / 2) * axis.y,
               std::sin(angle / 2) * axis.z};
  const Mat3 expected = ToMatrix(q), r = RotationFromVector(angle * axis);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(r.m[i][j], expected.m[i][j], 1e-12);
  }
  // Small vectors: I + [w]x to first order.
  const Vec3 w{1e-7, -2e-7, 3e-7}, v{1, 2, 3};
  EXPECT_NEAR(Norm(RotationFromVector(w) * v - (v + Cross(w, v))), 0, 1e-12);
  EXPECT_EQ(RotationFromVector({0, 0, 0}).m, Mat3::Identity().m);
}

TEST(Geometry, RigidInverseAndRigidity) {
  Rigid t{ToMatrix(QuatNormalized({0.9, 0.1, -0.3, 0.2})), {1, 2, 3}};
  const Vec3 p{0.5, -4, 2};
  const Vec3 back = t.Inverse() * (t * p);
  EXPECT_NEAR(Norm(back - p), 0, 1e-12);
  auto m = t.ToRowMajor();
  EXPECT_LT(RigidityError(m.data()), 1e-12);
  m[0] *= 0.7;  // Scale one axis: no longer rigid.
  double det = 0;
  EXPECT_GT(RigidityError(m.data(), &det), 0.1);
  EXPECT_LT(det, 0.95);
}

}  // namespace
}  // namespace pf
