// pf lidar spec SWEEP.bin [--origin X,Y,Z] [--min-range M] [--max-range M]
// Estimates a spinning LiDAR's beams from one recorded sweep (the clip's
// LiDAR record: float32 x, y, z, intensity in the sensor frame) and prints
// them as a pointforward.v1.LidarSpec (JSON, the `spec` of a RenderViews
// lidar) on stdout; how well the beams fit goes to stderr.
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "client/commands.h"
#include "common/command_line.h"
#include "common/file_util.h"
#include "common/status_macros.h"
#include "engine/render/lidar_spec.h"
#include "nlohmann/json.hpp"

namespace pf {
namespace {

constexpr char kLidarUsage[] =
    "usage: pf lidar spec SWEEP.bin [--origin X,Y,Z] [--min-range M] [--max-range M]";

absl::Status LidarSpecCommand(const CommandLine& cl) {
  if (cl.positional().size() != 2 || cl.positional()[0] != "spec") {
    return absl::InvalidArgumentError(kLidarUsage);
  }
  const std::string& path = cl.positional()[1];
  ASSIGN_OR_RETURN(const std::string bytes, ReadFileToString(path));
  if (bytes.size() % 16 != 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": ", bytes.size(),
                     " bytes is not a whole number of 16-byte (x, y, z, intensity) "
                     "float32 records"));
  }
  std::vector<float> xyz;
  xyz.reserve(bytes.size() / 16 * 3);
  for (size_t offset = 0; offset < bytes.size(); offset += 16) {
    float record[4];
    std::memcpy(record, bytes.data() + offset, sizeof(record));
    xyz.insert(xyz.end(), {record[0], record[1], record[2]});
  }
  Vec3 origin;
  if (cl.Has("origin")) {
    const std::vector<std::string> parts = absl::StrSplit(cl.Get("origin"), ',');
    double v[3];
    if (parts.size() != 3 || !absl::SimpleAtod(parts[0], &v[0]) ||
        !absl::SimpleAtod(parts[1], &v[1]) || !absl::SimpleAtod(parts[2], &v[2])) {
      return absl::InvalidArgumentError(
          absl::StrCat("--origin: expected X,Y,Z in metres, got '", cl.Get("origin"), "'"));
    }
    origin = {v[0], v[1], v[2]};
  }
  ASSIGN_OR_RETURN(const double min_range, cl.GetDouble("min-range", 1));
  ASSIGN_OR_RETURN(const double max_range, cl.GetDouble("max-range", 250));
  if (!(min_range >= 0 && max_range > min_range)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--min-range, --max-range: need 0 <= min < max, got ", min_range, ", ", max_range));
  }
  absl::StatusOr<EstimatedLidarSpec> estimated =
      EstimateLidarSpec(xyz, origin, min_range, max_range);
  if (!estimated.ok()) return StatusWithContext(estimated.status(), path);
  const LidarSpec& spec = estimated->spec;
  nlohmann::ordered_json json;
  json["beamElevationsDeg"] = spec.beam_elevations_deg;
  json["azimuthResolutionDeg"] = spec.azimuth_resolution_deg;
  json["rotationHz"] = spec.rotation_hz;
  json["maxRangeM"] = spec.max_range_m;
  std::printf("%s\n", json.dump(2).c_str());
  std::fprintf(stderr,
               "pf lidar spec: %zu beams from %lld of %zu points (%.2f to %.2f degrees), "
               "elevation RMS %.3f degrees from its beam, azimuth step %.3f degrees; "
               "rotationHz is not in a sweep: %.0f assumed\n",
               spec.beam_elevations_deg.size(), static_cast<long long>(estimated->points),
               xyz.size() / 3, spec.beam_elevations_deg.back(), spec.beam_elevations_deg.front(),
               estimated->elevation_rms_deg, spec.azimuth_resolution_deg, spec.rotation_hz);
  return absl::OkStatus();
}

}  // namespace

int RunLidar(const std::vector<std::string>& args) {
  absl::StatusOr<CommandLine> cl = CommandLine::Parse(args, {"origin", "min-range", "max-range"});
  if (!cl.ok()) return ReportError("lidar", cl.status());
  const absl::Status status = LidarSpecCommand(*cl);
  return status.ok() ? kExitOk : ReportError("lidar", status);
}

}  // namespace pf
