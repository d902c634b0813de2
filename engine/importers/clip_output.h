// What the importers share: their options, the result they return, and
// writing the clip manifest (DIR/clip.json) with a one-line summary.
#ifndef POINTFORWARD_ENGINE_IMPORTERS_CLIP_OUTPUT_H_
#define POINTFORWARD_ENGINE_IMPORTERS_CLIP_OUTPUT_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "common/geometry.h"
#include "engine/importers/frame_roles.h"
#include "pointforward/v1/clip.pb.h"

namespace pf {

struct ImportOptions {
  std::string out_dir;               // Receives clip.json, images/, lidar/.
  std::vector<std::string> cameras;  // Camera names to keep; empty = all.
  // Time window, as an offset from the source's first timestamp: frames with
  // start_us <= t - t0 < start_us + duration_us are kept.
  int64_t start_us = 0;
  std::optional<int64_t> duration_us;
  RolePolicy roles = RolePolicy::kPaper;
};

struct ImportResult {
  pointforward::v1::Clip clip;
  std::string manifest_path;          // out_dir/clip.json.
  std::vector<std::string> warnings;  // Things not imported, said plainly.
};

// The manifest's file name inside the output directory.
inline constexpr char kManifestName[] = "clip.json";

// Writes `clip` as pretty proto3 JSON (lowerCamelCase) to `out_dir`/clip.json
// atomically; returns the path.
absl::StatusOr<std::string> WriteClipManifest(const pointforward::v1::Clip& clip,
                                              const std::string& out_dir);

// Returns e.g. "5 cameras, 15 frames (8 context, 7 target), timestamps
// [t0, t1] us, 12 instances, 3 LiDAR sweeps".
std::string SummarizeClip(const pointforward::v1::Clip& clip);

// Sets `out` to the 16 row-major numbers of `t` (a manifest pose).
void SetRowMajor(const Rigid& t, google::protobuf::RepeatedField<double>* out);

// Appends a box at `timestamp_us` to `instance`: centre and box-to-world
// rotation from `world_from_box`, `size` = (length, width, height).
void AddBox(int64_t timestamp_us, const Rigid& world_from_box, const Vec3& size,
            pointforward::v1::Instance* instance);

// Writes `points` (float32 x, y, z, intensity records in the sensor frame)
// to `out_dir`/`relative` atomically and appends a sweep of them at
// `timestamp_us` with `world_from_sensor` to `clip`.
absl::Status AddLidarSweep(const std::vector<float>& points, const std::string& out_dir,
                           const std::string& relative, int64_t timestamp_us,
                           const Rigid& world_from_sensor, pointforward::v1::Clip* clip);

// Returns true if `t` (microseconds) is inside the window of `options`
// relative to the first timestamp `t0`.
bool InTimeWindow(const ImportOptions& options, int64_t t0, int64_t t);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_IMPORTERS_CLIP_OUTPUT_H_
