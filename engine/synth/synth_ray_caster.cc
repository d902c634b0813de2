// Ray casting of the synthetic scene (see synth_ray_caster.h).
#include "engine/synth/synth_ray_caster.h"

#include <algorithm>
#include <cmath>

#include "common/thread_pool.h"
#include "engine/synth/synth_shading.h"

namespace pf {
namespace {

// Rays start this far from their origin, so a surface point does not hit
// itself.
constexpr double kEpsilon = 1e-7;
constexpr int kTileSize = 16;

// Slab test of the ray (origin, 1 / dir) against box [lo, hi]. Returns the
// entry distance in `t_near`, the exit distance in `t_far` and the face
// entered through in `face`; false when the ray misses the box.
bool IntersectSlabs(const Vec3& lo, const Vec3& hi, const Vec3& origin, const Vec3& inv_dir,
                    double* t_near, double* t_far, BoxFace* face) {
  double near = -std::numeric_limits<double>::infinity();
  double far = std::numeric_limits<double>::infinity();
  int axis = 0;
  for (int a = 0; a < 3; ++a) {
    double t1 = (lo[a] - origin[a]) * inv_dir[a];
    double t2 = (hi[a] - origin[a]) * inv_dir[a];
    if (t1 > t2) std::swap(t1, t2);
    if (t1 > near) {
      near = t1;
      axis = a;
    }
    far = std::min(far, t2);
    if (near > far) return false;
  }
  *t_near = near;
  *t_far = far;
  face->axis = axis;
  face->sign = inv_dir[axis] > 0 ? -1 : 1;
  return true;
}

Vec3 Inverse(const Vec3& d) { return {1.0 / d.x, 1.0 / d.y, 1.0 / d.z}; }

// What the nearest hit so far is, before shading.
struct HitRecord {
  enum class Type { kNone, kGround, kStatic, kVehicle } type = Type::kNone;
  double distance = 0;
  int index = 0;  // Static box or placed vehicle.
  int part = 0;   // Vehicle part.
  BoxFace face;
};

// Returns true if box [lo, hi] lies entirely on the negative side of the
// plane through `apex` with normal `n`.
bool OutsidePlane(const Vec3& lo, const Vec3& hi, const Vec3& apex, const Vec3& n) {
  const Vec3 p{n.x > 0 ? hi.x : lo.x, n.y > 0 ? hi.y : lo.y, n.z > 0 ? hi.z : lo.z};
  return Dot(n, p - apex) < 0;
}

}  // namespace

Rigid InterpolateTrack(const std::vector<TrackPose>& track, double time_s) {
  if (time_s <= track.front().time_s) {
    return {ToMatrix(track.front().rotation), track.front().center};
  }
  if (time_s >= track.back().time_s) {
    return {ToMatrix(track.back().rotation), track.back().center};
  }
  size_t i = 1;
  while (track[i].time_s < time_s) ++i;
  const TrackPose& a = track[i - 1];
  const TrackPose& b = track[i];
  const double span = b.time_s - a.time_s;
  const double s = span > 0 ? (time_s - a.time_s) / span : 0.0;
  return {ToMatrix(Slerp(a.rotation, b.rotation, s)), a.center + (b.center - a.center) * s};
}

SceneSnapshot SnapshotAt(const SynthScene& scene, double time_s, const VehicleEdits& edits) {
  SceneSnapshot snapshot;
  snapshot.scene = &scene;
  snapshot.time_s = time_s;
  for (const Vehicle& vehicle : scene.vehicles) {
    if (edits.removed.count(vehicle.instance_id) > 0) continue;
    PlacedVehicle placed;
    placed.vehicle = &vehicle;
    const auto track = edits.trajectories.find(vehicle.instance_id);
    placed.box_to_world = track != edits.trajectories.end() && !track->second.empty()
                              ? InterpolateTrack(track->second, time_s)
                              : vehicle.BoxToWorldAt(time_s);
    placed.world_to_box = placed.box_to_world.Inverse();
    // World bounding box: the centre plus the absolute rotated half extents.
    const Vec3 half = vehicle.size * 0.5;
    const Mat3& r = placed.box_to_world.rotation;
    Vec3 extent;
    for (int i = 0; i < 3; ++i) {
      extent[i] = std::abs(r.m[i][0]) * half.x + std::abs(r.m[i][1]) * half.y +
                  std::abs(r.m[i][2]) * half.z;
    }
    placed.lo = placed.box_to_world.translation - extent;
    placed.hi = placed.box_to_world.translation + extent;
    snapshot.vehicles.push_back(placed);
  }
  return snapshot;
}

Candidates AllCandidates(const SceneSnapshot& snapshot) {
  Candidates all;
  all.statics.resize(snapshot.scene->boxes.size());
  for (size_t i = 0; i < all.statics.size(); ++i) all.statics[i] = static_cast<int>(i);
  all.vehicles.resize(snapshot.vehicles.size());
  for (size_t i = 0; i < all.vehicles.size(); ++i) all.vehicles[i] = static_cast<int>(i);
  return all;
}

Candidates CullToPyramid(const SceneSnapshot& snapshot, const Candidates& from, const Vec3& apex,
                         const Vec3 corners[4]) {
  // Inward plane normals through the apex.
  Vec3 centre;
  for (int i = 0; i < 4; ++i) centre = centre + corners[i];
  Vec3 normals[4];
  for (int i = 0; i < 4; ++i) {
    normals[i] = Cross(corners[i], corners[(i + 1) % 4]);
    if (Dot(normals[i], centre) < 0) normals[i] = -normals[i];
  }
  auto outside = [&](const Vec3& lo, const Vec3& hi) {
    for (const Vec3& n : normals) {
      if (OutsidePlane(lo, hi, apex, n)) return true;
    }
    return false;
  };
  Candidates kept;
  for (int i : from.statics) {
    const StaticBox& box = snapshot.scene->boxes[i];
    if (!outside(box.lo, box.hi)) kept.statics.push_back(i);
  }
  for (int i : from.vehicles) {
    const PlacedVehicle& v = snapshot.vehicles[i];
    if (!outside(v.lo, v.hi)) kept.vehicles.push_back(i);
  }
  return kept;
}

RayHit CastRay(const SceneSnapshot& snapshot, const Candidates& candidates, const Vec3& origin,
               const Vec3& dir, double max_distance) {
  const SynthScene& scene = *snapshot.scene;
  HitRecord best;
  best.distance = max_distance;

  // The ground plane z = 0, seen from above.
  if (dir.z < 0 && origin.z > 0) {
    const double t = -origin.z / dir.z;
    if (t > kEpsilon && t < best.distance) {
      best.type = HitRecord::Type::kGround;
      best.distance = t;
    }
  }

  const Vec3 inv_dir = Inverse(dir);
  for (int i : candidates.statics) {
    const StaticBox& box = scene.boxes[i];
    double t_near, t_far;
    BoxFace face;
    if (!IntersectSlabs(box.lo, box.hi, origin, inv_dir, &t_near, &t_far, &face)) continue;
    if (t_near > kEpsilon && t_near < best.distance) {
      best = {HitRecord::Type::kStatic, t_near, i, 0, face};
    }
  }

  for (int i : candidates.vehicles) {
    const PlacedVehicle& placed = snapshot.vehicles[i];
    const Vehicle& vehicle = *placed.vehicle;
    const Vec3 local_origin = placed.world_to_box * origin;
    const Vec3 local_dir = placed.world_to_box.rotation * dir;
    const Vec3 local_inv = Inverse(local_dir);
    const Vec3 half = vehicle.size * 0.5;
    double t_near, t_far;
    BoxFace face;
    if (!IntersectSlabs(-half, half, local_origin, local_inv, &t_near, &t_far, &face) ||
        t_far <= kEpsilon || t_near >= best.distance) {
      continue;
    }
    for (size_t p = 0; p < vehicle.parts.size(); ++p) {
      const VehiclePart& part = vehicle.parts[p];
      if (!IntersectSlabs(part.lo, part.hi, local_origin, local_inv, &t_near, &t_far, &face)) {
        continue;
      }
      if (t_near > kEpsilon && t_near < best.distance) {
        best = {HitRecord::Type::kVehicle, t_near, i, static_cast<int>(p), face};
      }
    }
  }

  RayHit hit;
  if (best.type == HitRecord::Type::kNone) return hit;
  hit.hit = true;
  hit.distance = best.distance;
  hit.point = origin + dir * best.distance;
  switch (best.type) {
    case HitRecord::Type::kGround:
      hit.normal = {0, 0, 1};
      hit.albedo = GroundAlbedo(scene.road, hit.point.x, hit.point.y);
      break;
    case HitRecord::Type::kStatic: {
      const StaticBox& box = scene.boxes[best.index];
      hit.normal = best.face.Normal();
      hit.albedo = StaticAlbedo(box, hit.point, best.face);
      break;
    }
    case HitRecord::Type::kVehicle: {
      const PlacedVehicle& placed = snapshot.vehicles[best.index];
      const VehiclePart& part = placed.vehicle->parts[best.part];
      hit.normal = placed.box_to_world.rotation * best.face.Normal();
      hit.albedo = VehicleAlbedo(*placed.vehicle, part, placed.world_to_box * hit.point, best.face);
      hit.instance = placed.vehicle->instance_id;
      break;
    }
    case HitRecord::Type::kNone:
      break;
  }
  return hit;
}

RayHit CastRay(const SceneSnapshot& snapshot, const Vec3& origin, const Vec3& dir,
               double max_distance) {
  return CastRay(snapshot, AllCandidates(snapshot), origin, dir, max_distance);
}

Vec3 RayColour(const RayHit& hit, const Vec3& dir) {
  const Vec3 c = hit.hit ? Shade(hit.albedo, hit.normal) : SkyColour(dir);
  return {std::clamp(c.x, 0.0, 1.0), std::clamp(c.y, 0.0, 1.0), std::clamp(c.z, 0.0, 1.0)};
}

RenderedView RenderView(const SceneSnapshot& snapshot, const CameraModel& camera,
                        const Rigid& world_from_camera, int antialias) {
  const int width = camera.width(), height = camera.height();
  const int n = std::max(1, antialias);
  RenderedView out;
  out.rgb = ImageF(width, height, 3);
  out.depth = ImageF(width, height, 1);
  out.instance.assign(static_cast<size_t>(width) * height, 0);

  const Mat3& rotation = world_from_camera.rotation;
  const Vec3 origin = world_from_camera.translation;
  const Vec3 forward = rotation.Col(2);
  // Returns the world unit direction through continuous pixel (u, v).
  auto ray_dir = [&](double u, double v, Vec3* dir) {
    Vec3 ray;
    if (!camera.Unproject(u, v, &ray)) return false;
    *dir = Normalized(rotation * ray);
    return true;
  };

  // The pyramid from `origin` holding every ray through the pixel rectangle
  // [u0, u1] x [v0, v1]: through its corners for a pinhole camera; for a
  // distorted lens, whose frustum edges bend, through the corners of the
  // bounding box (on the camera's z = 1 plane) of rays along the rectangle's
  // border, 1 px apart, widened by 1 % (the border's image bounds the
  // interior's). False where a border ray is outside the lens model.
  auto bounding_pyramid = [&](int u0, int v0, int u1, int v1, Vec3 corners[4]) {
    if (!camera.has_distortion()) {
      return ray_dir(u0, v0, &corners[0]) && ray_dir(u1, v0, &corners[1]) &&
             ray_dir(u1, v1, &corners[2]) && ray_dir(u0, v1, &corners[3]);
    }
    double x_lo = 1e300, x_hi = -1e300, y_lo = 1e300, y_hi = -1e300;
    auto take = [&](double u, double v) {
      Vec3 ray;
      if (!camera.Unproject(u, v, &ray)) return false;
      x_lo = std::min(x_lo, ray.x), x_hi = std::max(x_hi, ray.x);
      y_lo = std::min(y_lo, ray.y), y_hi = std::max(y_hi, ray.y);
      return true;
    };
    for (int u = u0; u <= u1; ++u) {
      if (!take(u, v0) || !take(u, v1)) return false;
    }
    for (int v = v0; v <= v1; ++v) {
      if (!take(u0, v) || !take(u1, v)) return false;
    }
    const double mx = 0.01 * (x_hi - x_lo), my = 0.01 * (y_hi - y_lo);
    x_lo -= mx, x_hi += mx, y_lo -= my, y_hi += my;
    corners[0] = rotation * Vec3{x_lo, y_lo, 1};
    corners[1] = rotation * Vec3{x_hi, y_lo, 1};
    corners[2] = rotation * Vec3{x_hi, y_hi, 1};
    corners[3] = rotation * Vec3{x_lo, y_hi, 1};
    return true;
  };
  Candidates all = AllCandidates(snapshot);
  {
    Vec3 corners[4];
    if (bounding_pyramid(0, 0, width, height, corners)) {
      all = CullToPyramid(snapshot, all, origin, corners);
    }
  }
  const int tiles_x = (width + kTileSize - 1) / kTileSize;
  const int tiles_y = (height + kTileSize - 1) / kTileSize;

  DefaultThreadPool().ParallelFor(0, tiles_y, 1, [&](int64_t row_begin, int64_t row_end) {
    for (int64_t ty = row_begin; ty < row_end; ++ty) {
      for (int tx = 0; tx < tiles_x; ++tx) {
        const int x0 = tx * kTileSize, y0 = static_cast<int>(ty) * kTileSize;
        const int x1 = std::min(width, x0 + kTileSize), y1 = std::min(height, y0 + kTileSize);
        Candidates tile = all;
        Vec3 corners[4];
        if (bounding_pyramid(x0, y0, x1, y1, corners)) {
          tile = CullToPyramid(snapshot, all, origin, corners);
        }
        for (int y = y0; y < y1; ++y) {
          for (int x = x0; x < x1; ++x) {
            const size_t pixel = static_cast<size_t>(y) * width + x;
            Vec3 dir;
            if (!ray_dir(x + 0.5, y + 0.5, &dir)) continue;  // Outside the lens model.
            const RayHit centre = CastRay(snapshot, tile, origin, dir);
            if (centre.hit) {
              out.depth.pixels[pixel] = static_cast<float>(Dot(centre.point - origin, forward));
              out.instance[pixel] = centre.instance;
            }
            // Colour: the mean over an n x n sub-pixel grid (the centre ray
            // is one of its samples when n is odd).
            Vec3 sum;
            int samples = 0;
            for (int j = 0; j < n; ++j) {
              for (int i = 0; i < n; ++i) {
                const double su = x + (i + 0.5) / n, sv = y + (j + 0.5) / n;
                if (n % 2 == 1 && 2 * i + 1 == n && 2 * j + 1 == n) {
                  sum = sum + RayColour(centre, dir);
                  ++samples;
                  continue;
                }
                Vec3 sub_dir;
                if (!ray_dir(su, sv, &sub_dir)) continue;
                sum = sum + RayColour(CastRay(snapshot, tile, origin, sub_dir), sub_dir);
                ++samples;
              }
            }
            if (samples == 0) continue;
            const Vec3 colour = sum / samples;
            for (int c = 0; c < 3; ++c)
              out.rgb.pixels[pixel * 3 + c] = static_cast<float>(colour[c]);
          }
        }
      }
    }
  });
  return out;
}

}  // namespace pf
