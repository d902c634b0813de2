// Camera models: pinhole, OpenCV (k1, k2, p1, p2, k3), equidistant fisheye
// (k1..k4) and f-theta (pixel distance from the principal point a polynomial
// of the angle from the optical axis), with projection of camera-frame points
// to pixels and back. Every model projects points ahead of the camera (z > 0)
// only, so a lens covers less than 180 degrees.
//
// Pixel coordinates are continuous with the image spanning [0, W] x [0, H]:
// pixel (i, j) has its centre at (i + 0.5, j + 0.5), and u = fx * x' + cx
// where (x', y') are the distorted normalised coordinates. Importers of data
// whose calibration puts pixel centres on integers add 0.5 to cx and cy.
// Camera axes are OpenCV's: x right, y down, z forward.
#ifndef POINTFORWARD_ENGINE_CAMERA_CAMERA_MODEL_H_
#define POINTFORWARD_ENGINE_CAMERA_CAMERA_MODEL_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "common/geometry.h"
#include "engine/camera/lens.h"

namespace pointforward::v1 {
class Camera;
}

namespace pf {

// The widest angle from the optical axis an f-theta lens projects (89.5
// degrees): every model here projects points ahead of the camera only.
inline constexpr double kFThetaMaxAngle = 89.5 * 3.14159265358979323846 / 180;

class CameraModel {
 public:
  enum class Kind {
    kPinhole = Lens::kPinhole,
    kOpenCv = Lens::kOpenCv,
    kFisheye = Lens::kFisheye,
    kFTheta = Lens::kFTheta
  };

  CameraModel() = default;
  // A pinhole camera.
  CameraModel(int width, int height, double fx, double fy, double cx, double cy);

  // Sets OpenCV distortion coefficients (Brown-Conrady).
  void SetOpenCv(double k1, double k2, double p1, double p2, double k3);
  // Sets equidistant fisheye coefficients.
  void SetFisheye(double k1, double k2, double k3, double k4);
  // Sets the f-theta model: the distance in pixels from (cx, cy) of a ray at
  // angle theta (radians) from the optical axis is
  // sum_i angle_to_pixels[i] theta^i (at most Lens::kFThetaTerms terms;
  // [0] = 0 and [1] > 0, which CameraModelFromProto checks). Replaces fx and
  // fy by [1], the focal length at the centre.
  void SetFTheta(const std::vector<double>& angle_to_pixels);

  Kind kind() const { return static_cast<Kind>(lens_.kind); }
  int width() const { return width_; }
  int height() const { return height_; }
  double fx() const { return lens_.fx; }
  double fy() const { return lens_.fy; }
  double cx() const { return lens_.cx; }
  double cy() const { return lens_.cy; }
  bool has_distortion() const { return lens_.kind != Lens::kPinhole; }
  // Distortion coefficients as set (0 when unset): k1..k3, p1, p2 of the
  // OpenCV model; k1..k4 of the fisheye model.
  double k1() const { return lens_.k1; }
  double k2() const { return lens_.k2; }
  double k3() const { return lens_.k3; }
  double k4() const { return lens_.k4; }
  double p1() const { return lens_.p1; }
  double p2() const { return lens_.p2; }
  // The f-theta polynomial in pixels (Lens::kFThetaTerms terms); empty for
  // the other models.
  std::vector<double> ftheta_pixels() const;
  // The projection as plain numbers (lens.h), for CUDA kernels.
  const Lens& lens() const { return lens_; }

  // Maps undistorted normalised coordinates (x/z, y/z) to distorted ones.
  // For the fisheye model the input is also (x/z, y/z) with z > 0.
  void Distort(double xn, double yn, double* xd, double* yd) const;
  // Inverts Distort() by iteration; false when it does not converge or the
  // point lies beyond the model's valid radius.
  bool Undistort(double xd, double yd, double* xn, double* yn) const;

  // Projects camera-frame point `p` to continuous pixel coordinates. Returns
  // false when the point is behind the camera (z <= 1e-6) or outside the
  // radius where the distortion polynomial is monotonic (where it would fold
  // far-away points back into the image). The pixel may lie outside the image.
  bool Project(const Vec3& p, double* u, double* v) const;

  // Returns the camera-frame ray through continuous pixel (u, v), scaled so
  // that z = 1; false if the pixel cannot be undistorted.
  bool Unproject(double u, double v, Vec3* ray) const;

  // The largest undistorted normalised radius Project() accepts.
  double max_normalized_radius() const { return lens_.max_radius; }

 private:
  void UpdateValidRadius();
  bool UndistortFTheta(double xd, double yd, double* xn, double* yn) const;

  int width_ = 0, height_ = 0;
  Lens lens_;
};

// Builds a CameraModel from a manifest camera. INVALID_ARGUMENT (naming the
// field) for a non-positive size or focal length or non-finite numbers. An
// FTHETA camera takes ftheta_poly (angle to pixels), or fits one of degree 5
// to ftheta_inverse_poly (pixels to angle) when only that is given, over the
// image out to where the inverse's angle stops growing or reaches
// kFThetaMaxAngle (within 0.05 px, else an error); with both, they must
// invert each other within 0.5 px over that range. Its intrinsics fx and fy
// are 0 or ftheta_poly[1] (within 1 %).
absl::StatusOr<CameraModel> CameraModelFromProto(const pointforward::v1::Camera& camera);

// The angle-to-pixel polynomial (Lens::kFThetaTerms terms) of an FTHETA
// manifest camera, checked as CameraModelFromProto describes; on a fault
// INVALID_ARGUMENT whose message is "<field>: <problem>", the field under the
// camera (e.g. "distortion.fthetaPoly[1]").
absl::StatusOr<std::vector<double>> FThetaPolynomialFromProto(
    const pointforward::v1::Camera& camera);

// Returns the world point seen through continuous pixel (u, v) at z depth
// `depth`; false when the pixel cannot be unprojected or depth <= 0.
bool LiftPixel(const CameraModel& camera, const Rigid& world_from_camera, double u, double v,
               double depth, Vec3* world);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_CAMERA_CAMERA_MODEL_H_
