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

bool WithinStillReach(const Vec3& first_centre, const Quat& first_rotation, const Vec3& centre,
                      const Quat& rotation) {
  if (Norm(centre - first_centre) > kStillCentre) return false;
  const Quat a = QuatNormalized(first_rotation);
  const Quat b = QuatNormalized(rotation);
  const double dot = std::min(1.0, std::abs(a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z));
  return 2 * std::acos(dot) <= kStillAngle;
}

bool IsStillTrack(const InstanceTrack& track) {
  if (track.boxes.empty()) return false;
  const TrackBox& first = track.boxes.front();
  return std::all_of(track.boxes.begin(), track.boxes.end(), [&](const TrackBox& box) {
    return WithinStillReach(first.center, first.rotation, box.center, box.rotation);
  });
}

std::vector<InstanceTrack> MovingTracks(const std::vector<InstanceTrack>& tracks) {
  std::vector<InstanceTrack> moving;
  for (const InstanceTrack& track : tracks) {
    if (!IsStillTrack(track)) moving.push_back(track);
  }
  return moving;
}

std::vector<int64_t> AdoptStillInstances(const std::vector<InstanceTrack>& still,
                                         const std::vector<uint8_t>& far, GaussianScene* scene) {
  std::vector<int64_t> taken(still.size(), 0);
  const uint32_t first_owner = static_cast<uint32_t>(scene->instances.size()) + 1;
  scene->instances.insert(scene->instances.end(), still.begin(), still.end());
  if (still.empty()) return taken;
  std::vector<InstanceTrack> first_boxes;
  for (const InstanceTrack& track : still) first_boxes.push_back({"", "", {track.boxes.front()}});
  const BoxesAt boxes(first_boxes, first_boxes.front().boxes.front().timestamp_us);
  const int64_t n = static_cast<int64_t>(scene->size());
  DefaultThreadPool().ParallelFor(0, n, 1 << 14, [&](int64_t begin, int64_t end) {
    for (int64_t i = begin; i < end; ++i) {
      if (scene->owners[i] != 0 || (size_t(i) < far.size() && far[i] != 0)) continue;
      const Vec3 p{scene->means[3 * i], scene->means[3 * i + 1], scene->means[3 * i + 2]};
      if (const uint32_t k = boxes.Owner(p, kMembershipMargin); k != 0) {
        scene->owners[i] = first_owner + k - 1;
      }
    }
  });
  for (const uint32_t owner : scene->owners) {
    if (owner >= first_owner) ++taken[owner - first_owner];
  }
  return taken;
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
  // Per box, the columns and rows whose pixel centres its image can reach:
  // through a pinhole lens with every corner in front of the camera, the
  // box's image lies in the hull of its corners' (grown by 2 pixels for
  // rounding); otherwise every pixel.
  struct Reach {
    int x0, x1, y0, y1;
  };
  std::vector<Reach> reach(cam_boxes.size(), Reach{0, width - 1, 0, height - 1});
  if (!camera.has_distortion()) {
    for (size_t k = 0; k < cam_boxes.size(); ++k) {
      const CamBox& cb = cam_boxes[k];
      const Mat3 camera_from_box = Transpose(cb.box_from_camera);
      double u_min = std::numeric_limits<double>::infinity(), u_max = -u_min;
      double v_min = u_min, v_max = -u_min;
      bool bounded = true;
      for (int corner = 0; corner < 8; ++corner) {
        const Vec3 c{corner & 1 ? cb.half.x : -cb.half.x, corner & 2 ? cb.half.y : -cb.half.y,
                     corner & 4 ? cb.half.z : -cb.half.z};
        const Vec3 p = camera_from_box * (c - cb.origin);
        double u, v;
        bounded = p.z > 1e-6 && camera.Project(p, &u, &v) && std::isfinite(u) && std::isfinite(v);
        if (!bounded) break;
        u_min = std::min(u_min, u);
        u_max = std::max(u_max, u);
        v_min = std::min(v_min, v);
        v_max = std::max(v_max, v);
      }
      if (!bounded) continue;
      // Pixel x is reached when its centre x + 0.5 lies in [u_min - 2, u_max + 2].
      auto clamp_to = [](double value, int hi) {
        return static_cast<int>(std::clamp(value, -1.0, static_cast<double>(hi) + 1));
      };
      reach[k] = {clamp_to(std::ceil(u_min - 2.5), width), clamp_to(std::floor(u_max + 1.5), width),
                  clamp_to(std::ceil(v_min - 2.5), height),
                  clamp_to(std::floor(v_max + 1.5), height)};
    }
  }
  DefaultThreadPool().ParallelFor(0, height, 8, [&](int64_t y0, int64_t y1) {
    std::vector<size_t> row_boxes;
    for (int64_t y = y0; y < y1; ++y) {
      row_boxes.clear();
      int x_first = width, x_last = -1;
      for (size_t k = 0; k < cam_boxes.size(); ++k) {
        const Reach& r = reach[k];
        if (y < r.y0 || y > r.y1 || r.x0 > r.x1) continue;
        row_boxes.push_back(k);
        x_first = std::min(x_first, r.x0);
        x_last = std::max(x_last, r.x1);
      }
      x_first = std::max(x_first, 0);
      x_last = std::min(x_last, width - 1);
      for (int x = x_first; x <= x_last; ++x) {
        Vec3 ray;
        if (!camera.Unproject(x + 0.5, y + 0.5, &ray)) continue;
        double best = std::numeric_limits<double>::infinity();
        uint8_t owner = 0;
        for (size_t k : row_boxes) {
          if (x < reach[k].x0 || x > reach[k].x1) continue;
          const CamBox& cb = cam_boxes[k];
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
