// Pixels to world points, Plücker rays and normals.
#include "engine/recon/query_lifting.h"

#include <cmath>

#include "common/thread_pool.h"

namespace pf {

std::array<float, 6> PluckerRay(const Vec3& origin, const Vec3& direction) {
  const Vec3 d = Normalized(direction);
  const Vec3 m = Cross(origin, d);
  return {float(d.x), float(d.y), float(d.z), float(m.x), float(m.y), float(m.z)};
}

bool LiftQuery(const ContextView& view, const ViewDepth& depth, int x, int y, Query12* query) {
  if (x < 0 || y < 0 || x >= view.width() || y >= view.height()) return false;
  const size_t i = static_cast<size_t>(y) * view.width() + x;
  const LinePoses lines = view.lines();
  Vec3 p;
  if (!lines.Lift(x + 0.5, y + 0.5, depth.depth[i], &p)) return false;
  const Vec3 origin = lines.WorldFromCameraAt(x + 0.5, y + 0.5).translation;
  const std::array<float, 6> plucker = PluckerRay(origin, p - origin);
  Query12& q = *query;
  q = {float(p.x),           float(p.y),           float(p.z),
       view.rgb.at(x, y, 0), view.rgb.at(x, y, 1), view.rgb.at(x, y, 2)};
  for (int k = 0; k < 6; ++k) q[6 + k] = plucker[k];
  return true;
}

LiftedView LiftView(const ContextView& view, const ViewDepth& depth) {
  LiftedView out;
  const int w = view.width(), h = view.height();
  out.width = w;
  out.height = h;
  const size_t n = static_cast<size_t>(w) * h;
  out.points.assign(n * 3, 0.f);
  out.normals.assign(n * 3, 0.f);
  out.valid.assign(n, 0);
  const LinePoses lines = view.lines();
  const Vec3 origin = view.world_from_camera.translation;
  // The centre of the line through pixel (x, y).
  auto origin_at = [&](int x, int64_t y) {
    return lines.rolling() ? lines.WorldFromCameraAt(x + 0.5, y + 0.5).translation : origin;
  };
  DefaultThreadPool().ParallelFor(0, h, 16, [&](int64_t y0, int64_t y1) {
    for (int64_t y = y0; y < y1; ++y) {
      for (int x = 0; x < w; ++x) {
        const size_t i = static_cast<size_t>(y) * w + x;
        Vec3 p;
        if (view.is_ego(i)) continue;  // The ego vehicle's body: not the scene.
        if (!lines.Lift(x + 0.5, y + 0.5, depth.depth[i], &p)) continue;
        out.points[3 * i] = float(p.x);
        out.points[3 * i + 1] = float(p.y);
        out.points[3 * i + 2] = float(p.z);
        out.valid[i] = 1;
      }
    }
  });
  auto point = [&](size_t i) {
    return Vec3{out.points[3 * i], out.points[3 * i + 1], out.points[3 * i + 2]};
  };
  // Picks the neighbour difference along one axis: central when both sides
  // are valid and smooth, else the side with the smaller relative depth jump.
  auto tangent = [&](size_t i, size_t prev, size_t next, bool has_prev, bool has_next, Vec3* t) {
    has_prev = has_prev && out.valid[prev] && depth.is_far(prev) == depth.is_far(i);
    has_next = has_next && out.valid[next] && depth.is_far(next) == depth.is_far(i);
    if (!has_prev && !has_next) return false;
    const float d = depth.depth[i];
    const float jump_prev = has_prev ? std::abs(depth.depth[prev] - d) / d : 1e9f;
    const float jump_next = has_next ? std::abs(depth.depth[next] - d) / d : 1e9f;
    if (has_prev && has_next && jump_prev < 0.05f && jump_next < 0.05f) {
      *t = point(next) - point(prev);
    } else if (jump_next <= jump_prev) {
      *t = point(next) - point(i);
    } else {
      *t = point(i) - point(prev);
    }
    return true;
  };
  DefaultThreadPool().ParallelFor(0, h, 16, [&](int64_t y0, int64_t y1) {
    for (int64_t y = y0; y < y1; ++y) {
      for (int x = 0; x < w; ++x) {
        const size_t i = static_cast<size_t>(y) * w + x;
        if (!out.valid[i]) continue;
        const Vec3 p = point(i);
        const Vec3 view_dir = Normalized(p - origin_at(x, y));
        Vec3 normal = -view_dir;
        Vec3 tx, ty;
        if (!depth.is_far(i) && tangent(i, i - 1, i + 1, x > 0, x + 1 < w, &tx) &&
            tangent(i, i - w, i + w, y > 0, y + 1 < h, &ty)) {
          const Vec3 c = Cross(tx, ty);
          if (Norm(c) > 0) normal = Normalized(c);
          if (Dot(normal, view_dir) > 0) normal = -normal;
        }
        out.normals[3 * i] = float(normal.x);
        out.normals[3 * i + 1] = float(normal.y);
        out.normals[3 * i + 2] = float(normal.z);
      }
    }
  });
  return out;
}

}  // namespace pf
