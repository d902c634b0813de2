// `pf import waymo`: a Waymo Open Dataset segment (a TFRecord of `Frame`
// protos) to a clip directory.
//
// Conventions (docs/IMPORTERS.md has the reasoning):
// - Waymo's camera frame is x forward, y left, z up; ours is OpenCV (x right,
//   y down, z forward). worldFromCamera = world_from_vehicle (the image's own
//   pose when present, else the frame's) * extrinsic (vehicle_from_camera) *
//   kOpenCvToWaymoCamera.
// - Intrinsic vector f_u, f_v, c_u, c_v, k1, k2, p1, p2, k3 maps to fx, fy,
//   cx, cy and OPENCV distortion (k1, k2, p1, p2, k3) unchanged: Waymo's pixel
//   coordinates already put the image's left edge at 0, as ours do.
// - Frame timestamps: the image's pose_timestamp (seconds) in microseconds,
//   else the frame's timestamp_micros. Boxes: laser_labels at the frame's
//   timestamp_micros, vehicle frame converted to world by the frame pose,
//   heading as a rotation about z; tracks keyed by the label's string id.
// - JPEGs are written as they are (no re-encode) to images/CAMERA_TIMESTAMP.jpg.
// - LiDAR: the first returns of every laser's compressed range image
//   (waymo_lidar.h), one sweep per frame in lidar/LIDAR_TIMESTAMP.bin, in the
//   vehicle frame (worldFromSensor = the frame pose). Frames with only the
//   deprecated uncompressed range images add a warning to the result.
#ifndef POINTFORWARD_ENGINE_IMPORTERS_WAYMO_IMPORTER_H_
#define POINTFORWARD_ENGINE_IMPORTERS_WAYMO_IMPORTER_H_

#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "common/geometry.h"
#include "engine/importers/clip_output.h"
#include "pointforward/v1/clip.pb.h"
#include "waymo/frame.pb.h"

namespace pf {

// Maps OpenCV camera axes to Waymo camera axes: p_waymo = R * p_opencv.
Mat3 OpenCvToWaymoCamera();

// Returns 16 row-major numbers of a Waymo Transform as a Rigid;
// INVALID_ARGUMENT naming `field` when there are not 16 or they are not rigid.
absl::StatusOr<Rigid> RigidFromWaymoTransform(const pointforward::waymo::Transform& transform,
                                              const std::string& field);

// Builds our camera (id = the Waymo camera name) from a calibration;
// INVALID_ARGUMENT naming the field for a wrong intrinsic count or size.
absl::StatusOr<pointforward::v1::Camera> CameraFromWaymoCalibration(
    const pointforward::waymo::CameraCalibration& calibration);

// Returns world_from_camera (OpenCV axes) for `image` of `frame` taken by
// the camera of `calibration`.
absl::StatusOr<Rigid> WaymoWorldFromCamera(
    const pointforward::waymo::Frame& frame, const pointforward::waymo::CameraImage& image,
    const pointforward::waymo::CameraCalibration& calibration);

// A camera image as a clip frame: its time, pose and (for a rolling-shutter
// camera) readout.
struct WaymoFramePose {
  int64_t timestamp_us = 0;  // Of the first line read, with a rolling shutter.
  Rigid world_from_camera;   // At timestamp_us (OpenCV axes).
  // Set for a camera whose calibration names a readout direction, on an image
  // with a velocity and trigger and readout-done times: the first line is
  // read at the middle of its exposure (trigger + shutter / 2), the last at
  // readout done - shutter / 2; the poses at those times are the image's
  // pose extrapolated with its velocity (r + v dt, exp(W dt) R).
  std::optional<pointforward::v1::RollingShutter> rolling_shutter;
};

// The frame `image` of `frame` gives (WaymoWorldFromCamera at the image's
// pose_timestamp for a global shutter); errors as WaymoWorldFromCamera.
absl::StatusOr<WaymoFramePose> WaymoFramePoseOf(
    const pointforward::waymo::Frame& frame, const pointforward::waymo::CameraImage& image,
    const pointforward::waymo::CameraCalibration& calibration);

// Imports `segment_path` into `options.out_dir` and writes the manifest.
// Errors: NOT_FOUND for a missing file; DATA_LOSS for a truncated or corrupt
// record (with its index and byte offset) or a record that is not a Frame;
// INVALID_ARGUMENT for an unknown camera in options.cameras (listing those
// the segment has), malformed calibration or poses, a JPEG whose size differs
// from its calibration, or no frames in the time window.
absl::StatusOr<ImportResult> ImportWaymo(const std::string& segment_path,
                                         const ImportOptions& options);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_IMPORTERS_WAYMO_IMPORTER_H_
