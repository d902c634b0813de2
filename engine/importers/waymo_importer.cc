// Waymo segment -> clip: stream frames, write JPEGs, convert calibration,
// poses and label boxes.
#include "engine/importers/waymo_importer.h"

#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "common/file_util.h"
#include "common/status_macros.h"
#include "engine/importers/jpeg_header.h"
#include "engine/importers/tfrecord_reader.h"
#include "engine/importers/waymo_lidar.h"

namespace pf {
namespace {

namespace waymo = pointforward::waymo;
namespace v1 = pointforward::v1;

constexpr double kRigidTolerance = 1e-4;

std::string CameraNameText(int name) {
  if (waymo::CameraName::Name_IsValid(name)) {
    return waymo::CameraName::Name_Name(static_cast<waymo::CameraName::Name>(name));
  }
  return absl::StrCat("camera#", name);
}

std::string LabelCategory(waymo::Label::Type type) {
  switch (type) {
    case waymo::Label::TYPE_VEHICLE:
      return "vehicle";
    case waymo::Label::TYPE_PEDESTRIAN:
      return "pedestrian";
    case waymo::Label::TYPE_SIGN:
      return "sign";
    case waymo::Label::TYPE_CYCLIST:
      return "cyclist";
    default:
      return "unknown";
  }
}

// True if a laser of `frame` carries only the deprecated uncompressed range
// image, which we do not read.
bool HasUncompressedRangeImages(const waymo::Frame& frame) {
  for (const waymo::Laser& laser : frame.lasers()) {
    if (laser.ri_return1().range_image_compressed().empty() &&
        laser.ri_return1().range_image().data_size() > 0) {
      return true;
    }
  }
  return false;
}

// State carried across frames while streaming a segment.
class WaymoImport {
 public:
  WaymoImport(std::string segment, const ImportOptions& options)
      : segment_(std::move(segment)), options_(options) {}

  // Reads the cameras of the first frame and checks options.cameras.
  absl::Status SetUpCameras(const waymo::Frame& frame);
  // Adds one frame's images and boxes (when inside the time window).
  absl::Status AddFrame(const waymo::Frame& frame, int64_t record_index);
  absl::StatusOr<ImportResult> Finish();

 private:
  absl::Status AddBoxes(const waymo::Frame& frame, const std::string& where);
  absl::Status AddLidar(const waymo::Frame& frame, const std::string& where);

  std::string segment_;
  const ImportOptions& options_;
  std::optional<int64_t> t0_;
  std::map<int, waymo::CameraCalibration> calibrations_;  // By camera name, selected only.
  std::map<int, v1::Camera> cameras_;                     // The same, converted.
  std::set<int> cameras_with_frames_;
  std::map<std::string, v1::Instance> instances_;  // By label id.
  int uncompressed_lidar_frames_ = 0;
  v1::Clip clip_;
};

absl::Status WaymoImport::SetUpCameras(const waymo::Frame& frame) {
  clip_.set_name(frame.context().name());
  std::map<std::string, const waymo::CameraCalibration*> by_name;
  for (const auto& calibration : frame.context().camera_calibrations()) {
    by_name[CameraNameText(calibration.name())] = &calibration;
  }
  if (by_name.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat(segment_, ": the first frame has no context.camera_calibrations"));
  }
  std::vector<std::string> have;
  for (const auto& [name, unused] : by_name) have.push_back(name);
  std::vector<std::string> wanted = options_.cameras.empty() ? have : options_.cameras;
  for (const std::string& name : wanted) {
    const auto it = by_name.find(name);
    if (it == by_name.end()) {
      return absl::InvalidArgumentError(absl::StrCat("--cameras ", name,
                                                     ": no such camera in the segment (have ",
                                                     absl::StrJoin(have, ", "), ")"));
    }
    // Converted now, so a bad calibration fails before any file is written.
    ASSIGN_OR_RETURN(cameras_[it->second->name()], CameraFromWaymoCalibration(*it->second));
    calibrations_[it->second->name()] = *it->second;
  }
  return absl::OkStatus();
}

absl::Status WaymoImport::AddFrame(const waymo::Frame& frame, int64_t record_index) {
  const std::string where = absl::StrCat(segment_, ": frame ", record_index);
  if (!frame.has_timestamp_micros()) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": timestamp_micros is missing"));
  }
  if (!t0_) {
    t0_ = frame.timestamp_micros();
    RETURN_IF_ERROR(SetUpCameras(frame));
  }
  if (!InTimeWindow(options_, *t0_, frame.timestamp_micros())) return absl::OkStatus();
  if (HasUncompressedRangeImages(frame)) ++uncompressed_lidar_frames_;
  RETURN_IF_ERROR(AddLidar(frame, where));

  for (const waymo::CameraImage& image : frame.images()) {
    const auto cal = calibrations_.find(image.name());
    if (cal == calibrations_.end()) continue;  // Not selected.
    const std::string camera = CameraNameText(image.name());
    const std::string image_where = absl::StrCat(where, ": images[", camera, "]");
    ASSIGN_OR_RETURN(JpegSize size, ReadJpegSize(image.image(), image_where));
    if (size.width != cal->second.width() || size.height != cal->second.height()) {
      return absl::InvalidArgumentError(absl::StrCat(
          image_where, ": JPEG is ", size.width, "x", size.height, " but the calibration says ",
          cal->second.width(), "x", cal->second.height()));
    }
    ASSIGN_OR_RETURN(WaymoFramePose pose, WaymoFramePoseOf(frame, image, cal->second));
    const int64_t timestamp = pose.timestamp_us;
    const std::string relative = absl::StrCat("images/", camera, "_", timestamp, ".jpg");
    RETURN_IF_ERROR(WriteFileAtomic((std::filesystem::path(options_.out_dir) / relative).string(),
                                    image.image()));
    v1::Frame* out = clip_.add_frames();
    out->set_camera(camera);
    out->set_timestamp_us(timestamp);
    out->set_image(relative);
    SetRowMajor(pose.world_from_camera, out->mutable_world_from_camera());
    if (pose.rolling_shutter.has_value()) *out->mutable_rolling_shutter() = *pose.rolling_shutter;
    cameras_with_frames_.insert(image.name());
  }
  return AddBoxes(frame, where);
}

absl::Status WaymoImport::AddBoxes(const waymo::Frame& frame, const std::string& where) {
  if (frame.laser_labels().empty()) return absl::OkStatus();
  ASSIGN_OR_RETURN(Rigid world_from_vehicle,
                   RigidFromWaymoTransform(frame.pose(), absl::StrCat(where, ": pose")));
  for (int i = 0; i < frame.laser_labels_size(); ++i) {
    const waymo::Label& label = frame.laser_labels(i);
    const waymo::Label::Box& b = label.box();
    const std::string label_where = absl::StrCat(where, ": laser_labels[", i, "]");
    if (label.id().empty()) {
      return absl::InvalidArgumentError(absl::StrCat(label_where, ": id is empty"));
    }
    if (!(b.length() > 0 && b.width() > 0 && b.height() > 0)) {
      return absl::InvalidArgumentError(
          absl::StrCat(label_where, ".box: length, width and height must be positive (got ",
                       b.length(), ", ", b.width(), ", ", b.height(), ")"));
    }
    v1::Instance& instance = instances_[label.id()];
    instance.set_id(label.id());
    instance.set_category(LabelCategory(label.type()));
    const Rigid vehicle_from_box{RotationZ(b.heading()),
                                 {b.center_x(), b.center_y(), b.center_z()}};
    AddBox(frame.timestamp_micros(), world_from_vehicle * vehicle_from_box,
           {b.length(), b.width(), b.height()}, &instance);
  }
  return absl::OkStatus();
}

absl::Status WaymoImport::AddLidar(const waymo::Frame& frame, const std::string& where) {
  if (!HasWaymoRangeImages(frame)) return absl::OkStatus();
  ASSIGN_OR_RETURN(Rigid world_from_vehicle,
                   RigidFromWaymoTransform(frame.pose(), absl::StrCat(where, ": pose")));
  absl::StatusOr<std::vector<float>> points = WaymoRangeImagesToPoints(frame, world_from_vehicle);
  if (!points.ok()) {
    return absl::Status(points.status().code(),
                        absl::StrCat(where, ": ", std::string(points.status().message())));
  }
  // One sweep per frame: every laser's first returns in the vehicle frame.
  return AddLidarSweep(*points, options_.out_dir,
                       absl::StrCat("lidar/LIDAR_", frame.timestamp_micros(), ".bin"),
                       frame.timestamp_micros(), world_from_vehicle, &clip_);
}

absl::StatusOr<ImportResult> WaymoImport::Finish() {
  if (clip_.frames().empty()) {
    return absl::InvalidArgumentError(absl::StrCat(
        segment_, ": no camera images in the selected time window (--start-us ", options_.start_us,
        ", --duration-us ",
        options_.duration_us ? absl::StrCat(*options_.duration_us) : "unbounded", ")"));
  }
  for (const auto& [name, camera] : cameras_) {
    if (cameras_with_frames_.count(name)) *clip_.add_cameras() = camera;
  }
  for (auto& [id, instance] : instances_) *clip_.add_instances() = std::move(instance);
  AssignRoles(options_.roles, &clip_);
  ImportResult result;
  if (uncompressed_lidar_frames_ > 0) {
    result.warnings.push_back(absl::StrCat(
        uncompressed_lidar_frames_,
        " frame(s) have only the deprecated uncompressed range_image field: their LiDAR "
        "returns are not imported yet (only range_image_compressed is read)"));
  }
  ASSIGN_OR_RETURN(result.manifest_path, WriteClipManifest(clip_, options_.out_dir));
  result.clip = std::move(clip_);
  return result;
}

}  // namespace

Mat3 OpenCvToWaymoCamera() {
  // Columns: OpenCV x (right) = Waymo -y, OpenCV y (down) = Waymo -z,
  // OpenCV z (forward) = Waymo x.
  Mat3 r;
  r.m = {{{0, 0, 1}, {-1, 0, 0}, {0, -1, 0}}};
  return r;
}

absl::StatusOr<Rigid> RigidFromWaymoTransform(const waymo::Transform& transform,
                                              const std::string& field) {
  if (transform.transform_size() != 16) {
    return absl::InvalidArgumentError(absl::StrCat(
        field, ": expected 16 numbers (4x4 row-major), got ", transform.transform_size()));
  }
  for (double v : transform.transform()) {
    if (!std::isfinite(v))
      return absl::InvalidArgumentError(absl::StrCat(field, ": non-finite number"));
  }
  double det = 0;
  const double error = RigidityError(transform.transform().data(), &det);
  if (error > kRigidTolerance) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": not a rigid transform (det = ", det, ", error ", error, ")"));
  }
  Rigid t = Rigid::FromRowMajor(transform.transform().data());
  t.rotation = ToMatrix(FromMatrix(t.rotation));  // Re-orthonormalise.
  return t;
}

absl::StatusOr<v1::Camera> CameraFromWaymoCalibration(const waymo::CameraCalibration& calibration) {
  const std::string name = CameraNameText(calibration.name());
  const std::string where = absl::StrCat("context.camera_calibrations[", name, "]");
  if (calibration.intrinsic_size() != 9) {
    return absl::InvalidArgumentError(absl::StrCat(
        where, ".intrinsic: expected 9 values (f_u, f_v, c_u, c_v, k1, k2, p1, p2, k3), got ",
        calibration.intrinsic_size()));
  }
  if (calibration.width() <= 0 || calibration.height() <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": width and height must be positive (got ", calibration.width(), "x",
                     calibration.height(), ")"));
  }
  const auto& k = calibration.intrinsic();
  for (double v : k) {
    if (!std::isfinite(v))
      return absl::InvalidArgumentError(absl::StrCat(where, ".intrinsic: non-finite value"));
  }
  if (k[0] <= 0 || k[1] <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ".intrinsic: f_u and f_v must be positive"));
  }
  v1::Camera camera;
  camera.set_id(name);
  camera.set_width(calibration.width());
  camera.set_height(calibration.height());
  camera.mutable_intrinsics()->set_fx(k[0]);
  camera.mutable_intrinsics()->set_fy(k[1]);
  camera.mutable_intrinsics()->set_cx(k[2]);
  camera.mutable_intrinsics()->set_cy(k[3]);
  v1::Distortion* d = camera.mutable_distortion();
  d->set_model(v1::Distortion::OPENCV);
  d->set_k1(k[4]);
  d->set_k2(k[5]);
  d->set_p1(k[6]);
  d->set_p2(k[7]);
  d->set_k3(k[8]);
  return camera;
}

absl::StatusOr<Rigid> WaymoWorldFromCamera(const waymo::Frame& frame,
                                           const waymo::CameraImage& image,
                                           const waymo::CameraCalibration& calibration) {
  const std::string name = CameraNameText(calibration.name());
  ASSIGN_OR_RETURN(
      Rigid vehicle_from_camera,
      RigidFromWaymoTransform(calibration.extrinsic(),
                              absl::StrCat("context.camera_calibrations[", name, "].extrinsic")));
  // Rolling-shutter cameras carry their own world_from_vehicle at the
  // image's pose_timestamp; fall back to the frame's pose.
  const bool has_image_pose = image.has_pose() && image.pose().transform_size() > 0;
  ASSIGN_OR_RETURN(Rigid world_from_vehicle,
                   has_image_pose ? RigidFromWaymoTransform(image.pose(),
                                                            absl::StrCat("images[", name, "].pose"))
                                  : RigidFromWaymoTransform(frame.pose(), "pose"));
  const Rigid waymo_from_opencv{OpenCvToWaymoCamera(), Vec3{}};
  return world_from_vehicle * vehicle_from_camera * waymo_from_opencv;
}

absl::StatusOr<WaymoFramePose> WaymoFramePoseOf(const waymo::Frame& frame,
                                                const waymo::CameraImage& image,
                                                const waymo::CameraCalibration& calibration) {
  ASSIGN_OR_RETURN(const Rigid world_from_camera, WaymoWorldFromCamera(frame, image, calibration));
  WaymoFramePose out;
  out.timestamp_us = image.pose_timestamp() > 0 ? std::llround(image.pose_timestamp() * 1e6)
                                                : frame.timestamp_micros();
  out.world_from_camera = world_from_camera;
  std::optional<v1::RollingShutter::Readout> readout;
  switch (calibration.rolling_shutter_direction()) {
    case waymo::CameraCalibration::TOP_TO_BOTTOM:
      readout = v1::RollingShutter::TOP_TO_BOTTOM;
      break;
    case waymo::CameraCalibration::BOTTOM_TO_TOP:
      readout = v1::RollingShutter::BOTTOM_TO_TOP;
      break;
    case waymo::CameraCalibration::LEFT_TO_RIGHT:
      readout = v1::RollingShutter::LEFT_TO_RIGHT;
      break;
    case waymo::CameraCalibration::RIGHT_TO_LEFT:
      readout = v1::RollingShutter::RIGHT_TO_LEFT;
      break;
    default:  // Unknown or a global shutter.
      break;
  }
  const bool has_image_pose = image.has_pose() && image.pose().transform_size() > 0;
  const double first = image.camera_trigger_time() + 0.5 * image.shutter();
  const double last = image.camera_readout_done_time() - 0.5 * image.shutter();
  if (!readout.has_value() || !has_image_pose || !image.has_velocity() ||
      !(image.pose_timestamp() > 0) || !(image.camera_trigger_time() > 0) || !(last >= first) ||
      !std::isfinite(first) || !std::isfinite(last) || last - first > 1.0) {
    return out;
  }
  // world_from_camera at time t: the vehicle moved on by its velocity.
  const waymo::Velocity& velocity = image.velocity();
  const Vec3 v{velocity.v_x(), velocity.v_y(), velocity.v_z()};
  const Vec3 w{velocity.w_x(), velocity.w_y(), velocity.w_z()};
  if (!std::isfinite(Norm(v)) || !std::isfinite(Norm(w))) return out;
  ASSIGN_OR_RETURN(const Rigid world_from_vehicle,
                   RigidFromWaymoTransform(image.pose(), "images.pose"));
  const Rigid vehicle_from_camera = world_from_vehicle.Inverse() * world_from_camera;
  auto at = [&](double t) {
    const double dt = t - image.pose_timestamp();
    const double angle = Norm(w) * dt;
    Rigid moved = world_from_vehicle;
    if (angle != 0) {
      const Vec3 axis = w / Norm(w);
      const double s = std::sin(0.5 * angle);
      moved.rotation = ToMatrix(Quat{std::cos(0.5 * angle), s * axis.x, s * axis.y, s * axis.z}) *
                       world_from_vehicle.rotation;
    }
    moved.translation = world_from_vehicle.translation + dt * v;
    return moved * vehicle_from_camera;
  };
  out.timestamp_us = std::llround(first * 1e6);
  out.world_from_camera = at(first);
  v1::RollingShutter& shutter = out.rolling_shutter.emplace();
  shutter.set_readout(*readout);
  shutter.set_readout_us(std::llround(last * 1e6) - out.timestamp_us);
  SetRowMajor(at(last), shutter.mutable_world_from_camera_end());
  return out;
}

absl::StatusOr<ImportResult> ImportWaymo(const std::string& segment_path,
                                         const ImportOptions& options) {
  ASSIGN_OR_RETURN(std::unique_ptr<TfRecordReader> reader, TfRecordReader::Open(segment_path));
  WaymoImport import(segment_path, options);
  std::string record;
  while (true) {
    const int64_t index = reader->record_index();
    const uint64_t offset = reader->offset();
    ASSIGN_OR_RETURN(bool more, reader->Next(&record));
    if (!more) break;
    waymo::Frame frame;
    if (!frame.ParseFromString(record)) {
      return absl::DataLossError(absl::StrCat(segment_path, ": record ", index, " at byte offset ",
                                              offset, ": not a Waymo Frame protobuf"));
    }
    RETURN_IF_ERROR(import.AddFrame(frame, index));
  }
  if (reader->record_index() == 0) {
    return absl::InvalidArgumentError(absl::StrCat(segment_path, ": holds no records"));
  }
  return import.Finish();
}

}  // namespace pf
