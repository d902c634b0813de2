// Oriented 3D boxes as the manifest stores them (centre, size = length along
// box x, width along y, height along z, rotation box-to-world): their corners,
// point containment, and their footprint in an image, used to check imported
// calibration against a dataset's own 2D boxes.
#ifndef POINTFORWARD_ENGINE_IMPORTERS_BOX_GEOMETRY_H_
#define POINTFORWARD_ENGINE_IMPORTERS_BOX_GEOMETRY_H_

#include <array>
#include <optional>

#include "common/geometry.h"
#include "engine/camera/camera_model.h"

namespace pf {

struct OrientedBox {
  Vec3 center;
  Vec3 size;      // Length (x), width (y), height (z).
  Mat3 rotation;  // Box-to-world.
};

// Axis-aligned pixel rectangle [x0, x1] x [y0, y1] in continuous coordinates.
struct PixelRect {
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  double Area() const { return x1 > x0 && y1 > y0 ? (x1 - x0) * (y1 - y0) : 0.0; }
};

// Returns the 8 corners of `box` in world coordinates.
std::array<Vec3, 8> BoxCorners(const OrientedBox& box);

// Returns true if world point `p` lies inside `box` (boundary included).
bool BoxContains(const OrientedBox& box, const Vec3& p);

struct BoxFootprint {
  PixelRect rect;              // Bounding rectangle of the projected corners.
  bool fully_in_view = false;  // Every corner in front and inside [0,W]x[0,H].
};

// Projects the corners of `box` through `camera` (world point -> camera frame
// by `camera_from_world`, then CameraModel::Project with its distortion) and
// returns their bounding rectangle; nullopt when any corner cannot be
// projected (behind the camera or beyond the distortion's valid radius).
std::optional<BoxFootprint> ProjectBox(const OrientedBox& box, const CameraModel& camera,
                                       const Rigid& camera_from_world);

// Returns `rect` clipped to [0, width] x [0, height].
PixelRect ClipRect(const PixelRect& rect, int width, int height);

// Intersection over union of two rectangles (0 when both are empty).
double Iou(const PixelRect& a, const PixelRect& b);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_IMPORTERS_BOX_GEOMETRY_H_
