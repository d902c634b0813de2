// LiDAR rendered against a recorded sweep (lidar_eval.h).
#include "engine/recon/lidar_eval.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "absl/container/flat_hash_map.h"
#include "absl/strings/str_cat.h"
#include "common/elapsed.h"
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

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegree = kPi / 180;
// Cells are tested for a camera's view this far along their ray.
constexpr double kCellSeenDistance = 30;

double ElevationDeg(const Vec3& d) { return std::atan2(d.z, std::hypot(d.x, d.y)) / kDegree; }
double AzimuthDeg(const Vec3& d) { return std::atan2(d.y, d.x) / kDegree; }

// The beam of elevation `e` among `beams` (sorted from the highest down):
// the nearest, when `e` lies within half the gap to its neighbour on that
// side; -1 otherwise.
int BeamOf(const std::vector<double>& beams, double e) {
  int best = -1;
  double best_gap = 0;
  for (size_t b = 0; b < beams.size(); ++b) {
    const double d = std::abs(e - beams[b]);
    if (best < 0 || d < best_gap) best = static_cast<int>(b), best_gap = d;
  }
  if (best < 0) return -1;
  const bool above = e > beams[best];
  const int neighbour = above ? best - 1 : best + 1;
  if (neighbour < 0 || neighbour >= static_cast<int>(beams.size())) {
    // Beyond the outermost beam: within half the gap to the one inside.
    const int inside = above ? best + 1 : best - 1;
    if (inside < 0 || inside >= static_cast<int>(beams.size())) return best;
    return best_gap <= 0.5 * std::abs(beams[best] - beams[inside]) ? best : -1;
  }
  return best_gap <= 0.5 * std::abs(beams[best] - beams[neighbour]) ? best : -1;
}

// The firing azimuths' phase (degrees, in [0, resolution)): the circular
// mean of each direction's azimuth modulo the resolution.
double FiringPhaseDeg(const std::vector<Vec3>& directions, double resolution) {
  double c = 0, s = 0;
  for (const Vec3& d : directions) {
    const double a = 2 * kPi * AzimuthDeg(d) / resolution;
    c += std::cos(a), s += std::sin(a);
  }
  double phase = std::atan2(s, c) / (2 * kPi) * resolution;
  if (phase < 0) phase += resolution;
  return phase;
}

}  // namespace

absl::StatusOr<LidarSpec> SweepBeams(const std::vector<float>& sensor_xyz, double max_range) {
  ASSIGN_OR_RETURN(const EstimatedLidarSpec estimate,
                   EstimateLidarSpec(sensor_xyz, {}, 1, max_range));
  const std::vector<double>& beams = estimate.spec.beam_elevations_deg;
  int64_t in_range = 0;
  for (size_t i = 0; i + 2 < sensor_xyz.size(); i += 3) {
    const double r = Norm(Vec3{sensor_xyz[i], sensor_xyz[i + 1], sensor_xyz[i + 2]});
    in_range += r >= 1 && r <= max_range;
  }
  if (estimate.points < 0.99 * static_cast<double>(in_range)) {
    return absl::InvalidArgumentError(absl::StrCat("not one spinning head's sweep: its ",
                                                   beams.size(), " beams place ", estimate.points,
                                                   " of ", in_range, " points"));
  }
  double min_gap = 180;
  for (size_t b = 0; b + 1 < beams.size(); ++b)
    min_gap = std::min(min_gap, beams[b] - beams[b + 1]);
  if (beams.size() > 1 && !(estimate.elevation_rms_deg < 0.1 * min_gap)) {
    return absl::InvalidArgumentError(
        absl::StrCat("not one spinning head's sweep: elevation RMS ", estimate.elevation_rms_deg,
                     " degrees from its beams, against a smallest gap of ", min_gap, " degrees"));
  }
  return estimate.spec;
}

LidarSweepFigures MeanLidarFigures(const std::vector<LidarSweepFigures>& sweeps) {
  LidarSweepFigures mean;
  int with_cells = 0, with_intensity = 0;
  bool same_beams = !sweeps.empty();
  for (const LidarSweepFigures& f : sweeps) {
    same_beams = same_beams && !f.beams.empty() && f.beams.size() == sweeps[0].beams.size();
  }
  if (same_beams) mean.beams.resize(sweeps[0].beams.size());
  for (const LidarSweepFigures& f : sweeps) {
    if (f.intensity_rays > 0) {
      ++with_intensity;
      mean.intensity_rays += f.intensity_rays;
      mean.intensity_error_median += f.intensity_error_median;
      mean.intensity_constant_error_median += f.intensity_constant_error_median;
    }
    if (f.cells > 0) {
      ++with_cells;
      mean.cells += f.cells;
      mean.recorded_drop_share += f.recorded_drop_share;
      mean.rendered_drop_share += f.rendered_drop_share;
      mean.drop_agreement += f.drop_agreement;
    }
    for (size_t b = 0; b < mean.beams.size(); ++b) {
      LidarBeamFigures& m = mean.beams[b];
      const LidarBeamFigures& g = f.beams[b];
      m.elevation_deg += g.elevation_deg / static_cast<double>(sweeps.size());
      m.points += g.points;
      m.hit_share += g.hit_share / static_cast<double>(sweeps.size());
      m.range_error_median += g.range_error_median / static_cast<double>(sweeps.size());
      m.range_error_p90 += g.range_error_p90 / static_cast<double>(sweeps.size());
    }
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
  if (with_intensity > 0) {
    mean.intensity_error_median /= with_intensity;
    mean.intensity_constant_error_median /= with_intensity;
  }
  if (with_cells > 0) {
    mean.recorded_drop_share /= with_cells;
    mean.rendered_drop_share /= with_cells;
    mean.drop_agreement /= with_cells;
  }
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
  std::vector<float> recorded_intensity;
  const bool with_intensity =
      scene.lidar_intensity_channel >= 0 && sweep.intensities.size() == sweep.points.size() / 3;
  std::vector<Vec3> in_sensor;  // Every point within range, in the sensor frame.
  int64_t sweep_points = 0;
  for (size_t i = 0; i + 2 < sweep.points.size(); i += 3) {
    const Vec3 p{sweep.points[i], sweep.points[i + 1], sweep.points[i + 2]};
    const Vec3 offset = p - sweep.sensor_origin;
    const double range = Norm(offset);
    if (!(range > 0.1 && range <= options.max_range)) continue;
    ++sweep_points;
    in_sensor.push_back(sensor_from_world * offset);
    if (!seen(p)) continue;
    rays.push_back({in_sensor.back(), 0.5});
    recorded.push_back(p);
    recorded_range.push_back(range);
    if (with_intensity) recorded_intensity.push_back(sweep.intensities[i / 3]);
  }
  if (rays.empty()) {
    return absl::FailedPreconditionError("no point of the sweep lies in a camera's image");
  }
  const auto start = std::chrono::steady_clock::now();
  ASSIGN_OR_RETURN(const std::vector<LidarReturn> returns,
                   RenderLidarRays(scene, rays, pose, options));
  LidarSweepFigures figures;
  figures.render_seconds = SecondsSince(start);
  figures.timestamp_us = sweep.timestamp_us;
  figures.sweep_points = sweep_points;
  figures.points = static_cast<int64_t>(rays.size());
  std::vector<double> errors;
  std::vector<Vec3> rendered;
  std::vector<size_t> same_surface;  // Rays both return within SignedTolerance.
  int64_t early = 0, late = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    if (!returns[i].hit) continue;
    const double signed_error = returns[i].range - recorded_range[i];
    errors.push_back(std::abs(signed_error));
    early += signed_error < -SignedTolerance(recorded_range[i]);
    late += signed_error > SignedTolerance(recorded_range[i]);
    if (std::abs(signed_error) <= SignedTolerance(recorded_range[i])) same_surface.push_back(i);
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
  if (with_intensity && !same_surface.empty()) {
    std::vector<double> truth, error, constant_error;
    for (size_t i : same_surface) {
      truth.push_back(recorded_intensity[i]);
      error.push_back(std::abs(returns[i].intensity - recorded_intensity[i]));
    }
    const double constant = Quantile(truth, 0.5);
    for (double t : truth) constant_error.push_back(std::abs(t - constant));
    figures.intensity_rays = static_cast<int64_t>(same_surface.size());
    figures.intensity_error_median = Quantile(error, 0.5);
    figures.intensity_constant_error_median = Quantile(constant_error, 0.5);
  }

  // Per beam and the drops, where the sweep is one head's.
  std::vector<float> xyz;
  xyz.reserve(3 * in_sensor.size());
  for (const Vec3& d : in_sensor) xyz.insert(xyz.end(), {float(d.x), float(d.y), float(d.z)});
  const absl::StatusOr<LidarSpec> spec = SweepBeams(xyz, options.max_range);
  if (!spec.ok()) {
    figures.beams_note = std::string(spec.status().message());
    return figures;
  }
  const std::vector<double>& beams = spec->beam_elevations_deg;
  std::vector<std::vector<double>> beam_errors(beams.size());
  figures.beams.resize(beams.size());
  for (size_t b = 0; b < beams.size(); ++b) figures.beams[b].elevation_deg = beams[b];
  for (size_t i = 0; i < rays.size(); ++i) {
    const int b = BeamOf(beams, ElevationDeg(rays[i].direction));
    if (b < 0) continue;
    ++figures.beams[b].points;
    if (returns[i].hit) beam_errors[b].push_back(std::abs(returns[i].range - recorded_range[i]));
  }
  for (size_t b = 0; b < beams.size(); ++b) {
    LidarBeamFigures& f = figures.beams[b];
    if (f.points > 0) {
      f.hit_share = static_cast<double>(beam_errors[b].size()) / static_cast<double>(f.points);
    }
    f.range_error_median = Quantile(beam_errors[b], 0.5);
    f.range_error_p90 = Quantile(beam_errors[b], 0.9);
  }

  // Cells: a beam and a firing azimuth (the recorded azimuths' phase plus a
  // multiple of the resolution); a cell holding a recorded point returned.
  const int columns = LidarColumns(*spec);
  const double resolution = 360.0 / columns;
  const double phase = FiringPhaseDeg(in_sensor, resolution);
  std::vector<uint8_t> returned(beams.size() * columns, 0);
  for (const Vec3& d : in_sensor) {
    const int b = BeamOf(beams, ElevationDeg(d));
    if (b < 0) continue;
    int k = static_cast<int>(std::lround((AzimuthDeg(d) - phase) / resolution)) % columns;
    if (k < 0) k += columns;
    returned[b * columns + k] = 1;
  }
  std::vector<LidarRay> cell_rays;
  std::vector<uint8_t> cell_returned;
  const Mat3& world_from_sensor = pose.world_from_sensor_start.rotation;
  for (size_t b = 0; b < beams.size(); ++b) {
    for (int k = 0; k < columns; ++k) {
      const double e = beams[b] * kDegree, a = (phase + k * resolution) * kDegree;
      const Vec3 d{std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e)};
      if (!seen(sweep.sensor_origin + kCellSeenDistance * (world_from_sensor * d))) continue;
      cell_rays.push_back({d, 0.5});
      cell_returned.push_back(returned[b * columns + k]);
    }
  }
  if (cell_rays.empty()) return figures;
  const auto cells_start = std::chrono::steady_clock::now();
  ASSIGN_OR_RETURN(const std::vector<LidarReturn> cell_returns,
                   RenderLidarRays(scene, cell_rays, pose, options));
  figures.render_seconds += SecondsSince(cells_start);
  int64_t recorded_drops = 0, rendered_drops = 0, agree = 0;
  for (size_t c = 0; c < cell_rays.size(); ++c) {
    recorded_drops += !cell_returned[c];
    rendered_drops += !cell_returns[c].hit;
    agree += (cell_returned[c] != 0) == cell_returns[c].hit;
  }
  const double cells = static_cast<double>(cell_rays.size());
  figures.cells = static_cast<int64_t>(cell_rays.size());
  figures.recorded_drop_share = static_cast<double>(recorded_drops) / cells;
  figures.rendered_drop_share = static_cast<double>(rendered_drops) / cells;
  figures.drop_agreement = static_cast<double>(agree) / cells;
  return figures;
}

}  // namespace pf
