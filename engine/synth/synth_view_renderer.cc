// `pf synth render` (see synth_view_renderer.h).
#include "engine/synth/synth_view_renderer.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "absl/strings/str_cat.h"
#include "common/bounded_json.h"
#include "common/file_util.h"
#include "common/status_macros.h"
#include "engine/image/image_io.h"
#include "engine/synth/synth_params.h"
#include "spdlog/spdlog.h"

namespace pf {
namespace {

namespace v1 = pointforward::v1;

constexpr double kRigidTolerance = 1e-4;
constexpr double kUnitQuatTolerance = 1e-3;
constexpr int kMaxImageSide = 16384;

absl::Status Invalid(const std::string& field, const std::string& problem) {
  return absl::InvalidArgumentError(absl::StrCat(field, ": ", problem));
}

bool AllFinite(const google::protobuf::RepeatedField<double>& values) {
  return std::all_of(values.begin(), values.end(), [](double v) { return std::isfinite(v); });
}

// Checks a 16-number rigid pose and returns it.
absl::StatusOr<Rigid> CheckPose(const google::protobuf::RepeatedField<double>& values,
                                const std::string& field) {
  if (values.size() != 16) {
    return Invalid(field, absl::StrCat("expected 16 numbers, got ", values.size()));
  }
  if (!AllFinite(values)) return Invalid(field, "non-finite number");
  double det = 0;
  if (RigidityError(values.data(), &det) > kRigidTolerance) {
    return Invalid(field, absl::StrCat("not a rigid transform (det = ", det, ")"));
  }
  return Rigid::FromRowMajor(values.data());
}

// Checks a replacement track and returns it sorted by time.
absl::StatusOr<std::vector<TrackPose>> CheckTrack(const v1::ActorEdit& edit,
                                                  const std::string& field) {
  if (edit.boxes().empty()) {
    return Invalid(absl::StrCat(field, ".boxes"), "TRAJECTORY needs at least one box");
  }
  std::vector<TrackPose> track;
  for (int j = 0; j < edit.boxes_size(); ++j) {
    const v1::Box& box = edit.boxes(j);
    const std::string where = absl::StrCat(field, ".boxes[", j, "]");
    if (box.center_size() != 3 || !AllFinite(box.center())) {
      return Invalid(where + ".center", "expected 3 finite numbers");
    }
    if (box.rotation_size() != 4 || !AllFinite(box.rotation())) {
      return Invalid(where + ".rotation", "expected 4 finite numbers (w, x, y, z)");
    }
    const Quat q{box.rotation(0), box.rotation(1), box.rotation(2), box.rotation(3)};
    if (std::abs(QuatNorm(q) - 1.0) > kUnitQuatTolerance) {
      return Invalid(where + ".rotation",
                     absl::StrCat("not a unit quaternion (norm = ", QuatNorm(q), ")"));
    }
    track.push_back({box.timestamp_us() * 1e-6, {box.center(0), box.center(1), box.center(2)}, q});
  }
  std::stable_sort(track.begin(), track.end(),
                   [](const TrackPose& a, const TrackPose& b) { return a.time_s < b.time_s; });
  return track;
}

}  // namespace

absl::StatusOr<v1::RenderViews> ParseRenderViews(const std::string& json,
                                                 const std::string& where) {
  v1::RenderViews request;
  if (const absl::Status parsed = ParseBoundedProtoJson(json, &request); !parsed.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": not a RenderViews message: ", parsed.message()));
  }
  return request;
}

absl::StatusOr<ResolvedViews> ResolveViews(const v1::RenderViews& request,
                                           const SynthScene& scene) {
  // Cameras of the request, then the clip's own.
  std::map<std::string, CameraModel> cameras;
  for (int i = 0; i < request.cameras_size(); ++i) {
    const v1::Camera& camera = request.cameras(i);
    const std::string field = absl::StrCat("cameras[", i, "]");
    if (camera.id().empty()) return Invalid(field + ".id", "missing");
    if (cameras.count(camera.id()) > 0) {
      return Invalid(field + ".id", absl::StrCat("duplicate camera '", camera.id(), "'"));
    }
    if (camera.width() > kMaxImageSide || camera.height() > kMaxImageSide) {
      return Invalid(field, absl::StrCat("image size ", camera.width(), "x", camera.height(),
                                         " exceeds ", kMaxImageSide, " pixels a side"));
    }
    auto model = CameraModelFromProto(camera);
    if (!model.ok()) return StatusWithContext(model.status(), field);
    cameras[camera.id()] = *model;
  }
  for (const RigCamera& camera : scene.cameras) cameras.emplace(camera.id, camera.model);

  ResolvedViews resolved;
  if (request.views().empty()) return Invalid("views", "no views to render");
  std::set<std::string> names;
  for (int i = 0; i < request.views_size(); ++i) {
    const v1::View& view = request.views(i);
    const std::string field = absl::StrCat("views[", i, "]");
    if (view.camera().empty()) return Invalid(field + ".camera", "missing");
    const auto camera = cameras.find(view.camera());
    if (camera == cameras.end()) {
      return Invalid(field + ".camera", absl::StrCat("unknown camera '", view.camera(), "'"));
    }
    ASSIGN_OR_RETURN(Rigid pose, CheckPose(view.world_from_camera(), field + ".worldFromCamera"));
    const std::string name =
        view.name().empty() ? absl::StrCat(view.camera(), "_", view.timestamp_us()) : view.name();
    if (name.find('/') != std::string::npos || name == "." || name == "..") {
      return Invalid(field + ".name", absl::StrCat("'", name, "' is not a plain file name"));
    }
    if (!names.insert(name).second) {
      return Invalid(field + ".name", absl::StrCat("duplicate output name '", name, "'"));
    }
    ResolvedView out{name, camera->second, pose, view.timestamp_us() * 1e-6, std::nullopt};
    if (view.has_rolling_shutter()) {
      const v1::RollingShutter& shutter = view.rolling_shutter();
      const std::string shutter_field = field + ".rollingShutter";
      if (shutter.readout() == v1::RollingShutter::READOUT_UNSPECIFIED) {
        return Invalid(shutter_field + ".readout", "say which line is read first");
      }
      if (shutter.readout_us() < 0) {
        return Invalid(shutter_field + ".readoutUs",
                       absl::StrCat("must be >= 0, got ", shutter.readout_us()));
      }
      if (out.camera.has_distortion()) {
        return Invalid(shutter_field,
                       "pf synth render reads a rolling shutter from pinhole "
                       "cameras only");
      }
      ASSIGN_OR_RETURN(Rigid end, CheckPose(shutter.world_from_camera_end(),
                                            shutter_field + ".worldFromCameraEnd"));
      out.rolling_shutter = SynthReadout{shutter.readout(), shutter.readout_us() * 1e-6, end};
    }
    resolved.views.push_back(std::move(out));
  }

  for (int i = 0; i < request.edits_size(); ++i) {
    const v1::ActorEdit& edit = request.edits(i);
    const std::string field = absl::StrCat("edits[", i, "]");
    const auto vehicle = std::find_if(scene.vehicles.begin(), scene.vehicles.end(),
                                      [&](const Vehicle& v) { return v.id == edit.instance(); });
    if (vehicle == scene.vehicles.end()) {
      return Invalid(field + ".instance", absl::StrCat("unknown instance '", edit.instance(), "'"));
    }
    switch (edit.kind()) {
      case v1::ActorEdit::REMOVE:
        resolved.edits.removed.insert(vehicle->instance_id);
        break;
      case v1::ActorEdit::TRAJECTORY: {
        ASSIGN_OR_RETURN(resolved.edits.trajectories[vehicle->instance_id],
                         CheckTrack(edit, field));
        break;
      }
      default:
        return Invalid(field + ".kind", "must be REMOVE or TRAJECTORY");
    }
  }
  return resolved;
}

namespace {

// Renders a rolling-shutter view line by line: each line a one-line pinhole
// camera (the principal point moved) at the line's pose and time.
RenderedView RenderRollingShutterView(const SynthScene& scene, const VehicleEdits& edits,
                                      const ResolvedView& view, int antialias) {
  const CameraModel& camera = view.camera;
  const SynthReadout& shutter = *view.rolling_shutter;
  const bool rows = shutter.readout == v1::RollingShutter::TOP_TO_BOTTOM ||
                    shutter.readout == v1::RollingShutter::BOTTOM_TO_TOP;
  const bool reversed = shutter.readout == v1::RollingShutter::BOTTOM_TO_TOP ||
                        shutter.readout == v1::RollingShutter::RIGHT_TO_LEFT;
  const int width = camera.width(), height = camera.height();
  const int lines = rows ? height : width;
  RenderedView out;
  out.rgb = ImageF(width, height, 3);
  out.depth = ImageF(width, height, 1);
  out.instance.assign(static_cast<size_t>(width) * height, 0);
  for (int line = 0; line < lines; ++line) {
    const int read = reversed ? lines - 1 - line : line;  // Order of reading.
    const double f = lines > 1 ? static_cast<double>(read) / (lines - 1) : 0;
    const Rigid pose = InterpolateRigid(view.world_from_camera, shutter.world_from_camera_end, f);
    const CameraModel strip =
        rows ? CameraModel(width, 1, camera.fx(), camera.fy(), camera.cx(), camera.cy() - line)
             : CameraModel(1, height, camera.fx(), camera.fy(), camera.cx() - line, camera.cy());
    const RenderedView part = RenderView(
        SnapshotAt(scene, view.time_s + f * shutter.readout_s, edits), strip, pose, antialias);
    const int count = rows ? width : height;
    for (int k = 0; k < count; ++k) {
      const int x = rows ? k : line, y = rows ? line : k;
      const size_t to = static_cast<size_t>(y) * width + x;
      for (int c = 0; c < 3; ++c) out.rgb.pixels[3 * to + c] = part.rgb.pixels[3 * k + c];
      out.depth.pixels[to] = part.depth.pixels[k];
      out.instance[to] = part.instance[k];
    }
  }
  return out;
}

}  // namespace

absl::StatusOr<std::vector<std::string>> RenderSynthViews(const std::string& clip_dir,
                                                          const std::string& views_path,
                                                          const std::string& out_dir) {
  const std::string params_path = absl::StrCat(clip_dir, "/synth.json");
  auto options = ReadSynthParams(params_path);
  if (!options.ok()) {
    if (absl::IsNotFound(options.status())) {
      return absl::NotFoundError(
          absl::StrCat(params_path, ": not found (is ", clip_dir, " a clip written by pf synth?)"));
    }
    return options.status();
  }
  ASSIGN_OR_RETURN(SynthScene scene, GenerateSynthScene(*options));
  ASSIGN_OR_RETURN(std::string json, ReadFileToString(views_path));
  ASSIGN_OR_RETURN(v1::RenderViews request, ParseRenderViews(json, views_path));
  auto resolved = ResolveViews(request, scene);
  if (!resolved.ok()) return StatusWithContext(resolved.status(), views_path);
  RETURN_IF_ERROR(MakeDirs(out_dir));

  std::vector<std::string> names;
  for (size_t i = 0; i < resolved->views.size(); ++i) {
    const ResolvedView& view = resolved->views[i];
    const RenderedView image =
        view.rolling_shutter.has_value()
            ? RenderRollingShutterView(scene, resolved->edits, view, options->antialias)
            : RenderView(SnapshotAt(scene, view.time_s, resolved->edits), view.camera,
                         view.world_from_camera, options->antialias);
    RETURN_IF_ERROR(WritePng(absl::StrCat(out_dir, "/", view.name, ".png"), image.rgb));
    RETURN_IF_ERROR(WriteDepthExr(absl::StrCat(out_dir, "/", view.name, ".exr"), image.depth));
    spdlog::info("synth render: view {}/{} '{}' done", i + 1, resolved->views.size(), view.name);
    names.push_back(view.name);
  }
  return names;
}

}  // namespace pf
