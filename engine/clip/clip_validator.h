// Checking a clip manifest for everything later stages rely on: required
// fields, consistent ids and timestamps, finite numbers, rigid poses, unit
// quaternions, positive sizes, and referenced files that exist, stay inside
// the clip directory and match their camera's size. docs/MANIFEST.md lists
// every rule.
//
//   ASSIGN_OR_RETURN(LoadedClip loaded, LoadClip(path));
//   ClipReport report = ValidateClip(loaded, {});
//   if (!report.ok()) for (const ClipProblem& p : report.problems) ...
#ifndef POINTFORWARD_ENGINE_CLIP_CLIP_VALIDATOR_H_
#define POINTFORWARD_ENGINE_CLIP_CLIP_VALIDATOR_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "engine/clip/clip_io.h"
#include "engine/image/image_io.h"

namespace pf {

// Tolerances of the numeric checks.
inline constexpr double kRigidityTolerance = 1e-3;    // RigidityError() of a pose.
inline constexpr double kQuaternionTolerance = 1e-3;  // | |q| - 1 | of a box rotation.

// Largest |value| of a pose's translation or a box centre, in metres: past
// any driving log's world frame; larger (finite) values are refused as
// absurd before any arithmetic on them overflows.
inline constexpr double kMaxWorldCoordinate = 1e7;

// Returns "" when `value` is a usable world coordinate, else why not.
std::string WorldCoordinateProblem(double value);

// A camera's ego mask (Camera.ego_mask): pixels whose first channel is at
// least this are the ego vehicle's body.
inline constexpr float kEgoMaskThreshold = 0.5f;

// Returns the ego mask in `image`: [H, W] 1 on the ego body, 0 elsewhere.
std::vector<uint8_t> EgoMaskFromImage(const ImageF& image);

struct ValidateOptions {
  // Accept absolute paths and paths that leave the clip directory.
  bool allow_outside_paths = false;
  // Open the referenced files (images, depth maps, LiDAR sweeps). When false,
  // only the manifest itself is checked.
  bool check_files = true;
};

// What a clip holds; filled in whether or not it is valid.
struct ClipSummary {
  int cameras = 0;
  int frames = 0;
  int context_frames = 0;  // CONTEXT and ROLE_UNSPECIFIED.
  int target_frames = 0;
  int64_t first_timestamp_us = 0;  // Over frames; 0..0 when there are none.
  int64_t last_timestamp_us = 0;
  int instances = 0;
  int boxes = 0;
  int lidar_sweeps = 0;

  // Returns e.g. "3 cameras, 60 frames (12 CONTEXT, 48 TARGET), timestamps
  // 0..1900000 us, 3 instances, 20 LiDAR sweeps".
  std::string ToString() const;
};

struct ClipReport {
  std::vector<ClipProblem> problems;  // In manifest order; empty when valid.
  ClipSummary summary;

  bool ok() const { return problems.empty(); }
};

// Checks `loaded` against every rule of docs/MANIFEST.md and returns all
// problems found, each naming its field path.
ClipReport ValidateClip(const LoadedClip& loaded, const ValidateOptions& options);

// Loads the manifest at `path` and validates it: parse problems (malformed
// JSON, unknown fields, wrong types) are reported the same way, and the
// semantic checks run only when parsing succeeded.
ClipReport ValidateClipFile(const std::string& path, const ValidateOptions& options);

// Returns `problem` as pf validate prints it for the manifest at `path`:
// "field: message", or for a problem about the whole document (no field,
// e.g. malformed JSON) the message prefixed by the path unless it already
// starts with it.
std::string ClipProblemLine(const ClipProblem& problem, const std::string& path);

// Loads the manifest at `path` and validates it as ValidateClipFile does, for
// a command that goes on to use the clip, so that it stops before any work
// with what `pf validate` would say: INVALID_ARGUMENT with every problem
// (ClipProblemLine), one per line, after "PATH: N problems (pf validate lists
// them):" when there are several; NOT_FOUND when the file does not exist.
absl::StatusOr<LoadedClip> LoadValidClip(const std::string& path, const ValidateOptions& options);

// Resolves `relative` (a path written in the manifest) against the clip's
// directory. Absolute paths and paths that leave the directory (by ".." or a
// symbolic link) are INVALID_ARGUMENT unless `allow_outside`.
absl::StatusOr<std::string> ResolveClipPath(const LoadedClip& loaded, const std::string& relative,
                                            bool allow_outside);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_CLIP_CLIP_VALIDATOR_H_
