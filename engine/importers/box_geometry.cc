// Box corners, containment and projection.
#include "engine/importers/box_geometry.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pf {

std::array<Vec3, 8> BoxCorners(const OrientedBox& box) {
  std::array<Vec3, 8> corners;
  int i = 0;
  for (double sx : {-0.5, 0.5}) {
    for (double sy : {-0.5, 0.5}) {
      for (double sz : {-0.5, 0.5}) {
        const Vec3 local{sx * box.size.x, sy * box.size.y, sz * box.size.z};
        corners[i++] = box.rotation * local + box.center;
      }
    }
  }
  return corners;
}

bool BoxContains(const OrientedBox& box, const Vec3& p) {
  const Vec3 local = Transpose(box.rotation) * (p - box.center);
  return std::abs(local.x) <= 0.5 * box.size.x && std::abs(local.y) <= 0.5 * box.size.y &&
         std::abs(local.z) <= 0.5 * box.size.z;
}

std::optional<BoxFootprint> ProjectBox(const OrientedBox& box, const CameraModel& camera,
                                       const Rigid& camera_from_world) {
  BoxFootprint out;
  out.rect = {std::numeric_limits<double>::max(), std::numeric_limits<double>::max(),
              std::numeric_limits<double>::lowest(), std::numeric_limits<double>::lowest()};
  out.fully_in_view = true;
  for (const Vec3& corner : BoxCorners(box)) {
    double u, v;
    if (!camera.Project(camera_from_world * corner, &u, &v)) return std::nullopt;
    out.rect.x0 = std::min(out.rect.x0, u);
    out.rect.y0 = std::min(out.rect.y0, v);
    out.rect.x1 = std::max(out.rect.x1, u);
    out.rect.y1 = std::max(out.rect.y1, v);
    if (u < 0 || v < 0 || u > camera.width() || v > camera.height()) out.fully_in_view = false;
  }
  return out;
}

PixelRect ClipRect(const PixelRect& rect, int width, int height) {
  return {std::clamp(rect.x0, 0.0, static_cast<double>(width)),
          std::clamp(rect.y0, 0.0, static_cast<double>(height)),
          std::clamp(rect.x1, 0.0, static_cast<double>(width)),
          std::clamp(rect.y1, 0.0, static_cast<double>(height))};
}

double Iou(const PixelRect& a, const PixelRect& b) {
  const PixelRect inter{std::max(a.x0, b.x0), std::max(a.y0, b.y0), std::min(a.x1, b.x1),
                        std::min(a.y1, b.y1)};
  const double i = inter.Area();
  const double u = a.Area() + b.Area() - i;
  return u > 0 ? i / u : 0.0;
}

}  // namespace pf
