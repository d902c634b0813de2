// `pf import dgp`: a scene in TRI's DGP format (the format of DDAD) to a clip
// directory.
//
// What is read (docs/IMPORTERS.md has the reasoning and the checks):
// - scene_*.json: samples (one per time step) listing datum keys; each datum
//   has a name (CAMERA_01, LIDAR), an ISO-8601 timestamp (kept to the
//   microsecond), a file name and a pose that is world_from_sensor
//   (quaternion w, x, y, z + translation). Cameras use OpenCV axes.
// - calibration/<key>.json: per sensor name, intrinsics (fx, fy, cx, cy,
//   skew; skew must be 0) and sensor-to-vehicle extrinsics (not needed: the
//   datum poses already include them). cx and cy are kept as they are: the
//   scene's own 2D boxes show DGP's pixel coordinates start at the image edge
//   like ours (docs/IMPORTERS.md has the measurement).
// - rgb/ JPEGs, copied as they are to images/CAMERA_TIMESTAMP.jpg.
// - point_cloud/*.npz (data.npy, N x 4 float64: x, y, z, intensity in the
//   sensor frame) -> lidar/NAME_TIMESTAMP.bin (float32 x, y, z, intensity).
// - bounding_box_3d of the point-cloud datums (boxes in that sensor's frame,
//   converted to world), tracked by instance_id; categories from the ontology.
#ifndef POINTFORWARD_ENGINE_IMPORTERS_DGP_IMPORTER_H_
#define POINTFORWARD_ENGINE_IMPORTERS_DGP_IMPORTER_H_

#include <cstdint>
#include <string>

#include "absl/status/statusor.h"
#include "engine/importers/clip_output.h"

namespace pf {

// Returns the scene JSON of `scene`: `scene` itself if it is a file, else
// the one scene_*.json inside the directory. NOT_FOUND when there is none,
// INVALID_ARGUMENT naming them when there are several.
absl::StatusOr<std::string> FindDgpSceneJson(const std::string& scene);

// Parses a DGP timestamp ("2464-11-12T01:04:09.936530Z") to microseconds
// since the Unix epoch; INVALID_ARGUMENT naming `field` otherwise.
absl::StatusOr<int64_t> ParseDgpTimestamp(const std::string& text, const std::string& field);

// Imports the scene at `scene` (directory or scene JSON) into
// `options.out_dir` and writes the manifest. Errors: NOT_FOUND for a missing
// scene or a file the scene references (named, with the datum); INVALID_ARGUMENT
// for malformed JSON or fields (named), an unknown camera in options.cameras
// (listing those the scene has), a JPEG whose size differs from its datum,
// or no frames in the time window; UNIMPLEMENTED for values we do not
// support (non-zero skew, a point format other than X, Y, Z[, INTENSITY],
// calibration changing within the scene).
absl::StatusOr<ImportResult> ImportDgp(const std::string& scene, const ImportOptions& options);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_IMPORTERS_DGP_IMPORTER_H_
