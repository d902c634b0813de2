// The pose of each line of a camera image: one pose for a global shutter,
// one per line for a rolling shutter (RollingShutter, rasterizer.h). What
// reconstruction needs to lift a pixel from the pose of the line that read
// it and to project a world point onto the line that reads it.
//
//   const LinePoses lines(camera, world_from_camera, rolling_shutter);
//   Vec3 p;
//   if (lines.Lift(u, v, depth, &p)) ...
//   if (lines.Project(p, &u, &v, &in_camera)) ...
//
// Without a rolling shutter every method gives the bits of CameraModel::Project
// and LiftPixel with `world_from_camera`.
#ifndef POINTFORWARD_ENGINE_RENDER_LINE_POSES_H_
#define POINTFORWARD_ENGINE_RENDER_LINE_POSES_H_

#include <optional>
#include <vector>

#include "common/geometry.h"
#include "engine/camera/camera_model.h"
#include "engine/render/rasterizer.h"

namespace pf {

// The fraction of a readout (0 the first line, 1 the last) at which the line
// through continuous pixel (u, v) of a width x height image is read.
inline double ReadoutFraction(RollingShutter::Readout readout, int width, int height, double u,
                              double v) {
  return ReadoutFractionOf<double>(readout, width, height, u, v);
}

class LinePoses {
 public:
  // Poses of a rolling shutter's lines are interpolated linearly between
  // this many evenly spaced fractions of the readout, each InterpolateRigid.
  static constexpr int kSamples = 33;
  static constexpr int kProjectSteps = 6;

  LinePoses(const CameraModel& camera, const Rigid& world_from_camera,
            const std::optional<RollingShutter>& rolling_shutter = std::nullopt);

  bool rolling() const { return readout_.has_value(); }
  const CameraModel& camera() const { return camera_; }

  // The fraction of the readout (0 the first line, 1 the last) at which the
  // line through continuous pixel (u, v) is read; 0 without a rolling shutter.
  double Fraction(double u, double v) const;
  // Microseconds after the first line at which that line is read.
  double TimeOffsetUs(double fraction) const { return fraction * static_cast<double>(readout_us_); }

  // world_from_camera of the line read at `fraction` of the readout.
  Rigid WorldFromCamera(double fraction) const;
  // Of the line through continuous pixel (u, v).
  Rigid WorldFromCameraAt(double u, double v) const { return WorldFromCamera(Fraction(u, v)); }
  // The middle line's (the image's whole pose without a rolling shutter): the
  // one pose for uses that take a single pose per image.
  Rigid MiddleWorldFromCamera() const { return WorldFromCamera(0.5); }

  // The camera of the line read at `fraction` from the middle line's camera
  // (identity without a rolling shutter): a point p_m in the middle line's
  // camera frame is LineFromMiddle(f) * p_m in that line's. Interpolated
  // linearly between line_from_middle_samples(), kSamples of them.
  Rigid LineFromMiddle(double fraction) const;
  const std::vector<Rigid>& line_from_middle_samples() const { return line_from_middle_; }

  // The world point seen through continuous pixel (u, v) at z depth `depth`
  // from its line's pose; false as LiftPixel.
  bool Lift(double u, double v, double depth, Vec3* world) const;

  // Projects world point `p` to continuous pixel (u, v) of the line that
  // reads it: with a rolling shutter, from the middle line's pose (else the
  // first or the last), then from the pose of the line the last projection
  // landed on, until that line moves by under a hundredth of a line (at most
  // kProjectSteps times). `in_camera` (if given) is `p` in that line's
  // camera frame. False as CameraModel::Project.
  bool Project(const Vec3& p, double* u, double* v, Vec3* in_camera = nullptr) const;

 private:
  Rigid CameraFromWorld(double fraction) const;

  CameraModel camera_;
  Rigid world_from_camera_;
  Rigid camera_from_world_;
  std::optional<RollingShutter::Readout> readout_;
  int64_t readout_us_ = 0;
  std::vector<Rigid> world_from_line_;   // [kSamples] with a rolling shutter.
  std::vector<Rigid> line_from_world_;   // [kSamples]
  std::vector<Rigid> line_from_middle_;  // [kSamples]
};

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RENDER_LINE_POSES_H_
