// RenderViews JSON: parsing and checking against the scene.
#include "engine/render/views.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>
#include <set>

#include "absl/strings/str_cat.h"
#include "common/file_util.h"
#include "common/geometry.h"
#include "common/status_macros.h"
#include "engine/camera/camera_model.h"
#include "engine/clip/clip_io.h"
#include "engine/clip/clip_validator.h"
#include "pointforward/v1/views.pb.h"

namespace pf {
namespace {

namespace v1 = pointforward::v1;

// Largest RigidityError accepted for a pose (float-precision inputs pass).
constexpr double kRigidTolerance = 1e-4;

absl::Status Invalid(const std::string& field, absl::string_view problem) {
  return absl::InvalidArgumentError(absl::StrCat(field, ": ", problem));
}

bool IsFileNameChar(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.';
}

// A view name becomes a file stem: no separators, no leading dot, printable.
bool IsSafeFileStem(const std::string& name) {
  if (name.empty() || name.size() > 200 || name[0] == '.') return false;
  return std::all_of(name.begin(), name.end(), IsFileNameChar);
}

// Output file names taken so far, and their stems.
struct TakenNames {
  std::set<std::string> stems;
  std::set<std::string> files;
};

// Takes output file stem `name` and its files (the stem with each of
// `suffixes`): INVALID_ARGUMENT under `field` if it is not a usable file
// name, or the stem or one of its files is already taken.
absl::Status TakeOutputName(const std::string& name, const std::array<const char*, 2>& suffixes,
                            const std::string& field, TakenNames* taken) {
  if (!IsSafeFileStem(name)) {
    return Invalid(
        field,
        absl::StrCat("'", name, "' is not a usable file name (letters, digits, '_', '-', '.')"));
  }
  if (!taken->stems.insert(name).second) {
    return Invalid(field, absl::StrCat("duplicate output name '", name, "'"));
  }
  for (const char* suffix : suffixes) {
    const std::string file = name + suffix;
    if (!taken->files.insert(file).second) {
      return Invalid(field, absl::StrCat("output file '", file, "' is another view's or sweep's"));
    }
  }
  return absl::OkStatus();
}

// Returns the default name of a view, "<camera>_<timestamp_us>", with
// characters unfit for a file name replaced by '_'.
std::string DefaultViewName(const std::string& camera, int64_t timestamp_us) {
  std::string name = absl::StrCat(camera, "_", timestamp_us);
  for (char& c : name) {
    if (!IsFileNameChar(c)) c = '_';
  }
  if (name[0] == '.') name[0] = '_';
  return name;
}

absl::StatusOr<Rigid> PoseFromNumbers(const google::protobuf::RepeatedField<double>& numbers,
                                      const std::string& field) {
  if (numbers.size() != 16) {
    return Invalid(field,
                   absl::StrCat("expected 16 numbers (4x4 row-major), got ", numbers.size()));
  }
  for (double v : numbers) {
    if (!std::isfinite(v)) return Invalid(field, "non-finite number");
  }
  for (int i : {3, 7, 11}) {
    if (const std::string problem = WorldCoordinateProblem(numbers[i]); !problem.empty()) {
      return Invalid(absl::StrCat(field, "[", i, "]"), problem);
    }
  }
  double det = 0;
  const double error = RigidityError(numbers.data(), &det);
  if (error > kRigidTolerance) {
    return Invalid(field, absl::StrCat("not a rigid transform (det ", det, ", error ", error, ")"));
  }
  Rigid pose = Rigid::FromRowMajor(numbers.data());
  pose.rotation = ToMatrix(FromMatrix(pose.rotation));  // Re-orthonormalise.
  return pose;
}

absl::StatusOr<TrackBox> BoxFromProto(const v1::Box& box, const std::string& field) {
  if (box.center_size() != 3) {
    return Invalid(field + ".center", absl::StrCat("expected 3 numbers, got ", box.center_size()));
  }
  if (box.rotation_size() != 4) {
    return Invalid(field + ".rotation",
                   absl::StrCat("expected 4 numbers (w, x, y, z), got ", box.rotation_size()));
  }
  TrackBox out;
  out.timestamp_us = box.timestamp_us();
  for (int i = 0; i < 3; ++i) {
    if (!std::isfinite(box.center(i))) return Invalid(field + ".center", "non-finite number");
    if (const std::string problem = WorldCoordinateProblem(box.center(i)); !problem.empty()) {
      return Invalid(absl::StrCat(field, ".center[", i, "]"), problem);
    }
    out.center[i] = box.center(i);
  }
  if (box.size_size() == 3) {
    for (int i = 0; i < 3; ++i) out.size[i] = box.size(i);
  }
  const Quat q{box.rotation(0), box.rotation(1), box.rotation(2), box.rotation(3)};
  const double norm = QuatNorm(q);
  if (!std::isfinite(norm) || norm < 1e-9)
    return Invalid(field + ".rotation", "zero or non-finite quaternion");
  out.rotation = QuatNormalized(q);
  return out;
}

std::string ModelName(const v1::Distortion& distortion) {
  switch (distortion.model()) {
    case v1::Distortion::OPENCV:
      return "opencv";
    case v1::Distortion::FISHEYE:
      return "fisheye";
    case v1::Distortion::FTHETA:
      return "ftheta";
    default:
      return "pinhole";
  }
}

std::vector<double> DistortionCoefficients(const v1::Distortion& d, const CameraModel& model) {
  switch (d.model()) {
    case v1::Distortion::FTHETA:
      return model.ftheta_pixels();
    case v1::Distortion::OPENCV:
      return {d.k1(), d.k2(), d.p1(), d.p2(), d.k3()};
    case v1::Distortion::FISHEYE:
      return {d.k1(), d.k2(), d.k3(), d.k4()};
    default:
      return {};
  }
}

}  // namespace

absl::StatusOr<RollingShutter> RollingShutterFromProto(const v1::RollingShutter& message,
                                                       const std::string& field) {
  RollingShutter out;
  switch (message.readout()) {
    case v1::RollingShutter::TOP_TO_BOTTOM:
      out.readout = RollingShutter::Readout::kTopToBottom;
      break;
    case v1::RollingShutter::BOTTOM_TO_TOP:
      out.readout = RollingShutter::Readout::kBottomToTop;
      break;
    case v1::RollingShutter::LEFT_TO_RIGHT:
      out.readout = RollingShutter::Readout::kLeftToRight;
      break;
    case v1::RollingShutter::RIGHT_TO_LEFT:
      out.readout = RollingShutter::Readout::kRightToLeft;
      break;
    default:
      return Invalid(field + ".readout",
                     "say which line is read first: TOP_TO_BOTTOM, BOTTOM_TO_TOP, LEFT_TO_RIGHT "
                     "or RIGHT_TO_LEFT");
  }
  if (message.readout_us() < 0) {
    return Invalid(field + ".readoutUs", absl::StrCat("must be >= 0, got ", message.readout_us()));
  }
  out.readout_us = message.readout_us();
  ASSIGN_OR_RETURN(out.world_from_camera_end,
                   PoseFromNumbers(message.world_from_camera_end(), field + ".worldFromCameraEnd"));
  return out;
}

std::string RenderViewName(const v1::View& view) {
  return view.name().empty() ? DefaultViewName(view.camera(), view.timestamp_us()) : view.name();
}

std::string RenderLidarName(const v1::LidarView& lidar) {
  return lidar.name().empty() ? absl::StrCat("lidar_", lidar.timestamp_us()) : lidar.name();
}

std::vector<std::string> InstanceIds(const GaussianScene& scene) {
  std::vector<std::string> ids;
  ids.reserve(scene.instances.size());
  for (const InstanceTrack& track : scene.instances) ids.push_back(track.id);
  return ids;
}

absl::StatusOr<RenderRequest> ParseRenderViews(const std::string& json,
                                               const GaussianScene& scene) {
  v1::RenderViews message;
  if (const absl::Status parsed = ParseJsonMessage(json, &message); !parsed.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("not a RenderViews JSON: ", std::string(parsed.message())));
  }
  return RenderRequestFromProto(message, InstanceIds(scene));
}

absl::StatusOr<RenderRequest> RenderRequestFromProto(
    const v1::RenderViews& message, const std::optional<std::vector<std::string>>& instances) {
  // Cameras by id.
  std::map<std::string, int> camera_index;
  std::vector<CameraModel> models;
  for (int i = 0; i < message.cameras_size(); ++i) {
    const v1::Camera& camera = message.cameras(i);
    const std::string field = absl::StrCat("cameras[", i, "]");
    if (camera.id().empty()) return Invalid(field + ".id", "empty");
    if (!camera_index.emplace(camera.id(), i).second) {
      return Invalid(field + ".id", absl::StrCat("duplicate camera id '", camera.id(), "'"));
    }
    absl::StatusOr<CameraModel> model = CameraModelFromProto(camera);
    if (!model.ok()) return StatusWithContext(model.status(), field);
    models.push_back(*std::move(model));
  }

  RenderRequest request;
  if (message.views_size() == 0 && message.lidars_size() == 0) {
    return Invalid("views", "no views or lidars to render");
  }
  TakenNames names;
  for (int i = 0; i < message.views_size(); ++i) {
    const v1::View& view = message.views(i);
    const std::string field = absl::StrCat("views[", i, "]");
    const auto camera = camera_index.find(view.camera());
    if (camera == camera_index.end()) {
      return Invalid(field + ".camera", absl::StrCat("unknown camera '", view.camera(), "'"));
    }
    RenderView out;
    out.camera_id = view.camera();
    out.timestamp_us = view.timestamp_us();
    out.camera.model = models[camera->second];
    ASSIGN_OR_RETURN(out.camera.world_from_camera,
                     PoseFromNumbers(view.world_from_camera(), field + ".worldFromCamera"));
    const v1::Distortion& distortion = message.cameras(camera->second).distortion();
    out.camera_model = ModelName(distortion);
    out.distortion = DistortionCoefficients(distortion, out.camera.model);
    if (view.has_rolling_shutter()) {
      ASSIGN_OR_RETURN(out.camera.rolling_shutter,
                       RollingShutterFromProto(view.rolling_shutter(), field + ".rollingShutter"));
    }
    out.name = RenderViewName(view);
    RETURN_IF_ERROR(TakeOutputName(out.name, kViewFileSuffixes, field + ".name", &names));
    request.views.push_back(std::move(out));
  }

  for (int i = 0; i < message.lidars_size(); ++i) {
    const v1::LidarView& lidar = message.lidars(i);
    const std::string field = absl::StrCat("lidars[", i, "]");
    LidarRenderView out;
    out.name = RenderLidarName(lidar);
    RETURN_IF_ERROR(TakeOutputName(out.name, kLidarFileSuffixes, field + ".name", &names));
    const v1::LidarSpec& spec = lidar.spec();
    out.spec.beam_elevations_deg.assign(spec.beam_elevations_deg().begin(),
                                        spec.beam_elevations_deg().end());
    if (spec.azimuth_resolution_deg() != 0) {
      out.spec.azimuth_resolution_deg = spec.azimuth_resolution_deg();
    }
    if (spec.rotation_hz() != 0) out.spec.rotation_hz = spec.rotation_hz();
    if (spec.max_range_m() != 0) out.spec.max_range_m = spec.max_range_m();
    RETURN_IF_ERROR(CheckLidarSpec(out.spec, field + ".spec"));
    ASSIGN_OR_RETURN(out.pose.world_from_sensor_start,
                     PoseFromNumbers(lidar.world_from_sensor(), field + ".worldFromSensor"));
    out.pose.world_from_sensor_end = out.pose.world_from_sensor_start;
    if (lidar.world_from_sensor_end_size() > 0) {
      ASSIGN_OR_RETURN(
          out.pose.world_from_sensor_end,
          PoseFromNumbers(lidar.world_from_sensor_end(), field + ".worldFromSensorEnd"));
    }
    out.pose.start_us = lidar.timestamp_us();
    out.pose.end_us =
        lidar.timestamp_us() + static_cast<int64_t>(std::llround(1e6 / out.spec.rotation_hz));
    request.lidars.push_back(std::move(out));
  }

  std::set<std::string> edited;
  for (int i = 0; i < message.edits_size(); ++i) {
    const v1::ActorEdit& edit = message.edits(i);
    const std::string field = absl::StrCat("edits[", i, "]");
    const bool known = !instances.has_value() || std::find(instances->begin(), instances->end(),
                                                           edit.instance()) != instances->end();
    if (!known) {
      return Invalid(field + ".instance", absl::StrCat("unknown instance '", edit.instance(), "'"));
    }
    if (!edited.insert(edit.instance()).second) {
      return Invalid(field + ".instance",
                     absl::StrCat("instance '", edit.instance(), "' is edited twice"));
    }
    ActorEdit out;
    out.instance_id = edit.instance();
    switch (edit.kind()) {
      case v1::ActorEdit::REMOVE:
        out.kind = ActorEdit::Kind::kRemove;
        break;
      case v1::ActorEdit::TRAJECTORY: {
        out.kind = ActorEdit::Kind::kTrajectory;
        if (edit.boxes_size() == 0) return Invalid(field + ".boxes", "TRAJECTORY needs boxes");
        for (int j = 0; j < edit.boxes_size(); ++j) {
          ASSIGN_OR_RETURN(TrackBox box,
                           BoxFromProto(edit.boxes(j), absl::StrCat(field, ".boxes[", j, "]")));
          out.boxes.push_back(box);
        }
        std::stable_sort(
            out.boxes.begin(), out.boxes.end(),
            [](const TrackBox& a, const TrackBox& b) { return a.timestamp_us < b.timestamp_us; });
        for (size_t j = 1; j < out.boxes.size(); ++j) {
          if (out.boxes[j].timestamp_us == out.boxes[j - 1].timestamp_us) {
            return Invalid(field + ".boxes",
                           absl::StrCat("two boxes at timestampUs ", out.boxes[j].timestamp_us));
          }
        }
        break;
      }
      default:
        return Invalid(field + ".kind", "must be REMOVE or TRAJECTORY");
    }
    request.edits.push_back(std::move(out));
  }
  return request;
}

absl::StatusOr<RenderRequest> LoadRenderViews(const std::string& path, const GaussianScene& scene) {
  ASSIGN_OR_RETURN(std::string json, ReadFileToString(path));
  absl::StatusOr<RenderRequest> request = ParseRenderViews(json, scene);
  if (!request.ok()) return StatusWithContext(request.status(), path);
  return request;
}

}  // namespace pf
