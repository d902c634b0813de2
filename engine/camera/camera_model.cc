// Camera models.
#include "engine/camera/camera_model.h"

#include <cmath>

#include "absl/strings/str_cat.h"
#include "pointforward/v1/clip.pb.h"

namespace pf {

CameraModel::CameraModel(int width, int height, double fx, double fy, double cx, double cy)
    : width_(width), height_(height) {
  lens_.fx = fx, lens_.fy = fy, lens_.cx = cx, lens_.cy = cy;
}

void CameraModel::SetOpenCv(double k1, double k2, double p1, double p2, double k3) {
  lens_.kind = Lens::kOpenCv;
  lens_.k1 = k1, lens_.k2 = k2, lens_.p1 = p1, lens_.p2 = p2, lens_.k3 = k3, lens_.k4 = 0;
  UpdateValidRadius();
}

void CameraModel::SetFisheye(double k1, double k2, double k3, double k4) {
  lens_.kind = Lens::kFisheye;
  lens_.k1 = k1, lens_.k2 = k2, lens_.k3 = k3, lens_.k4 = k4, lens_.p1 = 0, lens_.p2 = 0;
  UpdateValidRadius();
}

void CameraModel::UpdateValidRadius() {
  // Walk outwards until the distorted radius stops growing with the
  // undistorted one (or up to a radius far beyond any real lens).
  lens_.max_radius = 1e6;
  constexpr double kStep = 1e-3, kLimit = 20.0;
  double prev = 0;
  for (double r = kStep; r < kLimit; r += kStep) {
    double xd, yd;
    Distort(r, 0, &xd, &yd);
    // Include the tangential terms' worst direction by also checking y.
    double xd2, yd2;
    Distort(0, r, &xd2, &yd2);
    const double rd = std::min(std::hypot(xd, yd), std::hypot(xd2, yd2));
    if (rd <= prev) {
      lens_.max_radius = r - kStep;
      return;
    }
    prev = rd;
  }
}

void CameraModel::Distort(double xn, double yn, double* xd, double* yd) const {
  LensDistort(lens_, xn, yn, xd, yd);
}

bool CameraModel::Undistort(double xd, double yd, double* xn, double* yn) const {
  if (lens_.kind == Lens::kPinhole) {
    *xn = xd;
    *yn = yd;
    return true;
  }
  // Newton's method on Distort(x) - target, with a numeric Jacobian.
  double x = xd, y = yd;
  for (int iter = 0; iter < 50; ++iter) {
    double fx, fy;
    Distort(x, y, &fx, &fy);
    const double ex = fx - xd, ey = fy - yd;
    if (std::abs(ex) < 1e-12 && std::abs(ey) < 1e-12) break;
    constexpr double h = 1e-7;
    double fxx, fyx, fxy, fyy;
    Distort(x + h, y, &fxx, &fyx);
    Distort(x, y + h, &fxy, &fyy);
    const double j00 = (fxx - fx) / h, j10 = (fyx - fy) / h;
    const double j01 = (fxy - fx) / h, j11 = (fyy - fy) / h;
    const double det = j00 * j11 - j01 * j10;
    if (std::abs(det) < 1e-15) return false;
    x -= (j11 * ex - j01 * ey) / det;
    y -= (-j10 * ex + j00 * ey) / det;
    if (!std::isfinite(x) || !std::isfinite(y)) return false;
  }
  double cx, cy;
  Distort(x, y, &cx, &cy);
  if (std::hypot(cx - xd, cy - yd) > 1e-6) return false;
  if (std::hypot(x, y) > lens_.max_radius) return false;
  *xn = x;
  *yn = y;
  return true;
}

bool CameraModel::Project(const Vec3& p, double* u, double* v) const {
  return LensProject(lens_, p.x, p.y, p.z, u, v);
}

bool CameraModel::Unproject(double u, double v, Vec3* ray) const {
  double xn, yn;
  if (!Undistort((u - lens_.cx) / lens_.fx, (v - lens_.cy) / lens_.fy, &xn, &yn)) return false;
  *ray = {xn, yn, 1.0};
  return true;
}

absl::StatusOr<CameraModel> CameraModelFromProto(const pointforward::v1::Camera& camera) {
  const std::string where = absl::StrCat("camera '", camera.id(), "'");
  if (camera.width() <= 0 || camera.height() <= 0) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": width and height must be positive"));
  }
  const auto& k = camera.intrinsics();
  for (double value : {k.fx(), k.fy(), k.cx(), k.cy()}) {
    if (!std::isfinite(value)) {
      return absl::InvalidArgumentError(absl::StrCat(where, ".intrinsics: non-finite number"));
    }
  }
  if (k.fx() <= 0 || k.fy() <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ".intrinsics: focal length must be positive"));
  }
  CameraModel model(camera.width(), camera.height(), k.fx(), k.fy(), k.cx(), k.cy());
  const auto& d = camera.distortion();
  for (double value : {d.k1(), d.k2(), d.p1(), d.p2(), d.k3(), d.k4()}) {
    if (!std::isfinite(value)) {
      return absl::InvalidArgumentError(absl::StrCat(where, ".distortion: non-finite number"));
    }
  }
  switch (d.model()) {
    case pointforward::v1::Distortion::OPENCV:
      model.SetOpenCv(d.k1(), d.k2(), d.p1(), d.p2(), d.k3());
      break;
    case pointforward::v1::Distortion::FISHEYE:
      model.SetFisheye(d.k1(), d.k2(), d.k3(), d.k4());
      break;
    default:
      break;
  }
  return model;
}

bool LiftPixel(const CameraModel& camera, const Rigid& world_from_camera, double u, double v,
               double depth, Vec3* world) {
  if (!(depth > 0)) return false;
  Vec3 ray;
  if (!camera.Unproject(u, v, &ray)) return false;
  *world = world_from_camera * (depth * ray);
  return true;
}

}  // namespace pf
