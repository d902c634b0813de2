// Range image decoding (zlib + MatrixFloat) and polar-to-Cartesian conversion.
#include "engine/importers/waymo_lidar.h"

#include <zlib.h>

#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "common/status_macros.h"

namespace pf {
namespace {

namespace waymo = pointforward::waymo;

// Inflates zlib-wrapped `compressed`.
absl::StatusOr<std::string> Inflate(const std::string& compressed, const std::string& where) {
  z_stream zs{};
  if (inflateInit(&zs) != Z_OK) return absl::InternalError(where + ": inflateInit failed");
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(compressed.data()));
  zs.avail_in = static_cast<uInt>(compressed.size());
  std::string out(compressed.size() * 4 + 1024, '\0');
  int rc;
  do {
    if (zs.total_out == out.size()) out.resize(out.size() * 2);
    zs.next_out = reinterpret_cast<Bytef*>(out.data() + zs.total_out);
    zs.avail_out = static_cast<uInt>(out.size() - zs.total_out);
    rc = inflate(&zs, Z_NO_FLUSH);
  } while (rc == Z_OK);
  const size_t produced = zs.total_out;
  inflateEnd(&zs);
  if (rc != Z_STREAM_END) {
    return absl::DataLossError(absl::StrCat(where, ": zlib inflate failed (code ", rc, ")"));
  }
  out.resize(produced);
  return out;
}

// Decodes a compressed MatrixFloat of shape [H, W, channels].
absl::StatusOr<waymo::MatrixFloat> DecodeMatrix(const std::string& compressed, int channels,
                                                const std::string& where) {
  ASSIGN_OR_RETURN(std::string bytes, Inflate(compressed, where));
  waymo::MatrixFloat matrix;
  if (!matrix.ParseFromString(bytes)) {
    return absl::DataLossError(absl::StrCat(where, ": not a MatrixFloat"));
  }
  const auto& dims = matrix.shape().dims();
  if (dims.size() != 3 || dims[2] != channels || dims[0] <= 0 || dims[1] <= 0 ||
      static_cast<int64_t>(dims[0]) * dims[1] * dims[2] != matrix.data_size()) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": expected shape [H, W, ", channels, "] matching its data"));
  }
  return matrix;
}

Mat3 RotationFromEuler(double roll, double pitch, double yaw) {
  const double cr = std::cos(roll), sr = std::sin(roll), cp = std::cos(pitch), sp = std::sin(pitch),
               cy = std::cos(yaw), sy = std::sin(yaw);
  Mat3 r;  // Rz(yaw) * Ry(pitch) * Rx(roll).
  r.m = {{{cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr},
          {sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr},
          {-sp, cp * sr, cp * cr}}};
  return r;
}

}  // namespace

bool HasWaymoRangeImages(const waymo::Frame& frame) {
  for (const waymo::Laser& laser : frame.lasers()) {
    if (!laser.ri_return1().range_image_compressed().empty()) return true;
  }
  return false;
}

absl::StatusOr<std::vector<float>> WaymoRangeImagesToPoints(const waymo::Frame& frame,
                                                            const Rigid& world_from_vehicle) {
  std::vector<float> points;
  const Rigid vehicle_from_world = world_from_vehicle.Inverse();
  for (const waymo::Laser& laser : frame.lasers()) {
    const waymo::RangeImage& ri = laser.ri_return1();
    if (ri.range_image_compressed().empty()) continue;
    const std::string name = waymo::LaserName::Name_IsValid(laser.name())
                                 ? waymo::LaserName::Name_Name(laser.name())
                                 : absl::StrCat("laser#", laser.name());
    const std::string where = absl::StrCat("lasers[", name, "].ri_return1");
    const waymo::LaserCalibration* calibration = nullptr;
    for (const auto& c : frame.context().laser_calibrations()) {
      if (c.name() == laser.name()) calibration = &c;
    }
    if (calibration == nullptr) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, ": no context.laser_calibrations entry for ", name));
    }
    if (calibration->extrinsic().transform_size() != 16) {
      return absl::InvalidArgumentError(
          absl::StrCat("context.laser_calibrations[", name, "].extrinsic: expected 16 numbers"));
    }
    const Rigid vehicle_from_laser =
        Rigid::FromRowMajor(calibration->extrinsic().transform().data());
    ASSIGN_OR_RETURN(waymo::MatrixFloat image,
                     DecodeMatrix(ri.range_image_compressed(), 4, where + ".range_image"));
    const int height = image.shape().dims(0), width = image.shape().dims(1);

    // Inclination per row, row 0 the highest.
    std::vector<double> inclination(height);
    if (calibration->beam_inclinations_size() > 0) {
      if (calibration->beam_inclinations_size() != height) {
        return absl::InvalidArgumentError(absl::StrCat(where, ": ", height, " rows but ",
                                                       calibration->beam_inclinations_size(),
                                                       " beam_inclinations in the calibration"));
      }
      for (int i = 0; i < height; ++i) {
        inclination[i] = calibration->beam_inclinations(height - 1 - i);
      }
    } else {
      const double lo = calibration->beam_inclination_min(),
                   hi = calibration->beam_inclination_max();
      for (int i = 0; i < height; ++i) {
        inclination[i] = lo + (hi - lo) * (height - 1 - i + 0.5) / height;
      }
    }
    std::optional<waymo::MatrixFloat> pixel_pose;
    if (!ri.range_image_pose_compressed().empty()) {
      ASSIGN_OR_RETURN(pixel_pose, DecodeMatrix(ri.range_image_pose_compressed(), 6,
                                                where + ".range_image_pose"));
      if (pixel_pose->shape().dims(0) != height || pixel_pose->shape().dims(1) != width) {
        return absl::InvalidArgumentError(
            absl::StrCat(where, ".range_image_pose: size differs from the range image"));
      }
    }
    const double az_correction =
        std::atan2(vehicle_from_laser.rotation.m[1][0], vehicle_from_laser.rotation.m[0][0]);
    for (int row = 0; row < height; ++row) {
      const double ci = std::cos(inclination[row]), si = std::sin(inclination[row]);
      for (int col = 0; col < width; ++col) {
        const int64_t at = (static_cast<int64_t>(row) * width + col);
        const double range = image.data(at * 4);
        if (!(range > 0)) continue;
        const double azimuth = ((width - col - 0.5) / width * 2 - 1) * M_PI - az_correction;
        const Vec3 local{range * ci * std::cos(azimuth), range * ci * std::sin(azimuth),
                         range * si};
        Vec3 p = vehicle_from_laser * local;
        if (pixel_pose) {
          const float* q = pixel_pose->data().data() + at * 6;
          const Rigid world_from_pixel_vehicle{RotationFromEuler(q[0], q[1], q[2]),
                                               Vec3{q[3], q[4], q[5]}};
          p = vehicle_from_world * (world_from_pixel_vehicle * p);
        }
        points.insert(points.end(),
                      {static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z),
                       static_cast<float>(image.data(at * 4 + 1))});
      }
    }
  }
  return points;
}

}  // namespace pf
