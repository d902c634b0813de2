// Reading and writing clip manifests: the JSON file (proto3 JSON mapping of
// pointforward.v1.Clip) that names a clip's cameras, frames, LiDAR sweeps and
// box tracks. docs/MANIFEST.md describes the schema and its conventions.
//
//   ASSIGN_OR_RETURN(LoadedClip loaded, LoadClip("scenes/a/clip.json"));
//   for (const auto& frame : loaded.clip.frames()) ...
//
//   RETURN_IF_ERROR(SaveClip(clip, out_dir + "/clip.json"));
//
// Parsing is strict and names the JSON path of every problem: malformed JSON
// (with line and column), unknown fields, values of the wrong type and enum
// names that do not exist. It checks the shape of the document only; what the
// values mean (poses rigid, files present, ...) is ValidateClip()'s job
// (clip_validator.h).
#ifndef POINTFORWARD_ENGINE_CLIP_CLIP_IO_H_
#define POINTFORWARD_ENGINE_CLIP_CLIP_IO_H_

#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "pointforward/v1/clip.pb.h"

namespace pf {

// One problem found in a manifest. `field` is the JSON path in the manifest's
// spelling ("frames[2].worldFromCamera", "cameras[0].intrinsics.fx"); empty
// when the problem concerns the whole document (malformed JSON).
struct ClipProblem {
  std::string field;
  std::string message;

  // Returns "field: message", or just the message when `field` is empty.
  std::string ToString() const;
};

// A parsed manifest and the directory its relative paths are resolved
// against.
struct LoadedClip {
  pointforward::v1::Clip clip;
  std::string dir;  // The manifest's directory (absolute, normalised).
};

// Parses JSON text `json` into `message` (any proto message) by the
// manifest's rules: proto3 JSON names, types checked, duplicate keys and
// unknown fields refused (with a "did you mean"), each problem naming its
// field path (`views[0].timestampUs`). Every problem found is appended to
// `problems` (if non-null) and the result is then INVALID_ARGUMENT whose
// message lists them one per line.
absl::Status ParseJsonMessage(const std::string& json, google::protobuf::Message* message,
                              std::vector<ClipProblem>* problems = nullptr);

// Parses manifest text `json`; relative paths in it will resolve against
// `dir`. Every problem found is appended to `problems` (if non-null) and the
// result is then INVALID_ARGUMENT whose message lists them one per line.
absl::StatusOr<LoadedClip> ParseClip(const std::string& json, const std::string& dir,
                                     std::vector<ClipProblem>* problems = nullptr);

// Reads and parses the manifest at `path` (see ParseClip). NOT_FOUND when the
// file does not exist.
absl::StatusOr<LoadedClip> LoadClip(const std::string& path,
                                    std::vector<ClipProblem>* problems = nullptr);

// Returns `clip` as pretty JSON in the manifest's spelling: lowerCamelCase
// field names, enums by name, int64 as plain numbers, fields at their default
// value left out, arrays of numbers on one line.
std::string ClipToJson(const pointforward::v1::Clip& clip);

// Writes ClipToJson(clip) to `path` atomically (temporary file and rename),
// creating missing parent directories. Paths inside `clip` are written as
// given: keep them relative to `path`'s directory.
absl::Status SaveClip(const pointforward::v1::Clip& clip, const std::string& path);

// A file the manifest references, as written in it.
struct ClipFileRef {
  std::string field;  // "frames[3].image", "cameras[0].egoMask", "lidar[0].points".
  std::string path;
};

// Every file `clip` references (cameras' ego masks, frame images and depth
// maps, LiDAR sweeps),
// in manifest order; a path named twice is listed once, at its first field.
std::vector<ClipFileRef> ReferencedFiles(const pointforward::v1::Clip& clip);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_CLIP_CLIP_IO_H_
