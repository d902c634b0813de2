#include "engine/render/line_poses.h"

#include <algorithm>
#include <cmath>

namespace pf {
namespace {

Rigid Lerp(const std::vector<Rigid>& samples, double fraction) {
  const double s = std::clamp(fraction, 0.0, 1.0) * (LinePoses::kSamples - 1);
  const int k = std::min(static_cast<int>(s), LinePoses::kSamples - 2);
  const double w = s - k;
  const Rigid& a = samples[k];
  const Rigid& b = samples[k + 1];
  Rigid out;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      out.rotation.m[r][c] = a.rotation.m[r][c] + w * (b.rotation.m[r][c] - a.rotation.m[r][c]);
    }
  }
  out.translation = a.translation + w * (b.translation - a.translation);
  return out;
}

}  // namespace

LinePoses::LinePoses(const CameraModel& camera, const Rigid& world_from_camera,
                     const std::optional<RollingShutter>& rolling_shutter)
    : camera_(camera),
      world_from_camera_(world_from_camera),
      camera_from_world_(world_from_camera.Inverse()) {
  if (!rolling_shutter.has_value()) return;
  readout_ = rolling_shutter->readout;
  readout_us_ = rolling_shutter->readout_us;
  world_from_line_.resize(kSamples);
  line_from_world_.resize(kSamples);
  for (int k = 0; k < kSamples; ++k) {
    world_from_line_[k] =
        InterpolateRigid(world_from_camera, rolling_shutter->world_from_camera_end,
                         static_cast<double>(k) / (kSamples - 1));
    line_from_world_[k] = world_from_line_[k].Inverse();
  }
  const Rigid world_from_middle =
      InterpolateRigid(world_from_camera, rolling_shutter->world_from_camera_end, 0.5);
  line_from_middle_.resize(kSamples);
  for (int k = 0; k < kSamples; ++k) line_from_middle_[k] = line_from_world_[k] * world_from_middle;
}

double LinePoses::Fraction(double u, double v) const {
  return readout_.has_value() ? ReadoutFraction(*readout_, camera_.width(), camera_.height(), u, v)
                              : 0.0;
}

Rigid LinePoses::WorldFromCamera(double fraction) const {
  return readout_.has_value() ? Lerp(world_from_line_, fraction) : world_from_camera_;
}

Rigid LinePoses::CameraFromWorld(double fraction) const {
  return readout_.has_value() ? Lerp(line_from_world_, fraction) : camera_from_world_;
}

Rigid LinePoses::LineFromMiddle(double fraction) const {
  return readout_.has_value() ? Lerp(line_from_middle_, fraction) : Rigid{};
}

bool LinePoses::Lift(double u, double v, double depth, Vec3* world) const {
  if (!readout_.has_value()) return LiftPixel(camera_, world_from_camera_, u, v, depth, world);
  return LiftPixel(camera_, WorldFromCameraAt(u, v), u, v, depth, world);
}

bool LinePoses::Project(const Vec3& p, double* u, double* v, Vec3* in_camera) const {
  if (!readout_.has_value()) {
    const Vec3 pc = camera_from_world_ * p;
    if (in_camera != nullptr) *in_camera = pc;
    return camera_.Project(pc, u, v);
  }
  Vec3 pc;
  bool seen = false;
  for (double guess : {0.5, 0.0, 1.0}) {
    pc = CameraFromWorld(guess) * p;
    if (camera_.Project(pc, u, v)) {
      seen = true;
      break;
    }
  }
  if (!seen) return false;
  // The line a point lands on moves less each step; a hundredth of a line
  // apart is converged.
  const bool rows = *readout_ == RollingShutter::Readout::kTopToBottom ||
                    *readout_ == RollingShutter::Readout::kBottomToTop;
  const double close = 0.01 / std::max((rows ? camera_.height() : camera_.width()) - 1, 1);
  double fraction = -1;
  for (int step = 0; step < kProjectSteps; ++step) {
    const double next = Fraction(*u, *v);
    if (std::abs(next - fraction) < close) break;
    fraction = next;
    pc = CameraFromWorld(fraction) * p;
    if (!camera_.Project(pc, u, v)) return false;
  }
  if (in_camera != nullptr) *in_camera = pc;
  return true;
}

}  // namespace pf
