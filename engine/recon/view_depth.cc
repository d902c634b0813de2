// Depth per context image: depth maps, LiDAR projection and completion, and
// the far layer.
#include "engine/recon/view_depth.h"

// The generated protobuf header first (see image_io.h).
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>

#include "absl/strings/str_cat.h"
#include "common/thread_pool.h"
#include "engine/camera/camera_model.h"
#include "engine/camera/image_pixel.h"
#include "engine/clip/clip_validator.h"
#include "engine/recon/depth_completion.h"
#include "engine/recon/scene_graph.h"
#include "engine/render/instance_pose.h"
#include "pointforward/v1/clip.pb.h"

namespace pf {

absl::StatusOr<std::vector<LidarSweepData>> LoadLidarSweeps(const LoadedClip& loaded,
                                                            bool allow_outside_paths) {
  std::vector<LidarSweepData> sweeps;
  for (int i = 0; i < loaded.clip.lidar_size(); ++i) {
    const auto& sweep = loaded.clip.lidar(i);
    const std::string where = absl::StrCat("lidar[", i, "]");
    if (sweep.world_from_sensor_size() != 16) {
      return absl::InvalidArgumentError(absl::StrCat(where, ".worldFromSensor: has ",
                                                     sweep.world_from_sensor_size(),
                                                     " numbers, expected 16"));
    }
    absl::StatusOr<std::string> path = ResolveClipPath(loaded, sweep.points(), allow_outside_paths);
    if (!path.ok()) {
      return absl::Status(path.status().code(),
                          absl::StrCat(where, ".points: ", std::string(path.status().message())));
    }
    std::ifstream in(*path, std::ios::binary | std::ios::ate);
    if (!in) return absl::NotFoundError(absl::StrCat(where, ".points: cannot open ", *path));
    const std::streamoff bytes = in.tellg();
    if (bytes < 0 || bytes % 16 != 0) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, ".points: ", *path, " has ", bytes, " bytes, not a multiple of 16"));
    }
    std::vector<float> records(static_cast<size_t>(bytes / 4));
    in.seekg(0);
    if (!in.read(reinterpret_cast<char*>(records.data()), bytes)) {
      return absl::DataLossError(absl::StrCat(where, ".points: short read of ", *path));
    }
    const Rigid world_from_sensor = Rigid::FromRowMajor(sweep.world_from_sensor().data());
    LidarSweepData data;
    data.timestamp_us = sweep.timestamp_us();
    data.sensor_origin = world_from_sensor.translation;
    data.sensor_up = Normalized(world_from_sensor.rotation * Vec3{0, 0, 1});
    const size_t n = records.size() / 4;
    data.points.reserve(n * 3);
    data.intensities.reserve(n);
    for (size_t p = 0; p < n; ++p) {
      const Vec3 local{records[4 * p], records[4 * p + 1], records[4 * p + 2]};
      if (!std::isfinite(local.x) || !std::isfinite(local.y) || !std::isfinite(local.z)) continue;
      const Vec3 w = world_from_sensor * local;
      data.points.insert(data.points.end(), {float(w.x), float(w.y), float(w.z)});
      data.intensities.push_back(records[4 * p + 3]);
    }
    sweeps.push_back(std::move(data));
  }
  return sweeps;
}

int NearestSweep(const std::vector<LidarSweepData>& sweeps, int64_t timestamp_us) {
  int best = -1;
  int64_t best_gap = std::numeric_limits<int64_t>::max();
  for (size_t i = 0; i < sweeps.size(); ++i) {
    const int64_t gap = std::abs(sweeps[i].timestamp_us - timestamp_us);
    if (gap < best_gap) {
      best_gap = gap;
      best = static_cast<int>(i);
    }
  }
  return best;
}

std::vector<float> PointsAtTime(const LidarSweepData& sweep,
                                const std::vector<InstanceTrack>& tracks, int64_t timestamp_us) {
  std::vector<float> out = sweep.points;
  if (tracks.empty() || sweep.timestamp_us == timestamp_us) return out;
  const BoxesAt boxes(tracks, sweep.timestamp_us);
  // world(t) <- canonical <- world(sweep) per track.
  std::vector<Rigid> moves(tracks.size());
  for (size_t k = 0; k < tracks.size(); ++k) {
    if (!boxes.valid(k)) continue;
    moves[k] = InstancePoseAt(tracks[k].boxes, timestamp_us) *
               InstancePoseAt(tracks[k].boxes, sweep.timestamp_us).Inverse();
  }
  const int64_t n = static_cast<int64_t>(out.size() / 3);
  DefaultThreadPool().ParallelFor(0, n, 4096, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      const Vec3 p{out[3 * i], out[3 * i + 1], out[3 * i + 2]};
      const uint32_t owner = boxes.Owner(p, kMembershipMargin);
      if (owner == 0) continue;
      const Vec3 q = moves[owner - 1] * p;
      out[3 * i] = float(q.x);
      out[3 * i + 1] = float(q.y);
      out[3 * i + 2] = float(q.z);
    }
  });
  return out;
}

ImageF KnownDepthOnly(const ImageF& depth) {
  ImageF out = depth;
  for (float& d : out.pixels)
    if (!(d > 0.f) || !std::isfinite(d)) d = 0.f;
  return out;
}

ImageF ProjectPoints(const std::vector<float>& points, const LinePoses& lines) {
  const CameraModel& camera = lines.camera();
  ImageF depth(camera.width(), camera.height(), 1);
  const size_t n = points.size() / 3;
  for (size_t i = 0; i < n; ++i) {
    Vec3 pc;
    double u, v;
    if (!lines.Project(Vec3{points[3 * i], points[3 * i + 1], points[3 * i + 2]}, &u, &v, &pc)) {
      continue;
    }
    int x, y;
    if (!PixelInImage(u, v, depth.width, depth.height, &x, &y)) continue;
    float& d = depth.at(x, y);
    if (d == 0.f || pc.z < d) d = static_cast<float>(pc.z);
  }
  return depth;
}

ImageF ProjectPoints(const std::vector<float>& points, const CameraModel& camera,
                     const Rigid& world_from_camera) {
  return ProjectPoints(points, LinePoses(camera, world_from_camera));
}

int CompletionRadius(int height) {
  return std::max(12, static_cast<int>(std::lround(0.04 * height)));
}

ImageF CompleteDepth(const ImageF& sparse, const CompletionOptions& options,
                     std::vector<int32_t>* sources) {
  const int w = sparse.width, h = sparse.height;
  const int max_distance =
      options.max_distance_px > 0 ? options.max_distance_px : CompletionRadius(h);
  const int cell = std::max(1, max_distance);
  const int gw = (w + cell - 1) / cell;  // Cells of a row, for the order of equal depths.

  ImageF dense = sparse;
  if (sources != nullptr) {
    sources->assign(static_cast<size_t>(w) * h, -1);
    for (size_t i = 0; i < sources->size(); ++i)
      if (sparse.pixels[i] > 0.f) (*sources)[i] = static_cast<int32_t>(i);
  }
  // Per column, the rows to the nearest measured pixel in it (above or
  // below; > h when none): the squared distance to the nearest measurement
  // is then min over columns x' of (x - x')^2 + rows(x')^2, and within
  // max_distance only columns within max_distance matter.
  std::vector<int> rows(static_cast<size_t>(w) * h);
  DefaultThreadPool().ParallelFor(0, w, 64, [&](int64_t x0, int64_t x1) {
    for (int64_t x = x0; x < x1; ++x) {
      int last = -2 * h - 2;
      for (int y = 0; y < h; ++y) {
        if (sparse.at(static_cast<int>(x), y) > 0.f) last = y;
        rows[static_cast<size_t>(y) * w + x] = y - last;
      }
      last = 3 * h + 2;
      for (int y = h - 1; y >= 0; --y) {
        if (sparse.at(static_cast<int>(x), y) > 0.f) last = y;
        int& r = rows[static_cast<size_t>(y) * w + x];
        r = std::min(r, last - y);
      }
    }
  });
  // The measured pixels' columns, row by row (ascending): the search below
  // visits those alone.
  std::vector<int> row_start(static_cast<size_t>(h) + 1, 0), measured_x;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x)
      if (sparse.at(x, y) > 0.f) measured_x.push_back(x);
    row_start[y + 1] = static_cast<int>(measured_x.size());
  }
  const double max_d2 = double(max_distance) * max_distance;
  DefaultThreadPool().ParallelFor(0, h, 4, [&](int64_t y0, int64_t y1) {
    for (int64_t y = y0; y < y1; ++y) {
      const int cy = static_cast<int>(y) / cell;
      // The search stays within the 3 x 3 cells around the pixel's cell.
      const int block_y0 = std::max(0, (cy - 1) * cell);
      const int block_y1 = std::min(h - 1, (cy + 2) * cell - 1);
      const int* row_distance = &rows[static_cast<size_t>(y) * w];
      for (int x = 0; x < w; ++x) {
        if (sparse.at(x, y) > 0.f) continue;
        const int cx = x / cell;
        // The nearest measurement: within max_distance it lies in the 3 x 3
        // cells (any outside is at least cell + 1 away).
        double nearest = std::numeric_limits<double>::infinity();
        for (int sx = std::max(0, x - max_distance); sx <= std::min(w - 1, x + max_distance);
             ++sx) {
          const double dy = row_distance[sx];
          nearest = std::min(nearest, double(sx - x) * (sx - x) + dy * dy);
        }
        if (nearest > max_d2) continue;
        // The nearer surface among measurements within 1.5 px of that
        // distance; equal depths go to the first in the order the cells and
        // their raster order give.
        const double limit = std::pow(std::sqrt(nearest) + 1.5, 2);
        const int reach = static_cast<int>(std::sqrt(limit)) + 1;
        const int block_x0 = std::max(0, (cx - 1) * cell);
        const int block_x1 = std::min(w - 1, (cx + 2) * cell - 1);
        float best = std::numeric_limits<float>::infinity();
        int best_pixel = -1;
        int64_t best_order = 0;
        const int sx0 = std::max(block_x0, x - reach), sx1 = std::min(block_x1, x + reach);
        for (int sy = std::max(block_y0, static_cast<int>(y) - reach);
             sy <= std::min(block_y1, static_cast<int>(y) + reach); ++sy) {
          const int* row_begin = measured_x.data() + row_start[sy];
          const int* row_end = measured_x.data() + row_start[sy + 1];
          for (const int* it = std::lower_bound(row_begin, row_end, sx0);
               it != row_end && *it <= sx1; ++it) {
            const int sx = *it;
            const float depth = sparse.at(sx, sy);
            if (depth > best) continue;
            const double d2 = double(sx - x) * (sx - x) + double(sy - y) * (sy - y);
            if (d2 > limit) continue;
            const int64_t order = (int64_t((sy / cell) * gw + sx / cell) << 32) | (sy * w + sx);
            if (depth < best || order < best_order) {
              best = depth;
              best_pixel = sy * w + sx;
              best_order = order;
            }
          }
        }
        dense.at(x, static_cast<int>(y)) = best;
        if (sources != nullptr) (*sources)[static_cast<size_t>(y) * w + x] = best_pixel;
      }
    }
  });
  return dense;
}

namespace {

// Ground-plane fit (FitGroundPlane): reach of the candidates, their band
// of heights around the lowest ones, level tolerance, inlier distance,
// RANSAC trials.
constexpr double kGroundMinRange = 1.5, kGroundMaxRange = 60.0;
constexpr double kGroundBelowLowest = 0.5, kGroundAboveLowest = 2.0;
constexpr double kGroundMinCos = 0.94;  // cos(20 degrees)
constexpr double kGroundInlier = 0.1;
constexpr int kGroundTrials = 200;
constexpr size_t kGroundMinInliers = 50;
// A completed pixel within this (relative) of the road's depth is road: the
// completion gave it the nearest ring's depth, the plane gives its own.
constexpr double kGroundSnap = 0.15;
// A measured point this close to the plane (metres) is on the road (the
// inlier distance, and the half pixel its projection was rounded by).
constexpr double kGroundOnPlane = 0.15;

// Distance from `p` to the sensor along the plane perpendicular to `up`.
double ReachOf(const Vec3& p, const Vec3& origin, const Vec3& up) {
  const Vec3 d = p - origin;
  return Norm(d - Dot(d, up) * up);
}

}  // namespace

void LevelAxes(const Vec3& up, Vec3* e1, Vec3* e2) {
  const Vec3 seed = std::abs(up.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  *e1 = Normalized(Cross(up, seed));
  *e2 = Cross(up, *e1);
}

std::vector<size_t> CheckingViews(const std::vector<ContextView>& views, size_t v,
                                  double min_baseline, double max_baseline, double min_cos,
                                  int count) {
  struct Candidate {
    bool other_camera;
    double baseline;
    size_t index;
  };
  std::vector<Candidate> candidates;
  const Vec3 forward = views[v].world_from_camera.rotation * Vec3{0, 0, 1};
  for (size_t u = 0; u < views.size(); ++u) {
    if (u == v) continue;
    const double baseline =
        Norm(views[u].world_from_camera.translation - views[v].world_from_camera.translation);
    const Vec3 other = views[u].world_from_camera.rotation * Vec3{0, 0, 1};
    if (baseline < min_baseline || baseline > max_baseline || Dot(forward, other) <= min_cos) {
      continue;
    }
    candidates.push_back({views[u].camera_id != views[v].camera_id, baseline, u});
  }
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
    if (a.other_camera != b.other_camera) return !a.other_camera;
    if (a.baseline != b.baseline) return a.baseline < b.baseline;
    return a.index < b.index;
  });
  std::vector<size_t> out;
  for (size_t i = 0; i < candidates.size() && static_cast<int>(i) < count; ++i)
    out.push_back(candidates[i].index);
  return out;
}

GroundPlane FitGroundPlane(const LidarSweepData& sweep) {
  GroundPlane best;
  const Vec3 up = Normalized(sweep.sensor_up);
  const Vec3& o = sweep.sensor_origin;
  // Candidates: points within reach, at most 2 m above the lowest ones (the
  // 1st percentile of their heights; the sensor frame's origin may be on
  // the sensor or on the ground, so heights are not taken from it).
  std::vector<Vec3> near;
  std::vector<double> heights;
  const size_t n = sweep.points.size() / 3;
  for (size_t i = 0; i < n; ++i) {
    const Vec3 p{sweep.points[3 * i], sweep.points[3 * i + 1], sweep.points[3 * i + 2]};
    const double reach = ReachOf(p, o, up);
    if (reach < kGroundMinRange || reach > kGroundMaxRange) continue;
    near.push_back(p);
    heights.push_back(Dot(p - o, up));
  }
  if (near.empty()) return best;
  std::vector<double> sorted = heights;
  const size_t low_index = sorted.size() / 100;
  std::nth_element(sorted.begin(), sorted.begin() + low_index, sorted.end());
  const double lowest = sorted[low_index];
  std::vector<Vec3> candidates;
  for (size_t i = 0; i < near.size(); ++i) {
    if (heights[i] >= lowest - kGroundBelowLowest && heights[i] <= lowest + kGroundAboveLowest)
      candidates.push_back(near[i]);
  }
  const size_t min_inliers = std::max(kGroundMinInliers, candidates.size() / 10);
  if (candidates.size() < min_inliers) return best;

  // RANSAC over point triples, scored on at most 20 000 of the candidates.
  const size_t score_stride = std::max<size_t>(1, candidates.size() / 20000);
  uint64_t state = 0x9E3779B97F4A7C15ull;
  auto next = [&](size_t bound) {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<size_t>((state >> 33) % bound);
  };
  Vec3 best_normal;
  double best_offset = 0;
  size_t best_score = 0;
  for (int trial = 0; trial < kGroundTrials; ++trial) {
    const Vec3& a = candidates[next(candidates.size())];
    const Vec3& b = candidates[next(candidates.size())];
    const Vec3& c = candidates[next(candidates.size())];
    Vec3 normal = Cross(b - a, c - a);
    const double length = Norm(normal);
    if (length < 1e-9) continue;
    normal = normal / length;
    if (Dot(normal, up) < 0) normal = -normal;
    if (Dot(normal, up) < kGroundMinCos) continue;
    const double offset = Dot(normal, a);
    size_t score = 0;
    for (size_t i = 0; i < candidates.size(); i += score_stride)
      if (std::abs(Dot(normal, candidates[i]) - offset) < kGroundInlier) ++score;
    if (score > best_score) {
      best_score = score;
      best_normal = normal;
      best_offset = offset;
    }
  }
  if (best_score == 0) return best;

  // Least squares over the inliers: height h = a u + b v + c in a frame
  // with axes e1, e2 along the level plane and `up`.
  Vec3 e1, e2;
  LevelAxes(up, &e1, &e2);
  double s[3][3] = {}, t[3] = {};
  size_t count = 0;
  for (const Vec3& p : candidates) {
    if (std::abs(Dot(best_normal, p) - best_offset) >= kGroundInlier) continue;
    const Vec3 d = p - o;
    const double row[3] = {Dot(d, e1), Dot(d, e2), 1.0};
    const double h = Dot(d, up);
    for (int r = 0; r < 3; ++r) {
      for (int k = 0; k < 3; ++k) s[r][k] += row[r] * row[k];
      t[r] += row[r] * h;
    }
    ++count;
  }
  if (count < min_inliers) return best;
  Mat3 m;
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) m.m[r][k] = s[r][k];
  const double det = Determinant(m);
  if (std::abs(det) < 1e-12) return best;
  double coef[3];
  for (int col = 0; col < 3; ++col) {
    Mat3 replaced = m;
    for (int r = 0; r < 3; ++r) replaced.m[r][col] = t[r];
    coef[col] = Determinant(replaced) / det;
  }
  const Vec3 raw = up - coef[0] * e1 - coef[1] * e2;
  const double length = Norm(raw);
  best.normal = raw / length;
  best.offset = (Dot(raw, o) + coef[2]) / length;
  if (Dot(best.normal, up) < kGroundMinCos) return GroundPlane{};
  for (const Vec3& p : candidates) {
    if (std::abs(Dot(best.normal, p) - best.offset) >= kGroundInlier) continue;
    ++best.inliers;
    best.reach = std::max(best.reach, ReachOf(p, o, best.normal));
  }
  best.valid = best.inliers >= min_inliers;
  return best;
}

int64_t FillFromGround(const GroundPlane& ground, const Vec3& sensor_origin, const LinePoses& lines,
                       const std::vector<int32_t>& sources, ImageF* depth) {
  if (!ground.valid) return 0;
  const CameraModel& camera = lines.camera();
  // A camera under the road sees no road from above.
  if (Dot(ground.normal, lines.WorldFromCamera(0).translation) - ground.offset <= 0 &&
      Dot(ground.normal, lines.WorldFromCamera(1).translation) - ground.offset <= 0) {
    return 0;
  }
  // The z depth at which pixel centre (x, y)'s ray from its line's centre
  // `origin` meets the plane, 0 when it does not (at or above the horizon).
  auto plane_depth = [&](int x, int y, Vec3* dir, Vec3* origin) {
    Vec3 ray;
    if (!camera.Unproject(x + 0.5, y + 0.5, &ray)) return 0.0;
    const Rigid pose = lines.WorldFromCameraAt(x + 0.5, y + 0.5);
    *origin = pose.translation;
    const double height = Dot(ground.normal, *origin) - ground.offset;
    if (height <= 0) return 0.0;
    *dir = pose.rotation * ray;  // z-scaled: s is the z depth.
    const double down = -Dot(ground.normal, *dir);
    return down > 1e-9 ? height / down : 0.0;
  };
  // Measured pixels whose point lies on the road, and the ratio of their
  // depth to the plane's there: the road's local departure from the plane
  // (a crown, a change of slope). Each measurement's ratio also carries its
  // position inside its pixel (up to half a pixel off the centre the plane
  // is met through), so the ratio used is the mean over the road
  // measurements within the completion radius: the departure stays, the
  // pixel noise averages out.
  const int w = depth->width, h = depth->height;
  std::vector<uint8_t> on_ground(sources.size(), 0);
  // Summed-area tables, [H + 1, W + 1], of the ratios (less 1) and of the
  // road measurements.
  auto at = [&](int x, int y) { return static_cast<size_t>(y) * (w + 1) + x; };
  std::vector<double> ratio_sum(static_cast<size_t>(w + 1) * (h + 1), 0.0);
  std::vector<double> count(ratio_sum.size(), 0.0);
  for (size_t i = 0; i < sources.size(); ++i) {
    if (sources[i] != static_cast<int32_t>(i)) continue;
    Vec3 p;
    const int x = static_cast<int>(i % w), y = static_cast<int>(i / w);
    if (!lines.Lift(x + 0.5, y + 0.5, depth->pixels[i], &p)) continue;
    on_ground[i] = std::abs(Dot(ground.normal, p) - ground.offset) < kGroundOnPlane;
    Vec3 dir, origin;
    const double s = on_ground[i] ? plane_depth(x, y, &dir, &origin) : 0.0;
    if (s > 0 && std::abs(depth->pixels[i] - s) <= kGroundSnap * s) {
      ratio_sum[at(x + 1, y + 1)] = depth->pixels[i] / s - 1.0;
      count[at(x + 1, y + 1)] = 1.0;
    }
  }
  for (int y = 1; y <= h; ++y) {
    for (int x = 1; x <= w; ++x) {
      ratio_sum[at(x, y)] +=
          ratio_sum[at(x - 1, y)] + ratio_sum[at(x, y - 1)] - ratio_sum[at(x - 1, y - 1)];
      count[at(x, y)] += count[at(x - 1, y)] + count[at(x, y - 1)] - count[at(x - 1, y - 1)];
    }
  }
  const int radius = CompletionRadius(h);
  auto local_ratio = [&](int x, int y) {
    const int x0 = std::max(0, x - radius), x1 = std::min(w, x + radius + 1);
    const int y0 = std::max(0, y - radius), y1 = std::min(h, y + radius + 1);
    const double n = count[at(x1, y1)] - count[at(x0, y1)] - count[at(x1, y0)] + count[at(x0, y0)];
    if (n < 0.5) return 1.0;
    return 1.0 + (ratio_sum[at(x1, y1)] - ratio_sum[at(x0, y1)] - ratio_sum[at(x1, y0)] +
                  ratio_sum[at(x0, y0)]) /
                     n;
  };
  std::atomic<int64_t> filled{0};
  DefaultThreadPool().ParallelFor(0, depth->height, 16, [&](int64_t y0, int64_t y1) {
    int64_t local = 0;
    for (int64_t y = y0; y < y1; ++y) {
      for (int x = 0; x < depth->width; ++x) {
        const size_t i = static_cast<size_t>(y) * depth->width + x;
        if (sources[i] == static_cast<int32_t>(i)) continue;  // Measured.
        float& d = depth->at(x, static_cast<int>(y));
        Vec3 dir, origin;
        const double s = plane_depth(x, static_cast<int>(y), &dir, &origin);
        if (s <= 0) continue;
        if (ReachOf(origin + s * dir, sensor_origin, ground.normal) > ground.reach) continue;
        const bool from_road = sources[i] >= 0 && on_ground[sources[i]];
        if (d > 0.f && !(from_road && std::abs(d - s) <= kGroundSnap * s)) {
          continue;  // Completed from another surface.
        }
        d = static_cast<float>(s * local_ratio(x, static_cast<int>(y)));
        ++local;
      }
    }
    filled += local;
  });
  return filled.load();
}

double FarDepth(const FarLayer& far, const CameraModel& camera, const Rigid& world_from_camera,
                double u, double v) {
  Vec3 ray;
  if (!camera.Unproject(u, v, &ray)) return 0.0;
  // Solve |o + s d - c| = R for s > 0 with d the world ray (z-scaled).
  const Vec3 d = world_from_camera.rotation * ray;
  const Vec3 oc = world_from_camera.translation - far.center;
  const double a = Dot(d, d), b = 2 * Dot(oc, d), c = Dot(oc, oc) - far.radius * far.radius;
  const double disc = b * b - 4 * a * c;
  if (disc < 0) return 0.0;
  const double s = (-b + std::sqrt(disc)) / (2 * a);
  return s > 0 ? s : 0.0;  // ray has z = 1, so s is the z depth.
}

FarLayer FarLayerFor(const std::vector<ContextView>& views, const std::vector<float>& max_depths,
                     double min_radius) {
  FarLayer far;
  if (views.empty()) {
    far.radius = min_radius;
    return far;
  }
  for (const ContextView& view : views)
    far.center = far.center + view.world_from_camera.translation;
  far.center = far.center / double(views.size());
  double spread = 0, deepest = 0;
  for (const ContextView& view : views)
    spread = std::max(spread, Norm(view.world_from_camera.translation - far.center));
  for (float d : max_depths) deepest = std::max(deepest, double(d));
  far.radius = std::max(min_radius, 2.0 * (spread + deepest));
  return far;
}

namespace {

// The known pixels of a sparse depth map as a sweep: lifted to the world,
// seen from the camera centre, "up" being the camera's image-up axis (level
// on a car's cameras), so that the ground plane is fitted to them as to a
// LiDAR's points.
LidarSweepData SweepFromDepthMap(const ContextView& view, const ImageF& sparse) {
  LidarSweepData sweep;
  sweep.timestamp_us = view.timestamp_us;
  sweep.sensor_origin = view.world_from_camera.translation;
  sweep.sensor_up = Normalized(view.world_from_camera.rotation * Vec3{0, -1, 0});
  const LinePoses lines = view.lines();
  for (int y = 0; y < sparse.height; ++y) {
    for (int x = 0; x < sparse.width; ++x) {
      const float d = sparse.at(x, y);
      Vec3 ray;
      if (!(d > 0.f) || !view.camera.Unproject(x + 0.5, y + 0.5, &ray)) continue;
      const Vec3 p = lines.WorldFromCameraAt(x + 0.5, y + 0.5) * (ray * double(d));
      sweep.points.insert(sweep.points.end(), {float(p.x), float(p.y), float(p.z)});
    }
  }
  return sweep;
}

// Completes `sparse` (measured pixels of `view`, 0 unknown) by `options`:
// nearest or IP-Basic completion, then the ground plane of `sweep`.
ImageF CompleteMeasured(const ImageF& sparse, const LidarSweepData& sweep, const ContextView& view,
                        const CompletionOptions& options, int64_t* ground_pixels,
                        GroundPlane* ground) {
  std::vector<int32_t> sources;
  ImageF depth = CompleteDepth(sparse, options, options.ground_fill ? &sources : nullptr);
  if (options.method == CompletionOptions::Method::kIpBasic) {
    IpBasicOptions ip_basic;
    ip_basic.extrapolate = false;
    const ImageF dense = CompleteDepthIpBasic(sparse, ip_basic);
    for (size_t i = 0; i < depth.pixels.size(); ++i) {
      if (dense.pixels[i] > 0.f) depth.pixels[i] = dense.pixels[i];
    }
  }
  const GroundPlane plane =
      options.ground_fill || options.facades ? FitGroundPlane(sweep) : GroundPlane{};
  if (ground != nullptr) *ground = plane;
  if (options.ground_fill) {
    const int64_t filled =
        FillFromGround(plane, sweep.sensor_origin, view.lines(), sources, &depth);
    if (ground_pixels != nullptr) *ground_pixels = filled;
  }
  return depth;
}

}  // namespace

ImageF MeasuredDepth(const ContextView& view, const std::vector<LidarSweepData>& sweeps,
                     const std::vector<InstanceTrack>& tracks, const CompletionOptions& options,
                     MeasuredSource* source, int64_t* ground_pixels, GroundPlane* ground) {
  if (source != nullptr) *source = MeasuredSource::kNone;
  if (ground_pixels != nullptr) *ground_pixels = 0;
  if (ground != nullptr) *ground = GroundPlane{};
  if (view.depth.width > 0) {
    const ImageF depth = KnownDepthOnly(view.depth);
    if (!IsSparseDepth(depth)) {
      if (source != nullptr) *source = MeasuredSource::kDepthMap;
      return depth;
    }
    if (source != nullptr) *source = MeasuredSource::kSparseDepthMap;
    return CompleteMeasured(depth, SweepFromDepthMap(view, depth), view, options, ground_pixels,
                            ground);
  }
  const int nearest = NearestSweep(sweeps, view.timestamp_us);
  if (nearest < 0) return ImageF(view.width(), view.height(), 1);
  if (source != nullptr) *source = MeasuredSource::kLidar;
  const LidarSweepData& sweep = sweeps[nearest];
  const std::vector<float> points = PointsAtTime(sweep, tracks, view.middle_time_us());
  const ImageF projected = ProjectPoints(points, view.lines());
  return CompleteMeasured(projected, sweep, view, options, ground_pixels, ground);
}

ViewDepth WithFarLayer(const ImageF& measured, bool completed, const ContextView& view,
                       const FarLayer& far) {
  ViewDepth out;
  out.width = measured.width;
  out.height = measured.height;
  const size_t n = static_cast<size_t>(out.width) * out.height;
  out.depth.resize(n);
  out.source.resize(n);
  const uint8_t measured_source =
      uint8_t(completed ? DepthSource::kCompleted : DepthSource::kDepthMap);
  const LinePoses lines = view.lines();
  DefaultThreadPool().ParallelFor(0, out.height, 16, [&](int64_t y0, int64_t y1) {
    for (int64_t y = y0; y < y1; ++y) {
      for (int x = 0; x < out.width; ++x) {
        const size_t i = static_cast<size_t>(y) * out.width + x;
        const float d = measured.pixels[i];
        if (d > 0.f) {
          out.depth[i] = d;
          out.source[i] = measured_source;
        } else {
          out.depth[i] = static_cast<float>(FarDepth(
              far, view.camera, lines.WorldFromCameraAt(x + 0.5, y + 0.5), x + 0.5, y + 0.5));
          out.source[i] = uint8_t(DepthSource::kFar);
        }
      }
    }
  });
  return out;
}

namespace {

// Four lanes of float and int32 (SSE2 on x86-64, NEON elsewhere).
using F4 = float __attribute__((vector_size(16)));
using I4 = int32_t __attribute__((vector_size(16)));

// One row of FindBehindSources' window maximum at offset `step`: for each
// pixel x of row y, the first deepest of the 3 x 3 pixels at offsets
// -step, 0, +step (rows outer, columns inner, clamped to the image), the
// pixel's own entry first; strict ">" keeps the first of equal depths.
void WindowMaxRow(const int32_t* deepest, const float* depth, int w, int h, int64_t y, int step,
                  int32_t* next, float* next_depth) {
  const size_t rows[3] = {size_t(std::clamp<int64_t>(y - step, 0, h - 1)) * w, size_t(y) * w,
                          size_t(std::clamp<int64_t>(y + step, 0, h - 1)) * w};
  const size_t row = size_t(y) * w;
  auto scalar = [&](int x) {
    const size_t i = row + x;
    int32_t best = deepest[i];
    float best_depth = depth[i];
    const int xs[3] = {std::clamp(x - step, 0, w - 1), x, std::clamp(x + step, 0, w - 1)};
    for (size_t r : rows) {
      for (int xx : xs) {
        if (depth[r + xx] > best_depth) best = deepest[r + xx], best_depth = depth[r + xx];
      }
    }
    next[i] = best;
    next_depth[i] = best_depth;
  };
  // Lanes where no offset leaves the row.
  const int first = std::min(step, w), last = std::max(first, w - step);
  int x = 0;
  for (; x < first; ++x) scalar(x);
  for (; x + 4 <= last; x += 4) {
    const size_t i = row + x;
    I4 best;
    F4 best_depth;
    std::memcpy(&best, deepest + i, sizeof(best));
    std::memcpy(&best_depth, depth + i, sizeof(best_depth));
    for (size_t r : rows) {
      for (int dx = -step; dx <= step; dx += step) {
        const size_t j = r + x + dx;
        I4 candidate;
        F4 candidate_depth;
        std::memcpy(&candidate, deepest + j, sizeof(candidate));
        std::memcpy(&candidate_depth, depth + j, sizeof(candidate_depth));
        const I4 deeper = candidate_depth > best_depth;
        best = deeper ? candidate : best;
        best_depth = deeper ? candidate_depth : best_depth;
      }
    }
    std::memcpy(next + i, &best, sizeof(best));
    std::memcpy(next_depth + i, &best_depth, sizeof(best_depth));
  }
  for (; x < w; ++x) scalar(x);
}

}  // namespace

BehindSources FindBehindSources(const ViewDepth& depth, int band_px, double min_jump) {
  BehindSources out;
  const int w = depth.width, h = depth.height;
  const size_t n = static_cast<size_t>(w) * h;
  if (band_px < 1 || n == 0) return out;
  // deepest[i]: the deepest pixel of the window of the current radius, and
  // its depth beside it (read with it, not through it).
  std::vector<int32_t> deepest(n), next(n);
  std::vector<float> deepest_depth(depth.depth.begin(), depth.depth.end()), next_depth(n);
  for (size_t i = 0; i < n; ++i) deepest[i] = static_cast<int32_t>(i);
  int previous = 0;  // Radius of `deepest` (0: the pixel itself).
  for (int radius = 1; radius <= band_px; radius *= 2) {
    // The window of `radius` is the union of the windows of `previous` at
    // offsets -step, 0, +step per axis (step = radius - previous).
    const int step = radius - previous;
    std::vector<int32_t> sources(n);
    DefaultThreadPool().ParallelFor(0, h, 16, [&](int64_t y0, int64_t y1) {
      for (int64_t y = y0; y < y1; ++y) {
        WindowMaxRow(deepest.data(), deepest_depth.data(), w, h, y, step, next.data(),
                     next_depth.data());
        for (size_t i = size_t(y) * w; i < size_t(y + 1) * w; ++i) {
          sources[i] = next_depth[i] > (1.0 + min_jump) * depth.depth[i] ? next[i] : -1;
        }
      }
    });
    deepest.swap(next);
    deepest_depth.swap(next_depth);
    out.radii.push_back(radius);
    out.sources.push_back(std::move(sources));
    previous = radius;
  }
  return out;
}

}  // namespace pf
