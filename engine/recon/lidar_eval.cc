// LiDAR rendered against a recorded sweep (lidar_eval.h).
#include "engine/recon/lidar_eval.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <vector>

#include "absl/container/flat_hash_map.h"
#include "common/status_macros.h"
#include "engine/camera/image_pixel.h"

namespace pf {
namespace {

// Nearest-neighbour distances to a point cloud, by a hash grid of cells
// kCell wide searched in growing shells, capped at kChamferCap.
class NearestPoints {
 public:
  explicit NearestPoints(const std::vector<Vec3>& points) : points_(points) {
    for (size_t i = 0; i < points_.size(); ++i) cells_[Key(Cell(points_[i]))].push_back(i);
  }

  double Distance(const Vec3& p) const {
    const std::array<int64_t, 3> c = Cell(p);
    double best = kChamferCap;
    for (int shell = 0; shell * kCell <= best + kCell && shell <= kMaxShell; ++shell) {
      for (int dx = -shell; dx <= shell; ++dx) {
        for (int dy = -shell; dy <= shell; ++dy) {
          for (int dz = -shell; dz <= shell; ++dz) {
            if (std::max({std::abs(dx), std::abs(dy), std::abs(dz)}) != shell) continue;
            const auto it = cells_.find(Key({c[0] + dx, c[1] + dy, c[2] + dz}));
            if (it == cells_.end()) continue;
            for (size_t i : it->second) best = std::min(best, Norm(points_[i] - p));
          }
        }
      }
    }
    return best;
  }

 private:
  static constexpr double kCell = 1.0;
  static constexpr int kMaxShell = static_cast<int>(kChamferCap / kCell) + 1;

  static std::array<int64_t, 3> Cell(const Vec3& p) {
    return {static_cast<int64_t>(std::floor(p.x / kCell)),
            static_cast<int64_t>(std::floor(p.y / kCell)),
            static_cast<int64_t>(std::floor(p.z / kCell))};
  }
  static uint64_t Key(const std::array<int64_t, 3>& c) {
    auto q = [](int64_t v) { return static_cast<uint64_t>(v + (1 << 20)) & 0x1FFFFF; };
    return (q(c[0]) << 42) | (q(c[1]) << 21) | q(c[2]);
  }

  const std::vector<Vec3>& points_;
  absl::flat_hash_map<uint64_t, std::vector<size_t>> cells_;
};

double MeanDistance(const std::vector<Vec3>& from, const NearestPoints& to) {
  if (from.empty()) return kChamferCap;
  double sum = 0;
  for (const Vec3& p : from) sum += to.Distance(p);
  return sum / static_cast<double>(from.size());
}

double Quantile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  const size_t k = std::min(values.size() - 1, static_cast<size_t>(q * values.size()));
  std::nth_element(values.begin(), values.begin() + k, values.end());
  return values[k];
}

}  // namespace

LidarSweepFigures MeanLidarFigures(const std::vector<LidarSweepFigures>& sweeps) {
  LidarSweepFigures mean;
  for (const LidarSweepFigures& f : sweeps) {
    mean.sweep_points += f.sweep_points;
    mean.points += f.points;
    mean.hit_share += f.hit_share;
    mean.range_error_median += f.range_error_median;
    mean.range_error_p90 += f.range_error_p90;
    mean.early_share += f.early_share;
    mean.late_share += f.late_share;
    mean.chamfer += f.chamfer;
    mean.render_seconds += f.render_seconds;
  }
  if (sweeps.empty()) return mean;
  const double n = static_cast<double>(sweeps.size());
  mean.hit_share /= n;
  mean.range_error_median /= n;
  mean.range_error_p90 /= n;
  mean.early_share /= n;
  mean.late_share /= n;
  mean.chamfer /= n;
  return mean;
}

absl::StatusOr<LidarSweepFigures> EvaluateLidarRender(const GaussianScene& scene,
                                                      const LidarSweepData& sweep,
                                                      const std::vector<SeeingCamera>& cameras,
                                                      const LidarRenderOptions& options) {
  std::vector<Rigid> camera_from_world;
  for (const SeeingCamera& c : cameras) camera_from_world.push_back(c.world_from_camera.Inverse());
  auto seen = [&](const Vec3& p) {
    for (size_t k = 0; k < cameras.size(); ++k) {
      const CameraModel& model = cameras[k].model;
      double u, v;
      int px, py;
      if (model.Project(camera_from_world[k] * p, &u, &v) &&
          PixelInImage(u, v, model.width(), model.height(), &px, &py)) {
        return true;
      }
    }
    return false;
  };
  // A sensor frame with z along the sensor's up (azimuth about it); its x
  // and y are any pair across it.
  const Vec3 up = Normalized(sweep.sensor_up);
  const Vec3 any = std::abs(up.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  const Vec3 x = Normalized(Cross(any, up)), y = Cross(up, x);
  LidarSweepPose pose;
  for (int r = 0; r < 3; ++r) {
    pose.world_from_sensor_start.rotation.m[r][0] = x[r];
    pose.world_from_sensor_start.rotation.m[r][1] = y[r];
    pose.world_from_sensor_start.rotation.m[r][2] = up[r];
  }
  pose.world_from_sensor_start.translation = sweep.sensor_origin;
  pose.world_from_sensor_end = pose.world_from_sensor_start;
  pose.start_us = pose.end_us = sweep.timestamp_us;
  const Mat3 sensor_from_world = Transpose(pose.world_from_sensor_start.rotation);

  std::vector<LidarRay> rays;
  std::vector<Vec3> recorded;
  std::vector<double> recorded_range;
  int64_t sweep_points = 0;
  for (size_t i = 0; i + 2 < sweep.points.size(); i += 3) {
    const Vec3 p{sweep.points[i], sweep.points[i + 1], sweep.points[i + 2]};
    const Vec3 offset = p - sweep.sensor_origin;
    const double range = Norm(offset);
    if (!(range > 0.1 && range <= options.max_range)) continue;
    ++sweep_points;
    if (!seen(p)) continue;
    rays.push_back({sensor_from_world * offset, 0.5});
    recorded.push_back(p);
    recorded_range.push_back(range);
  }
  if (rays.empty()) {
    return absl::FailedPreconditionError("no point of the sweep lies in a camera's image");
  }
  const auto start = std::chrono::steady_clock::now();
  ASSIGN_OR_RETURN(const std::vector<LidarReturn> returns,
                   RenderLidarRays(scene, rays, pose, options));
  LidarSweepFigures figures;
  figures.render_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  figures.timestamp_us = sweep.timestamp_us;
  figures.sweep_points = sweep_points;
  figures.points = static_cast<int64_t>(rays.size());
  std::vector<double> errors;
  std::vector<Vec3> rendered;
  int64_t early = 0, late = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    if (!returns[i].hit) continue;
    const double signed_error = returns[i].range - recorded_range[i];
    errors.push_back(std::abs(signed_error));
    early += signed_error < -SignedTolerance(recorded_range[i]);
    late += signed_error > SignedTolerance(recorded_range[i]);
    rendered.push_back(sweep.sensor_origin + (returns[i].range / recorded_range[i]) *
                                                 (recorded[i] - sweep.sensor_origin));
  }
  figures.hit_share = static_cast<double>(errors.size()) / static_cast<double>(rays.size());
  if (!errors.empty()) {
    figures.early_share = static_cast<double>(early) / static_cast<double>(errors.size());
    figures.late_share = static_cast<double>(late) / static_cast<double>(errors.size());
  }
  figures.range_error_median = Quantile(errors, 0.5);
  figures.range_error_p90 = Quantile(errors, 0.9);
  const NearestPoints to_recorded(recorded), to_rendered(rendered);
  figures.chamfer =
      0.5 * (MeanDistance(rendered, to_recorded) + MeanDistance(recorded, to_rendered));
  return figures;
}

}  // namespace pf
