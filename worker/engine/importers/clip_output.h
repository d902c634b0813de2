// What the importers share: their options, the result they return, and
// writing the clip manifest (DIR/clip.json) with a one-line summary.
#ifndef POINTFORWARD_WORKER_ENGINE_IMPORTERS_CLIP_OUTPUT_H_
#define POINTFORWARD_WORKER_ENGINE_IMPORTERS_CLIP_OUTPUT_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "pointforward/v1/clip.pb.h"
#include "worker/engine/importers/frame_roles.h"

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

// Returns true if `t` (microseconds) is inside the window of `options`
// relative to the first timestamp `t0`.
bool InTimeWindow(const ImportOptions& options, int64_t t0, int64_t t);

}  // namespace pf

#endif  // POINTFORWARD_WORKER_ENGINE_IMPORTERS_CLIP_OUTPUT_H_
