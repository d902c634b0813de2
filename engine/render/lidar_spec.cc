#include "engine/render/lidar_spec.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>

#include "absl/strings/str_cat.h"
#include "common/elapsed.h"
#include "common/file_util.h"
#include "common/status_macros.h"
#include "engine/image/oiio_write.h"

namespace pf {
namespace {

using OIIO::TypeDesc;

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegree = kPi / 180;

// Unit direction at `elevation_deg` and `azimuth_deg` in the sensor frame.
Vec3 Direction(double elevation_deg, double azimuth_deg) {
  const double e = elevation_deg * kDegree, a = azimuth_deg * kDegree;
  return {std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e)};
}

double ColumnAzimuthDeg(const LidarSpec& spec, int column) {
  return 180 - (column + 0.5) * spec.azimuth_resolution_deg;
}

double ColumnFraction(int column, int columns) { return (column + 0.5) / columns; }

}  // namespace

absl::Status CheckLidarSpec(const LidarSpec& spec, const std::string& field) {
  const size_t beams = spec.beam_elevations_deg.size();
  if (beams < 1 || beams > 1024) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ".beamElevationsDeg: must list 1 to 1024 beams, got ", beams));
  }
  for (size_t b = 0; b < beams; ++b) {
    const double e = spec.beam_elevations_deg[b];
    if (!(std::isfinite(e) && e > -90 && e < 90)) {
      return absl::InvalidArgumentError(absl::StrCat(field, ".beamElevationsDeg[", b,
                                                     "]: must be in (-90, 90) degrees, got ", e));
    }
  }
  if (!(spec.azimuth_resolution_deg >= 0.01 && spec.azimuth_resolution_deg <= 10)) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ".azimuthResolutionDeg: must be in [0.01, 10] degrees, got ",
                     spec.azimuth_resolution_deg));
  }
  if (!(spec.rotation_hz > 0 && spec.rotation_hz <= 100)) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ".rotationHz: must be in (0, 100], got ", spec.rotation_hz));
  }
  if (!(spec.max_range_m > 0 && spec.max_range_m <= 10000)) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ".maxRangeM: must be in (0, 10000] metres, got ", spec.max_range_m));
  }
  return absl::OkStatus();
}

int LidarColumns(const LidarSpec& spec) {
  return std::max(1, static_cast<int>(std::lround(360 / spec.azimuth_resolution_deg)));
}

std::vector<LidarRay> LidarSpecRays(const LidarSpec& spec) {
  const int columns = LidarColumns(spec);
  std::vector<LidarRay> rays;
  rays.reserve(spec.beam_elevations_deg.size() * columns);
  for (double elevation : spec.beam_elevations_deg) {
    for (int k = 0; k < columns; ++k) {
      rays.push_back({Direction(elevation, ColumnAzimuthDeg(spec, k)), ColumnFraction(k, columns)});
    }
  }
  return rays;
}

absl::StatusOr<RenderedSweep> RenderLidarSweep(const GaussianScene& scene, const LidarSpec& spec,
                                               const LidarSweepPose& pose,
                                               const std::vector<ActorEdit>& edits,
                                               const std::string& field) {
  RETURN_IF_ERROR(CheckLidarSpec(spec, field));
  const auto start = std::chrono::steady_clock::now();
  LidarRenderOptions options;
  options.max_range = spec.max_range_m;
  RenderedSweep out{spec, pose, {}, 0, 0};
  ASSIGN_OR_RETURN(out.returns, RenderLidarRays(scene, LidarSpecRays(spec), pose, options, edits));
  out.render_seconds = SecondsSince(start);
  for (const LidarReturn& r : out.returns) out.hits += r.hit ? 1 : 0;
  return out;
}

absl::Status WriteSweepPoints(const std::string& path, const RenderedSweep& sweep) {
  const int columns = LidarColumns(sweep.spec);
  const Rigid sensor_start_from_world = sweep.pose.world_from_sensor_start.Inverse();
  std::vector<float> records;
  records.reserve(4 * static_cast<size_t>(sweep.hits));
  for (size_t b = 0; b < sweep.spec.beam_elevations_deg.size(); ++b) {
    for (int k = 0; k < columns; ++k) {
      const LidarReturn& r = sweep.returns[b * columns + k];
      if (!r.hit) continue;
      const Vec3 in_sensor =
          r.range * Direction(sweep.spec.beam_elevations_deg[b], ColumnAzimuthDeg(sweep.spec, k));
      const Vec3 p = sensor_start_from_world *
                     (SweepPoseAt(sweep.pose, ColumnFraction(k, columns)) * in_sensor);
      records.insert(records.end(), {float(p.x), float(p.y), float(p.z), r.intensity});
    }
  }
  std::string bytes(records.size() * sizeof(float), '\0');
  if (!records.empty()) std::memcpy(bytes.data(), records.data(), bytes.size());
  return WriteFileAtomic(path, bytes);
}

absl::Status WriteRangeImageExr(const std::string& path, const RenderedSweep& sweep) {
  const int columns = LidarColumns(sweep.spec);
  const int rows = static_cast<int>(sweep.spec.beam_elevations_deg.size());
  if (sweep.returns.size() != static_cast<size_t>(rows) * columns) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": ", sweep.returns.size(),
                                                   " returns for ", rows, " x ", columns, " rays"));
  }
  // Channels in OpenEXR's order: hit, intensity, range.
  std::vector<float> pixels(static_cast<size_t>(rows) * columns * 3, 0.f);
  for (size_t i = 0; i < sweep.returns.size(); ++i) {
    pixels[3 * i] = sweep.returns[i].hit ? 1.f : 0.f;
    pixels[3 * i + 1] = sweep.returns[i].hit ? sweep.returns[i].intensity : 0.f;
    pixels[3 * i + 2] = sweep.returns[i].hit ? sweep.returns[i].range : 0.f;
  }
  OIIO::ImageSpec spec(columns, rows, 3, TypeDesc::FLOAT);
  spec.channelnames = {"hit", "intensity", "range"};
  spec.attribute("compression", "zip:1");
  std::vector<float> elevations(sweep.spec.beam_elevations_deg.begin(),
                                sweep.spec.beam_elevations_deg.end());
  spec.attribute("pf:beamElevationsDeg", TypeDesc(TypeDesc::FLOAT, rows), elevations.data());
  spec.attribute("pf:azimuthResolutionDeg", TypeDesc::DOUBLE, &sweep.spec.azimuth_resolution_deg);
  spec.attribute("pf:rotationHz", TypeDesc::DOUBLE, &sweep.spec.rotation_hz);
  spec.attribute("pf:maxRangeM", TypeDesc::DOUBLE, &sweep.spec.max_range_m);
  const std::array<double, 16> start = sweep.pose.world_from_sensor_start.ToRowMajor();
  const std::array<double, 16> end = sweep.pose.world_from_sensor_end.ToRowMajor();
  const TypeDesc m44d(TypeDesc::DOUBLE, TypeDesc::MATRIX44);
  spec.attribute("pf:worldFromSensorStart", m44d, start.data());
  spec.attribute("pf:worldFromSensorEnd", m44d, end.data());
  spec.attribute("pf:timestampUs", absl::StrCat(sweep.pose.start_us));

  return WriteImageAtomically(path, spec, TypeDesc::FLOAT, pixels.data());
}

absl::StatusOr<EstimatedLidarSpec> EstimateLidarSpec(const std::vector<float>& xyz,
                                                     const Vec3& origin, double min_range,
                                                     double max_range) {
  if (xyz.size() % 3 != 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("points: ", xyz.size(), " numbers is not a whole number of (x, y, z)"));
  }
  // Elevation and azimuth (degrees) of each point within range.
  std::vector<double> elevation, azimuth;
  for (size_t i = 0; i + 2 < xyz.size(); i += 3) {
    const Vec3 d = Vec3{xyz[i], xyz[i + 1], xyz[i + 2]} - origin;
    const double range = Norm(d);
    if (!(range >= min_range && range <= max_range)) continue;
    elevation.push_back(std::asin(std::clamp(d.z / range, -1.0, 1.0)) / kDegree);
    azimuth.push_back(std::atan2(d.y, d.x) / kDegree);
  }
  constexpr size_t kMinPoints = 1000;
  if (elevation.size() < kMinPoints) {
    return absl::InvalidArgumentError(absl::StrCat("points: ", elevation.size(), " within ",
                                                   min_range, "-", max_range, " m, need ",
                                                   kMinPoints, " to find the beams"));
  }
  // Histogram at 0.02 degrees over [-90, 90]; peaks: local maxima of a
  // 3-bin sum holding 0.2 % of the points, at least 0.15 degrees apart
  // (the fuller one kept).
  constexpr double kBin = 0.02;
  const int bins = static_cast<int>(std::lround(180 / kBin));
  std::vector<int64_t> histogram(bins, 0);
  auto bin_of = [&](double e) {
    return std::clamp(static_cast<int>((e + 90) / kBin), 0, bins - 1);
  };
  for (double e : elevation) ++histogram[bin_of(e)];
  std::vector<int64_t> smooth(bins, 0);
  for (int b = 0; b < bins; ++b) {
    for (int d = -1; d <= 1; ++d) {
      if (b + d >= 0 && b + d < bins) smooth[b] += histogram[b + d];
    }
  }
  const int64_t min_count =
      std::max<int64_t>(3, static_cast<int64_t>(0.002 * static_cast<double>(elevation.size())));
  const int min_gap = static_cast<int>(std::lround(0.15 / kBin));
  std::vector<int> peaks;  // Bins, by count, fullest first.
  for (int b = 0; b < bins; ++b) {
    if (smooth[b] < min_count) continue;
    if ((b > 0 && smooth[b - 1] > smooth[b]) || (b + 1 < bins && smooth[b + 1] >= smooth[b])) {
      continue;
    }
    peaks.push_back(b);
  }
  std::sort(peaks.begin(), peaks.end(), [&](int a, int b) { return smooth[a] > smooth[b]; });
  std::vector<int> kept;
  for (int p : peaks) {
    bool near = false;
    for (int q : kept) near = near || std::abs(p - q) < min_gap;
    if (!near) kept.push_back(p);
  }
  std::sort(kept.begin(), kept.end(), std::greater<int>());  // Highest first.
  if (kept.empty()) return absl::InvalidArgumentError("points: no beam holds 0.2 % of them");

  // Each point to its nearest peak within half the gap to the neighbours;
  // the beam at the mean elevation of its points.
  const size_t beams = kept.size();
  std::vector<double> centre(beams), sum(beams, 0);
  for (size_t b = 0; b < beams; ++b) centre[b] = -90 + (kept[b] + 0.5) * kBin;
  std::vector<int64_t> count(beams, 0);
  std::vector<int> beam_of(elevation.size(), -1);
  for (size_t i = 0; i < elevation.size(); ++i) {
    // centre is descending: find the nearest.
    size_t best = 0;
    for (size_t b = 1; b < beams; ++b) {
      if (std::abs(elevation[i] - centre[b]) < std::abs(elevation[i] - centre[best])) best = b;
    }
    const double gap_up = best > 0 ? centre[best - 1] - centre[best] : 1.0;
    const double gap_down = best + 1 < beams ? centre[best] - centre[best + 1] : 1.0;
    const double delta = elevation[i] - centre[best];
    if (delta > 0.5 * gap_up || -delta > 0.5 * gap_down) continue;
    beam_of[i] = static_cast<int>(best);
    sum[best] += elevation[i];
    ++count[best];
  }
  EstimatedLidarSpec out;
  double squared = 0;
  int64_t used = 0;
  for (size_t b = 0; b < beams; ++b) {
    centre[b] = count[b] > 0 ? sum[b] / static_cast<double>(count[b]) : centre[b];
  }
  for (size_t i = 0; i < elevation.size(); ++i) {
    if (beam_of[i] < 0) continue;
    const double delta = elevation[i] - centre[beam_of[i]];
    squared += delta * delta;
    ++used;
  }
  out.spec.beam_elevations_deg = centre;
  out.points_per_beam = count;
  out.points = used;
  out.elevation_rms_deg = used > 0 ? std::sqrt(squared / static_cast<double>(used)) : 0;
  out.spec.max_range_m = max_range;

  // Azimuth resolution: the median gap between successive distinct
  // azimuths of the fullest beam's points.
  const size_t fullest =
      static_cast<size_t>(std::max_element(count.begin(), count.end()) - count.begin());
  std::vector<double> az;
  for (size_t i = 0; i < elevation.size(); ++i) {
    if (beam_of[i] == static_cast<int>(fullest)) az.push_back(azimuth[i]);
  }
  std::sort(az.begin(), az.end());
  std::vector<double> gaps;
  for (size_t i = 1; i < az.size(); ++i) {
    if (az[i] - az[i - 1] > 1e-4) gaps.push_back(az[i] - az[i - 1]);
  }
  if (gaps.empty()) return absl::InvalidArgumentError("points: the fullest beam has one azimuth");
  std::nth_element(gaps.begin(), gaps.begin() + gaps.size() / 2, gaps.end());
  out.spec.azimuth_resolution_deg = std::clamp(gaps[gaps.size() / 2], 0.01, 10.0);
  return out;
}

}  // namespace pf
