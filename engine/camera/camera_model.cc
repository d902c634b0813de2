// Camera models.
#include "engine/camera/camera_model.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
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

namespace {

// sum_i c[i] x^i and its derivative.
double EvalPolynomial(const double* c, int n, double x, double* slope = nullptr) {
  double value = 0, derivative = 0;
  for (int i = n - 1; i >= 0; --i) {
    derivative = derivative * x + value;
    value = value * x + c[i];
  }
  if (slope != nullptr) *slope = derivative;
  return value;
}

}  // namespace

void CameraModel::SetFTheta(const std::vector<double>& angle_to_pixels) {
  lens_.kind = Lens::kFTheta;
  lens_.k1 = lens_.k2 = lens_.k3 = lens_.k4 = lens_.p1 = lens_.p2 = 0;
  const double focal = angle_to_pixels.size() > 1 ? angle_to_pixels[1] : 1.0;
  lens_.fx = lens_.fy = focal;
  for (int i = 0; i < Lens::kFThetaTerms; ++i) {
    lens_.ftheta[i] = i < static_cast<int>(angle_to_pixels.size()) ? angle_to_pixels[i] / focal : 0;
  }
  UpdateValidRadius();
}

std::vector<double> CameraModel::ftheta_pixels() const {
  if (lens_.kind != Lens::kFTheta) return {};
  std::vector<double> pixels(Lens::kFThetaTerms);
  for (int i = 0; i < Lens::kFThetaTerms; ++i) pixels[i] = lens_.ftheta[i] * lens_.fx;
  return pixels;
}

void CameraModel::UpdateValidRadius() {
  if (lens_.kind == Lens::kFTheta) {
    // In angle: up to where the polynomial stops growing, at most
    // kFThetaMaxAngle.
    constexpr double kStep = 1e-4;
    double theta = kStep, previous = 0;
    for (; theta <= kFThetaMaxAngle; theta += kStep) {
      const double value = EvalPolynomial(lens_.ftheta, Lens::kFThetaTerms, theta);
      if (value <= previous) break;
      previous = value;
    }
    lens_.max_radius = std::tan(theta - kStep);
    return;
  }
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
  if (lens_.kind == Lens::kFTheta) return UndistortFTheta(xd, yd, xn, yn);
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

bool CameraModel::UndistortFTheta(double xd, double yd, double* xn, double* yn) const {
  const double rd = std::hypot(xd, yd);
  if (rd < 1e-12) {
    *xn = xd;
    *yn = yd;
    return true;
  }
  // The distorted radius grows with theta up to the valid radius: Newton's
  // method on theta, kept inside the bracket [lo, hi] by bisection.
  double lo = 0, hi = std::atan(lens_.max_radius);
  if (EvalPolynomial(lens_.ftheta, Lens::kFThetaTerms, hi) < rd) return false;
  double theta = std::min(rd, hi);
  for (int iter = 0; iter < 100; ++iter) {
    double slope;
    const double error = EvalPolynomial(lens_.ftheta, Lens::kFThetaTerms, theta, &slope) - rd;
    if (std::abs(error) < 1e-14) break;
    (error > 0 ? hi : lo) = theta;
    double next = slope > 0 ? theta - error / slope : lo - 1;
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (next == theta) break;
    theta = next;
  }
  const double r = std::tan(theta);
  *xn = xd * r / rd;
  *yn = yd * r / rd;
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

namespace {

constexpr int kFitDegree = 5;
constexpr int kRadiusSamples = 256;
constexpr double kFitTolerancePx = 0.05;
constexpr double kInverseTolerancePx = 0.5;

absl::Status LensFieldError(const std::string& where, const std::string& message) {
  return absl::InvalidArgumentError(absl::StrCat(where, ": ", message));
}

// The distance from (cx, cy) to the farthest image corner.
double FarthestCornerPx(const pointforward::v1::Camera& camera) {
  const double cx = camera.intrinsics().cx(), cy = camera.intrinsics().cy();
  double farthest = 0;
  for (double x : {0.0, static_cast<double>(camera.width())}) {
    for (double y : {0.0, static_cast<double>(camera.height())}) {
      farthest = std::max(farthest, std::hypot(x - cx, y - cy));
    }
  }
  return farthest;
}

// (theta, pixels) of `pixels_to_angle` at pixel distances max_px k /
// kRadiusSamples from k = `first` on, up to where its angle stops growing or
// reaches kFThetaMaxAngle.
std::vector<std::pair<double, double>> GrowingSamples(const std::vector<double>& pixels_to_angle,
                                                      double max_px, int first) {
  const int n = static_cast<int>(pixels_to_angle.size());
  std::vector<std::pair<double, double>> samples;
  double previous = -1;
  for (int k = first; k <= kRadiusSamples; ++k) {
    const double px = max_px * k / kRadiusSamples;
    const double theta = EvalPolynomial(pixels_to_angle.data(), n, px);
    if (!(theta > previous) || theta >= kFThetaMaxAngle) break;
    samples.emplace_back(theta, px);
    previous = theta;
  }
  return samples;
}

// The angle-to-pixel polynomial (c0 = 0, degree 5) closest in least squares
// to the inverse of `pixels_to_angle` over [0, max_px], sampled where the
// inverse's angle grows and stays ahead of the camera.
absl::StatusOr<std::vector<double>> FitFTheta(const std::vector<double>& pixels_to_angle,
                                              double max_px) {
  const std::vector<std::pair<double, double>> samples = GrowingSamples(pixels_to_angle, max_px, 0);
  if (samples.size() < kRadiusSamples / 16) {
    return LensFieldError(
        "distortion.fthetaInversePoly",
        "the angle does not grow with the pixel distance from the principal point "
        "(or passes 89.5 degrees) within a sixteenth of the image; give fthetaPoly "
        "instead");
  }
  // Normal equations of sum_k (sum_i a_i theta_k^i - px_k)^2, i = 1..5.
  std::array<std::array<double, kFitDegree + 1>, kFitDegree> m{};
  for (const auto& [theta, px] : samples) {
    std::array<double, kFitDegree> powers;
    double p = 1;
    for (int i = 0; i < kFitDegree; ++i) powers[i] = (p *= theta);
    for (int i = 0; i < kFitDegree; ++i) {
      for (int j = 0; j < kFitDegree; ++j) m[i][j] += powers[i] * powers[j];
      m[i][kFitDegree] += powers[i] * px;
    }
  }
  for (int col = 0; col < kFitDegree; ++col) {  // Gauss-Jordan, partial pivoting.
    int pivot = col;
    for (int row = col + 1; row < kFitDegree; ++row) {
      if (std::abs(m[row][col]) > std::abs(m[pivot][col])) pivot = row;
    }
    std::swap(m[col], m[pivot]);
    if (std::abs(m[col][col]) < 1e-300) {
      return LensFieldError("distortion.fthetaInversePoly", "cannot fit fthetaPoly to it; give it");
    }
    for (int row = 0; row < kFitDegree; ++row) {
      if (row == col) continue;
      const double f = m[row][col] / m[col][col];
      for (int k = col; k <= kFitDegree; ++k) m[row][k] -= f * m[col][k];
    }
  }
  std::vector<double> poly(kFitDegree + 1, 0.0);
  for (int i = 0; i < kFitDegree; ++i) poly[i + 1] = m[i][kFitDegree] / m[i][i];
  double worst = 0;
  for (const auto& [theta, px] : samples) {
    worst = std::max(worst, std::abs(EvalPolynomial(poly.data(), kFitDegree + 1, theta) - px));
  }
  if (!(worst <= kFitTolerancePx)) {
    return LensFieldError(
        "distortion.fthetaInversePoly",
        absl::StrFormat("no degree-5 fthetaPoly follows it within %.2f px over the "
                        "image (the closest is off by %.3g px); give fthetaPoly",
                        kFitTolerancePx, worst));
  }
  return poly;
}

}  // namespace

absl::StatusOr<std::vector<double>> FThetaPolynomialFromProto(
    const pointforward::v1::Camera& camera) {
  const auto& d = camera.distortion();
  const std::vector<double> forward(d.ftheta_poly().begin(), d.ftheta_poly().end());
  const std::vector<double> inverse(d.ftheta_inverse_poly().begin(), d.ftheta_inverse_poly().end());
  const std::pair<const char*, const std::vector<double>*> polys[] = {
      {"fthetaPoly", &forward}, {"fthetaInversePoly", &inverse}};
  for (const auto& [name, poly] : polys) {
    if (static_cast<int>(poly->size()) > Lens::kFThetaTerms) {
      return LensFieldError(absl::StrCat("distortion.", name),
                            absl::StrCat("at most ", Lens::kFThetaTerms,
                                         " coefficients (theta^0 .. "
                                         "theta^5), got ",
                                         poly->size()));
    }
    for (double value : *poly) {
      if (!std::isfinite(value))
        return LensFieldError(absl::StrCat("distortion.", name), "non-finite number");
    }
  }
  const double max_px = FarthestCornerPx(camera);
  std::vector<double> poly = forward;
  if (poly.empty()) {
    if (inverse.empty()) {
      return LensFieldError(
          "distortion.fthetaPoly",
          "missing: FTHETA needs fthetaPoly (pixel distance from the principal point "
          "as a polynomial of the angle, radians) or fthetaInversePoly");
    }
    auto fitted = FitFTheta(inverse, max_px);
    if (!fitted.ok()) return fitted.status();
    poly = *std::move(fitted);
  }
  poly.resize(Lens::kFThetaTerms, 0.0);
  if (std::abs(poly[0]) > 0.01) {
    return LensFieldError(
        "distortion.fthetaPoly[0]",
        absl::StrFormat("must be 0 (the optical axis lands on the principal point), "
                        "got %g px",
                        poly[0]));
  }
  if (!(poly[1] > 0)) {
    return LensFieldError(
        "distortion.fthetaPoly[1]",
        absl::StrFormat("the focal length at the centre (pixels per radian) must be "
                        "positive, got %g",
                        poly[1]));
  }
  for (const auto& [name, value] : {std::pair<const char*, double>{"fx", camera.intrinsics().fx()},
                                    {"fy", camera.intrinsics().fy()}}) {
    if (value != 0 && std::abs(value - poly[1]) > 0.01 * poly[1]) {
      return LensFieldError(
          absl::StrCat("intrinsics.", name),
          absl::StrFormat("an FTHETA camera's focal length is fthetaPoly[1] (%g px "
                          "per radian); leave %s at 0 or set it to that, got %g",
                          poly[1], name, value));
    }
  }
  if (!forward.empty() && !inverse.empty()) {
    // Both given: the inverse must undo the forward one over the image.
    const std::vector<std::pair<double, double>> samples = GrowingSamples(inverse, max_px, 1);
    const int checked = static_cast<int>(samples.size());
    for (const auto& [theta, px] : samples) {
      const double back = EvalPolynomial(poly.data(), Lens::kFThetaTerms, theta);
      if (!(std::abs(back - px) <= kInverseTolerancePx)) {
        return LensFieldError(
            "distortion.fthetaInversePoly",
            absl::StrFormat("does not invert fthetaPoly: %.1f px from the principal "
                            "point it gives %.4f rad, which fthetaPoly maps to "
                            "%.1f px (are the two swapped?)",
                            px, theta, back));
      }
    }
    if (checked < kRadiusSamples / 16) {
      return LensFieldError(
          "distortion.fthetaInversePoly",
          absl::StrFormat("its angle stops growing or passes 89.5 degrees %.1f px from the "
                          "principal point, where the image reaches %.1f px (are the two "
                          "swapped?)",
                          max_px * (checked + 1) / kRadiusSamples, max_px));
    }
  }
  return poly;
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
  const auto& d = camera.distortion();
  const bool ftheta = d.model() == pointforward::v1::Distortion::FTHETA;
  if (!ftheta && (k.fx() <= 0 || k.fy() <= 0)) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ".intrinsics: focal length must be positive"));
  }
  CameraModel model(camera.width(), camera.height(), k.fx(), k.fy(), k.cx(), k.cy());
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
    case pointforward::v1::Distortion::FTHETA: {
      auto poly = FThetaPolynomialFromProto(camera);
      if (!poly.ok()) {
        return absl::InvalidArgumentError(absl::StrCat(where, ".", poly.status().message()));
      }
      model.SetFTheta(*poly);
      break;
    }
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
