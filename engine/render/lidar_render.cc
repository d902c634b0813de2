// LiDAR returns from a Gaussian scene, sector by sector (lidar_render.h).
#include "engine/render/lidar_render.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "engine/camera/image_pixel.h"
#include "engine/render/rasterizer.h"

namespace pf {
namespace {

constexpr double kLidarPi = 3.14159265358979323846;
constexpr double kLidarDegree = kLidarPi / 180;

// sensor_from_camera of a view looking along azimuth `azimuth` and
// elevation `elevation` (radians), OpenCV camera axes.
Mat3 SectorRotation(double azimuth, double elevation) {
  const Vec3 forward{std::cos(elevation) * std::cos(azimuth),
                     std::cos(elevation) * std::sin(azimuth), std::sin(elevation)};
  const Vec3 right{std::sin(azimuth), -std::cos(azimuth), 0};
  const Vec3 down = Cross(forward, right);
  Mat3 r;
  for (int i = 0; i < 3; ++i) {
    r.m[i][0] = right[i];
    r.m[i][1] = down[i];
    r.m[i][2] = forward[i];
  }
  return r;
}

// The depth at continuous pixel (u, v): bilinear between the 4 pixel
// centres around it where all four are returns on one surface (depths within
// 3 % of each other), so a ray is not read half a pixel off on a slanted
// surface; else pixel `nearest`'s, so no return falls between two surfaces.
double SmoothDepth(const RenderBuffers& b, double u, double v, double min_alpha, size_t nearest) {
  const double x = u - 0.5, y = v - 0.5;
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  if (x0 < 0 || y0 < 0 || x0 + 1 >= b.width || y0 + 1 >= b.height) return b.depth[nearest];
  const size_t p = static_cast<size_t>(y0) * b.width + x0;
  const size_t corners[4] = {p, p + 1, p + b.width, p + b.width + 1};
  float lo = b.depth[p], hi = b.depth[p];
  for (size_t c : corners) {
    if (!(b.alpha[c] >= min_alpha)) return b.depth[nearest];
    lo = std::min(lo, b.depth[c]);
    hi = std::max(hi, b.depth[c]);
  }
  if (!(hi <= 1.03f * lo)) return b.depth[nearest];
  const double fx = x - x0, fy = y - y0;
  const double top = b.depth[corners[0]] + fx * (b.depth[corners[1]] - b.depth[corners[0]]);
  const double bottom = b.depth[corners[2]] + fx * (b.depth[corners[3]] - b.depth[corners[2]]);
  return top + fy * (bottom - top);
}

}  // namespace

Rigid SweepPoseAt(const LidarSweepPose& pose, double fraction) {
  return InterpolateRigid(pose.world_from_sensor_start, pose.world_from_sensor_end, fraction);
}

absl::StatusOr<std::vector<LidarReturn>> RenderLidarRays(const GaussianScene& scene,
                                                         const std::vector<LidarRay>& rays,
                                                         const LidarSweepPose& pose,
                                                         const LidarRenderOptions& options,
                                                         const std::vector<ActorEdit>& edits) {
  if (options.sectors < 4 || options.sectors > 720) {
    return absl::InvalidArgumentError(
        absl::StrCat("sectors: must be in [4, 720], got ", options.sectors));
  }
  if (!(options.pixels_per_degree > 0 && options.pixels_per_degree <= 100)) {
    return absl::InvalidArgumentError(
        absl::StrCat("pixels_per_degree: must be in (0, 100], got ", options.pixels_per_degree));
  }
  // Each ray's unit direction, azimuth and elevation, and its sector.
  const int sectors = options.sectors;
  const double sector_width = 2 * kLidarPi / sectors;
  std::vector<std::vector<size_t>> members(sectors);
  std::vector<Vec3> unit(rays.size());
  for (size_t i = 0; i < rays.size(); ++i) {
    const double norm = Norm(rays[i].direction);
    if (!(norm > 0) || !std::isfinite(norm)) {
      return absl::InvalidArgumentError(
          absl::StrCat("rays[", i, "]: zero or non-finite direction"));
    }
    if (!(rays[i].sweep_fraction >= 0 && rays[i].sweep_fraction <= 1)) {
      return absl::InvalidArgumentError(absl::StrCat(
          "rays[", i, "]: sweep fraction must be in [0, 1], got ", rays[i].sweep_fraction));
    }
    unit[i] = rays[i].direction / norm;
    if (std::hypot(unit[i].x, unit[i].y) < std::sin(1 * kLidarDegree)) {
      // Within a degree of straight up or down: no sector view reaches it.
      continue;
    }
    double azimuth = std::atan2(unit[i].y, unit[i].x);
    if (azimuth < 0) azimuth += 2 * kLidarPi;
    const int s = std::min(sectors - 1, static_cast<int>(azimuth / sector_width));
    members[s].push_back(i);
  }

  std::vector<LidarReturn> out(rays.size());
  RenderOptions render_options;
  const int intensity_channel = scene.lidar_intensity_channel;
  render_options.features = intensity_channel >= 0;
  render_options.instance = false;
  for (int s = 0; s < sectors; ++s) {
    if (members[s].empty()) continue;
    // The view looks along the sector's middle azimuth, at the middle of its
    // rays' elevations, with square pixels of pixels_per_degree at its
    // centre, reaching every ray of the sector plus a pixel.
    const double azimuth = (s + 0.5) * sector_width;
    double lowest = kLidarPi, highest = -kLidarPi, fraction = 0;
    for (size_t i : members[s]) {
      const double elevation = std::asin(std::clamp(unit[i].z, -1.0, 1.0));
      lowest = std::min(lowest, elevation);
      highest = std::max(highest, elevation);
      fraction += rays[i].sweep_fraction;
    }
    fraction /= static_cast<double>(members[s].size());
    const double elevation = 0.5 * (lowest + highest);
    const Mat3 sensor_from_camera = SectorRotation(azimuth, elevation);
    const Mat3 camera_from_sensor = Transpose(sensor_from_camera);
    double tan_x = 0, tan_y = 0;
    for (size_t i : members[s]) {
      const Vec3 d = camera_from_sensor * unit[i];
      const double z = std::max(d.z, std::cos(80 * kLidarDegree));
      tan_x = std::max(tan_x, std::abs(d.x) / z);
      tan_y = std::max(tan_y, std::abs(d.y) / z);
    }
    const double focal = options.pixels_per_degree / kLidarDegree;
    const int width = 2 * static_cast<int>(std::ceil(tan_x * focal)) + 4;
    const int height = 2 * static_cast<int>(std::ceil(tan_y * focal)) + 4;
    RenderCamera camera;
    camera.model = CameraModel(width, height, focal, focal, 0.5 * width, 0.5 * height);
    const Rigid world_from_sensor = SweepPoseAt(pose, fraction);
    camera.world_from_camera = world_from_sensor * Rigid{sensor_from_camera, {}};
    const int64_t time_us =
        pose.start_us + static_cast<int64_t>(std::llround(
                            fraction * static_cast<double>(pose.end_us - pose.start_us)));
    absl::StatusOr<RenderBuffers> buffers = Render(scene, camera, time_us, edits, render_options);
    if (!buffers.ok()) return buffers.status();
    for (size_t i : members[s]) {
      const Vec3 d = camera_from_sensor * unit[i];
      double u, v;
      int px, py;
      if (!camera.model.Project(d, &u, &v) || !PixelInImage(u, v, width, height, &px, &py)) {
        continue;
      }
      const size_t pixel = static_cast<size_t>(py) * width + px;
      if (!(buffers->alpha[pixel] >= options.min_alpha)) continue;
      const double range = SmoothDepth(*buffers, u, v, options.min_alpha, pixel) / d.z;
      if (!(range > 0 && range <= options.max_range)) continue;
      const float intensity =
          intensity_channel < 0
              ? 0.f
              : buffers->features[pixel * scene.num_channels + intensity_channel] /
                    buffers->alpha[pixel];
      out[i] = {true, static_cast<float>(range), intensity};
    }
  }
  return out;
}

}  // namespace pf
