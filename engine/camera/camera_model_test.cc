// Tests for camera models: projection and its inverse for each model.
#include "engine/camera/camera_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

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

// An f-theta lens as automotive surround cameras have: f (theta - 0.05
// theta^3) pixels, 120 degrees across a 768-pixel image.
std::vector<double> SurroundPolynomial() {
  const double side = M_PI / 3, f = 384 / (side - 0.05 * side * side * side);
  return {0, f, 0, -0.05 * f, 0, 0};
}

double PolynomialAt(const std::vector<double>& c, double x) {
  double value = 0;
  for (size_t i = c.size(); i-- > 0;) value = value * x + c[i];
  return value;
}

TEST(CameraModel, FThetaPixelDistanceIsThePolynomialOfTheAngle) {
  CameraModel cam(768, 576, 1, 1, 383.5, 290.25);
  const std::vector<double> poly = SurroundPolynomial();
  cam.SetFTheta(poly);
  EXPECT_EQ(cam.kind(), CameraModel::Kind::kFTheta);
  EXPECT_DOUBLE_EQ(cam.fx(), poly[1]);
  EXPECT_DOUBLE_EQ(cam.fy(), poly[1]);
  ASSERT_EQ(cam.ftheta_pixels().size(), 6u);
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(cam.ftheta_pixels()[i], poly[i], 1e-12);
  int checked = 0;
  for (double theta_deg : {0.5, 10.0, 30.0, 45.0, 60.0, 75.0, 85.0}) {
    for (double azimuth_deg : {0.0, 37.0, 90.0, 200.0, 311.0}) {
      const double theta = theta_deg * M_PI / 180, phi = azimuth_deg * M_PI / 180;
      const Vec3 p{std::sin(theta) * std::cos(phi) * 4, std::sin(theta) * std::sin(phi) * 4,
                   std::cos(theta) * 4};
      double u, v;
      ASSERT_TRUE(cam.Project(p, &u, &v)) << theta_deg;
      const double distance = PolynomialAt(poly, theta);
      EXPECT_NEAR(u, 383.5 + distance * std::cos(phi), 1e-9) << theta_deg << " " << azimuth_deg;
      EXPECT_NEAR(v, 290.25 + distance * std::sin(phi), 1e-9) << theta_deg << " " << azimuth_deg;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 35);
  double u, v;
  ASSERT_TRUE(cam.Project({0, 0, 2}, &u, &v));
  EXPECT_DOUBLE_EQ(u, 383.5);
  EXPECT_DOUBLE_EQ(v, 290.25);
  EXPECT_FALSE(cam.Project({1, 0, -0.1}, &u, &v));  // Behind: past 90 degrees.
}

TEST(CameraModel, FThetaRoundTripsOverTheWholeFieldOfView) {
  CameraModel cam(768, 576, 1, 1, 384, 288);
  cam.SetFTheta(SurroundPolynomial());
  // Every 4th pixel of the image, corners and edges included: unprojected,
  // then projected back to the same place.
  int pixels = 0;
  double worst_px = 0;
  for (int y = 0; y <= 576; y += 4) {
    for (int x = 0; x <= 768; x += 4) {
      Vec3 ray;
      ASSERT_TRUE(cam.Unproject(x, y, &ray)) << x << ", " << y;
      EXPECT_DOUBLE_EQ(ray.z, 1.0);
      double u, v;
      ASSERT_TRUE(cam.Project(3.0 * ray, &u, &v)) << x << ", " << y;
      worst_px = std::max(worst_px, std::hypot(u - x, v - y));
      ++pixels;
    }
  }
  EXPECT_EQ(pixels, 193 * 145);
  EXPECT_LT(worst_px, 1e-8);
  // The corners lie 480 px from the centre, 78 degrees off the axis: the
  // angle whose polynomial is 480.
  Vec3 corner;
  ASSERT_TRUE(cam.Unproject(0, 0, &corner));
  const double corner_theta = std::atan(std::hypot(corner.x, corner.y));
  EXPECT_NEAR(PolynomialAt(SurroundPolynomial(), corner_theta), 480, 1e-8);
  EXPECT_NEAR(corner_theta * 180 / M_PI, 78.16, 0.01);
  // Every direction up to 87 degrees: projected, then unprojected to the
  // same direction.
  double worst_rad = 0;
  for (double theta = 0; theta < 87 * M_PI / 180; theta += 0.01) {
    for (double phi = 0; phi < 2 * M_PI; phi += 0.3) {
      const Vec3 p{std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi),
                   std::cos(theta)};
      double u, v;
      ASSERT_TRUE(cam.Project(p, &u, &v));
      Vec3 ray;
      ASSERT_TRUE(cam.Unproject(u, v, &ray)) << theta;
      const Vec3 back = Normalized(ray);
      worst_rad = std::max(worst_rad, std::acos(std::min(1.0, Dot(back, p))));
    }
  }
  EXPECT_LT(worst_rad, 1e-7);
}

TEST(CameraModel, FThetaOfALinearPolynomialIsTheEquidistantFisheye) {
  CameraModel ftheta(1000, 800, 1, 1, 500, 400), fisheye(1000, 800, 310, 310, 500, 400);
  ftheta.SetFTheta({0, 310});
  fisheye.SetFisheye(0, 0, 0, 0);
  for (double x : {-3.0, -0.4, 0.0, 0.7, 2.5}) {
    for (double y : {-2.0, 0.1, 1.3}) {
      double u1, v1, u2, v2;
      ASSERT_TRUE(ftheta.Project({x, y, 1.5}, &u1, &v1));
      ASSERT_TRUE(fisheye.Project({x, y, 1.5}, &u2, &v2));
      EXPECT_NEAR(u1, u2, 1e-9);
      EXPECT_NEAR(v1, v2, 1e-9);
    }
  }
}

// An FTHETA manifest camera of 768x576 with `poly` and `inverse`.
pointforward::v1::Camera FThetaCamera(const std::vector<double>& poly,
                                      const std::vector<double>& inverse) {
  pointforward::v1::Camera camera;
  camera.set_id("surround");
  camera.set_width(768);
  camera.set_height(576);
  camera.mutable_intrinsics()->set_cx(384);
  camera.mutable_intrinsics()->set_cy(288);
  camera.mutable_distortion()->set_model(pointforward::v1::Distortion::FTHETA);
  for (double c : poly) camera.mutable_distortion()->add_ftheta_poly(c);
  for (double c : inverse) camera.mutable_distortion()->add_ftheta_inverse_poly(c);
  return camera;
}

// The message of CameraModelFromProto's error for `camera`, or "ok".
std::string FromProtoError(const pointforward::v1::Camera& camera) {
  const absl::StatusOr<CameraModel> model = CameraModelFromProto(camera);
  return model.ok() ? "ok" : std::string(model.status().message());
}

TEST(CameraModel, FThetaFromProtoTakesEitherPolynomial) {
  const std::vector<double> poly = SurroundPolynomial();
  absl::StatusOr<CameraModel> model = CameraModelFromProto(FThetaCamera(poly, {}));
  ASSERT_TRUE(model.ok()) << model.status();
  EXPECT_EQ(model->kind(), CameraModel::Kind::kFTheta);
  EXPECT_DOUBLE_EQ(model->fx(), poly[1]);

  // Only the inverse, pixels to angle, as calibration tools give it: here
  // the least-squares inverse of the surround lens over the image (degree 5,
  // within 0.01 px of it). The fitted forward polynomial lands every angle
  // within 0.05 px of the true one.
  std::vector<double> inverse = {0, 1 / poly[1]};
  {
    // theta(r) by a fit of degree 5 through samples of the true inverse.
    CameraModel truth(768, 576, 1, 1, 384, 288);
    truth.SetFTheta(poly);
    std::vector<std::pair<double, double>> samples;  // (r px, theta).
    for (int k = 0; k <= 200; ++k) {
      const double r = 480.0 * k / 200;
      Vec3 ray;
      ASSERT_TRUE(truth.Unproject(384 + r, 288, &ray));
      samples.emplace_back(r, std::atan(std::hypot(ray.x, ray.y)));
    }
    // Normal equations in r / 480 for conditioning.
    double m[5][6] = {};
    for (const auto& [r, theta] : samples) {
      double p[5], t = 1;
      for (int i = 0; i < 5; ++i) p[i] = (t *= r / 480);
      for (int i = 0; i < 5; ++i) {
        for (int j = 0; j < 5; ++j) m[i][j] += p[i] * p[j];
        m[i][5] += p[i] * theta;
      }
    }
    for (int c = 0; c < 5; ++c) {
      for (int r = 0; r < 5; ++r) {
        if (r == c) continue;
        const double f = m[r][c] / m[c][c];
        for (int k = c; k < 6; ++k) m[r][k] -= f * m[c][k];
      }
    }
    inverse.assign(6, 0.0);
    for (int i = 0; i < 5; ++i) inverse[i + 1] = m[i][5] / m[i][i] / std::pow(480.0, i + 1);
  }
  model = CameraModelFromProto(FThetaCamera({}, inverse));
  ASSERT_TRUE(model.ok()) << model.status();
  CameraModel truth(768, 576, 1, 1, 384, 288);
  truth.SetFTheta(poly);
  for (double theta_deg = 1; theta_deg < 78; theta_deg += 7) {
    const double theta = theta_deg * M_PI / 180;
    const Vec3 p{std::sin(theta), 0, std::cos(theta)};
    double u1, v1, u2, v2;
    ASSERT_TRUE(model->Project(p, &u1, &v1));
    ASSERT_TRUE(truth.Project(p, &u2, &v2));
    EXPECT_NEAR(u1, u2, 0.05) << theta_deg;
  }
  // Both, agreeing; fx and fy at 0 or the centre's focal length.
  pointforward::v1::Camera both = FThetaCamera(poly, inverse);
  both.mutable_intrinsics()->set_fx(poly[1]);
  EXPECT_EQ(FromProtoError(both), "ok");
}

TEST(CameraModel, FThetaFromProtoNamesTheFieldAtFault) {
  const std::vector<double> poly = SurroundPolynomial();
  auto expect_error = [](const pointforward::v1::Camera& camera, const std::string& field) {
    const std::string message = FromProtoError(camera);
    EXPECT_EQ(message.rfind("camera 'surround'." + field + ": ", 0), 0u) << message;
  };
  expect_error(FThetaCamera({}, {}), "distortion.fthetaPoly");
  expect_error(FThetaCamera({0.5, poly[1]}, {}), "distortion.fthetaPoly[0]");
  expect_error(FThetaCamera({0, -300}, {}), "distortion.fthetaPoly[1]");
  expect_error(FThetaCamera({0, 1, 2, 3, 4, 5, 6}, {}), "distortion.fthetaPoly");
  expect_error(FThetaCamera({0, std::nan("")}, {}), "distortion.fthetaPoly");
  // Swapped: the angle polynomial given as the inverse.
  expect_error(FThetaCamera({0, 1 / poly[1]}, poly), "distortion.fthetaInversePoly");
  // An inverse 20 % off the forward polynomial.
  expect_error(FThetaCamera({0, 300}, {0, 1 / 360.0}), "distortion.fthetaInversePoly");
  // An inverse whose angle does not grow.
  expect_error(FThetaCamera({}, {0, -0.01}), "distortion.fthetaInversePoly");
  pointforward::v1::Camera focal = FThetaCamera(poly, {});
  focal.mutable_intrinsics()->set_fy(0.9 * poly[1]);
  expect_error(focal, "intrinsics.fy");
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
