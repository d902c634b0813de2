// The projection of a camera model as plain numbers, so that host code
// (CameraModel) and CUDA kernels (the GPU rasterizer) project through the
// same arithmetic: pinhole, OpenCV (k1, k2, p1, p2, k3), equidistant
// fisheye (k1..k4) and f-theta (the distance from the principal point a
// polynomial of the angle from the optical axis), in double.
#ifndef POINTFORWARD_ENGINE_CAMERA_LENS_H_
#define POINTFORWARD_ENGINE_CAMERA_LENS_H_

#include <cmath>

#include "common/host_device.h"

namespace pf {

struct Lens {
  enum Kind : int { kPinhole = 0, kOpenCv = 1, kFisheye = 2, kFTheta = 3 };
  static constexpr int kFThetaTerms = 6;
  int kind = kPinhole;
  double fx = 1, fy = 1, cx = 0, cy = 0;
  double k1 = 0, k2 = 0, k3 = 0, k4 = 0, p1 = 0, p2 = 0;
  // f-theta: the distorted normalised radius at angle theta from the axis is
  // sum_i ftheta[i] theta^i (the pixel distance over fx; fx = fy, the
  // polynomial's slope at the centre, so ftheta[1] = 1 and ftheta[0] = 0).
  double ftheta[kFThetaTerms] = {0, 1, 0, 0, 0, 0};
  double max_radius = 1e6;  // Largest undistorted normalised radius projected.
};

// Maps undistorted normalised coordinates (x/z, y/z) to distorted ones.
PF_HD inline void LensDistort(const Lens& lens, double xn, double yn, double* xd, double* yd) {
  if (lens.kind == Lens::kOpenCv) {
    const double r2 = xn * xn + yn * yn;
    const double radial = 1 + r2 * (lens.k1 + r2 * (lens.k2 + r2 * lens.k3));
    *xd = xn * radial + 2 * lens.p1 * xn * yn + lens.p2 * (r2 + 2 * xn * xn);
    *yd = yn * radial + lens.p1 * (r2 + 2 * yn * yn) + 2 * lens.p2 * xn * yn;
    return;
  }
  if (lens.kind == Lens::kFisheye) {
    const double r = std::sqrt(xn * xn + yn * yn);
    if (r < 1e-12) {
      *xd = xn;
      *yd = yn;
      return;
    }
    const double theta = std::atan(r);
    const double t2 = theta * theta;
    const double theta_d =
        theta * (1 + t2 * (lens.k1 + t2 * (lens.k2 + t2 * (lens.k3 + t2 * lens.k4))));
    *xd = xn * theta_d / r;
    *yd = yn * theta_d / r;
    return;
  }
  if (lens.kind == Lens::kFTheta) {
    const double r = std::sqrt(xn * xn + yn * yn);
    if (r < 1e-12) {
      *xd = xn;
      *yd = yn;
      return;
    }
    const double theta = std::atan(r);
    double rd = 0;
    for (int i = Lens::kFThetaTerms - 1; i >= 0; --i) rd = rd * theta + lens.ftheta[i];
    *xd = xn * rd / r;
    *yd = yn * rd / r;
    return;
  }
  *xd = xn;
  *yd = yn;
}

// The 2x2 Jacobian of the pixel with respect to undistorted normalised
// coordinates at (xn, yn), row-major (d[0] = du/dxn, d[1] = du/dyn, d[2] =
// dv/dxn, d[3] = dv/dyn), by central differences of LensDistort (step 1e-6):
// what the rasterizer linearises a Gaussian's footprint with.
PF_HD inline void LensJacobian(const Lens& lens, double xn, double yn, double d[4]) {
  constexpr double h = 1e-6;
  double ax, ay, bx, by, cx, cy, dx, dy;
  LensDistort(lens, xn + h, yn, &ax, &ay);
  LensDistort(lens, xn - h, yn, &bx, &by);
  LensDistort(lens, xn, yn + h, &cx, &cy);
  LensDistort(lens, xn, yn - h, &dx, &dy);
  d[0] = lens.fx * (ax - bx) / (2 * h);
  d[1] = lens.fx * (cx - dx) / (2 * h);
  d[2] = lens.fy * (ay - by) / (2 * h);
  d[3] = lens.fy * (cy - dy) / (2 * h);
}

// Projects the camera-frame point (x, y, z) to continuous pixel coordinates;
// false when z <= 1e-6 or the point lies beyond max_radius (distorted
// lenses only). CameraModel::Project.
PF_HD inline bool LensProject(const Lens& lens, double x, double y, double z, double* u,
                              double* v) {
  if (z <= 1e-6) return false;
  const double xn = x / z, yn = y / z;
  if (lens.kind != Lens::kPinhole && xn * xn + yn * yn > lens.max_radius * lens.max_radius) {
    return false;
  }
  double xd, yd;
  LensDistort(lens, xn, yn, &xd, &yd);
  *u = lens.fx * xd + lens.cx;
  *v = lens.fy * yd + lens.cy;
  return true;
}

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_CAMERA_LENS_H_
