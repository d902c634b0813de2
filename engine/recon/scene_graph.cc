// Box membership, canonical frames and dynamic masks.
#include "engine/recon/scene_graph.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/thread_pool.h"
#include "engine/render/instance_pose.h"

namespace pf {

namespace {

// PointInBox with the box's rotation to its frame given.
bool InBox(const Vec3& p, const TrackBox& box, const Mat3& box_from_world,
           const BoxMargin& margin) {
  const Vec3 local = box_from_world * (p - box.center);
  return std::abs(local.x) <= 0.5 * box.size.x + margin.grow &&
         std::abs(local.y) <= 0.5 * box.size.y + margin.grow &&
         local.z <= 0.5 * box.size.z + margin.grow &&
         local.z >= -0.5 * box.size.z + margin.floor_raise;
}

// Whether `p` is farther from the box's centre than any point InBox accepts
// (its farthest corner with the margin, a millionth to spare for rounding).
bool BeyondBox(const Vec3& p, const TrackBox& box, const BoxMargin& margin) {
  const double hx = 0.5 * box.size.x + margin.grow, hy = 0.5 * box.size.y + margin.grow;
  const double hz = std::max(std::abs(0.5 * box.size.z + margin.grow),
                             std::abs(-0.5 * box.size.z + margin.floor_raise));
  const Vec3 d = p - box.center;
  return d.x * d.x + d.y * d.y + d.z * d.z > (hx * hx + hy * hy + hz * hz) * (1 + 1e-6);
}

}  // namespace

bool PointInBox(const Vec3& p, const TrackBox& box, const BoxMargin& margin) {
  return InBox(p, box, Transpose(ToMatrix(box.rotation)), margin);
}

Rigid CanonicalFromWorld(const InstanceTrack& track, int64_t timestamp_us) {
  return InstancePoseAt(track.boxes, timestamp_us).Inverse();
}

BoxesAt::BoxesAt(const std::vector<InstanceTrack>& tracks, int64_t timestamp_us) {
  boxes_.resize(tracks.size());
  valid_.resize(tracks.size(), false);
  box_from_world_.resize(tracks.size());
  for (size_t k = 0; k < tracks.size(); ++k) {
    if (tracks[k].boxes.empty()) continue;
    boxes_[k] = InterpolateBox(tracks[k].boxes, timestamp_us);
    box_from_world_[k] = Transpose(ToMatrix(boxes_[k].rotation));
    valid_[k] = true;
  }
}

uint32_t BoxesAt::Owner(const Vec3& p, const BoxMargin& margin) const {
  for (size_t k = 0; k < boxes_.size(); ++k) {
    if (!valid_[k] || BeyondBox(p, boxes_[k], margin)) continue;
    if (InBox(p, boxes_[k], box_from_world_[k], margin)) return static_cast<uint32_t>(k + 1);
  }
  return 0;
}

uint32_t OwnerAt(const Vec3& p, const std::vector<InstanceTrack>& tracks, int64_t timestamp_us,
                 const BoxMargin& margin) {
  return BoxesAt(tracks, timestamp_us).Owner(p, margin);
}

namespace {

// Returns the entry distance of the ray o + s d (s > 0) into the box with
// half sizes `half` centred at the origin (box frame), or +inf if it misses.
double RayBoxEntry(const Vec3& o, const Vec3& d, const Vec3& half) {
  double s_min = 0.0, s_max = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (std::abs(d[a]) < 1e-12) {
      if (std::abs(o[a]) > half[a]) return std::numeric_limits<double>::infinity();
      continue;
    }
    double s0 = (-half[a] - o[a]) / d[a];
    double s1 = (half[a] - o[a]) / d[a];
    if (s0 > s1) std::swap(s0, s1);
    s_min = std::max(s_min, s0);
    s_max = std::min(s_max, s1);
    if (s_min > s_max) return std::numeric_limits<double>::infinity();
  }
  return s_min;
}

}  // namespace

std::vector<uint8_t> DynamicMask(const CameraModel& camera, const Rigid& world_from_camera,
                                 const std::vector<InstanceTrack>& tracks, int64_t timestamp_us,
                                 double margin) {
  const int width = camera.width(), height = camera.height();
  std::vector<uint8_t> mask(static_cast<size_t>(width) * height, 0);
  const BoxesAt boxes(tracks, timestamp_us);
  // Each box in camera coordinates: origin and axes of the ray in box frame.
  struct CamBox {
    Mat3 box_from_camera;
    Vec3 origin;  // The camera centre in the box frame.
    Vec3 half;
    uint8_t owner;
  };
  std::vector<CamBox> cam_boxes;
  for (size_t k = 0; k < boxes.boxes().size(); ++k) {
    if (!boxes.valid(k)) continue;
    const TrackBox& b = boxes.boxes()[k];
    const Mat3 box_from_world = Transpose(ToMatrix(b.rotation));
    CamBox cb;
    cb.box_from_camera = box_from_world * world_from_camera.rotation;
    cb.origin = box_from_world * (world_from_camera.translation - b.center);
    cb.half = {0.5 * b.size.x + margin, 0.5 * b.size.y + margin, 0.5 * b.size.z + margin};
    cb.owner = static_cast<uint8_t>(std::min<size_t>(k + 1, 255));
    cam_boxes.push_back(cb);
  }
  if (cam_boxes.empty()) return mask;
  DefaultThreadPool().ParallelFor(0, height, 8, [&](int64_t y0, int64_t y1) {
    for (int64_t y = y0; y < y1; ++y) {
      for (int x = 0; x < width; ++x) {
        Vec3 ray;
        if (!camera.Unproject(x + 0.5, y + 0.5, &ray)) continue;
        double best = std::numeric_limits<double>::infinity();
        uint8_t owner = 0;
        for (const CamBox& cb : cam_boxes) {
          const double s = RayBoxEntry(cb.origin, cb.box_from_camera * ray, cb.half);
          if (s < best) {
            best = s;
            owner = cb.owner;
          }
        }
        mask[static_cast<size_t>(y) * width + x] = owner;
      }
    }
  });
  return mask;
}

}  // namespace pf
