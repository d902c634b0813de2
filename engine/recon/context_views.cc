// Decoding a clip's frames and box tracks for reconstruction.
#include "engine/recon/context_views.h"

// The generated protobuf header first: OpenImageIO headers included before it
// break it (see image_io.h).
#include <algorithm>
#include <map>
#include <optional>
#include <set>

#include "absl/strings/str_cat.h"
#include "common/status_macros.h"
#include "engine/clip/clip_validator.h"
#include "engine/render/views.h"
#include "pointforward/v1/clip.pb.h"

namespace pf {
namespace {

using pointforward::v1::Clip;
using pointforward::v1::Frame;

bool IsSelected(const Frame& frame, FrameSelection selection) {
  const bool is_target = frame.role() == Frame::TARGET;
  return selection == FrameSelection::kTarget ? is_target : !is_target;
}

// The encoding a camera declares for its images; nullopt: by file format.
std::optional<ColourEncoding> DeclaredEncoding(const pointforward::v1::Camera& camera) {
  switch (camera.color_space()) {
    case pointforward::v1::Camera::SRGB:
      return ColourEncoding::kSrgb;
    case pointforward::v1::Camera::LINEAR:
      return ColourEncoding::kLinear;
    default:
      return std::nullopt;
  }
}

absl::Status CheckSize(const ImageF& image, const CameraModel& camera, const std::string& where) {
  if (image.width != camera.width() || image.height != camera.height()) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": image is ", image.width, "x",
                                                   image.height, ", camera is ", camera.width(),
                                                   "x", camera.height()));
  }
  return absl::OkStatus();
}

// Prefixes `status`'s message with `where` unless it already names it.
absl::Status WithField(const absl::Status& status, const std::string& where) {
  if (status.ok()) return status;
  return absl::Status(status.code(), absl::StrCat(where, ": ", std::string(status.message())));
}

}  // namespace

absl::StatusOr<std::vector<ContextView>> LoadFrames(const LoadedClip& loaded,
                                                    const std::vector<int>& frame_indices,
                                                    const LoadViewsOptions& options) {
  const Clip& clip = loaded.clip;
  std::set<std::string> cameras_used;
  for (int f : frame_indices) {
    if (f < 0 || f >= clip.frames_size()) {
      return absl::InvalidArgumentError(
          absl::StrCat("frames: no frame ", f, " (the clip has ", clip.frames_size(), ")"));
    }
    cameras_used.insert(clip.frames(f).camera());
  }
  std::map<std::string, CameraModel> cameras;
  std::map<std::string, std::optional<ColourEncoding>> encodings;
  std::map<std::string, std::vector<uint8_t>> ego_masks;
  for (int c = 0; c < clip.cameras_size(); ++c) {
    absl::StatusOr<CameraModel> model = CameraModelFromProto(clip.cameras(c));
    if (!model.ok()) return WithField(model.status(), absl::StrCat("cameras[", c, "]"));
    cameras[clip.cameras(c).id()] = *model;
    encodings[clip.cameras(c).id()] = DeclaredEncoding(clip.cameras(c));
    const std::string& mask_file = clip.cameras(c).ego_mask();
    if (mask_file.empty() || !cameras_used.contains(clip.cameras(c).id())) continue;
    const std::string where = absl::StrCat("cameras[", c, "].egoMask");
    absl::StatusOr<std::string> mask_path =
        ResolveClipPath(loaded, mask_file, options.allow_outside_paths);
    if (!mask_path.ok()) return WithField(mask_path.status(), where);
    absl::StatusOr<ImageF> mask = ReadImage(*mask_path);
    if (!mask.ok()) return WithField(mask.status(), where);
    RETURN_IF_ERROR(CheckSize(*mask, *model, where));
    ego_masks[clip.cameras(c).id()] = EgoMaskFromImage(*mask);
  }
  std::vector<ContextView> views;
  for (int f : frame_indices) {
    const Frame& frame = clip.frames(f);
    const std::string where = absl::StrCat("frames[", f, "]");
    auto camera = cameras.find(frame.camera());
    if (camera == cameras.end()) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, ".camera: unknown camera '", frame.camera(), "'"));
    }
    if (frame.world_from_camera_size() != 16) {
      return absl::InvalidArgumentError(absl::StrCat(where, ".worldFromCamera: has ",
                                                     frame.world_from_camera_size(),
                                                     " numbers, expected 16"));
    }
    ContextView view;
    view.frame_index = f;
    view.camera_id = frame.camera();
    view.camera = camera->second;
    view.world_from_camera = Rigid::FromRowMajor(frame.world_from_camera().data());
    view.timestamp_us = frame.timestamp_us();
    if (frame.has_rolling_shutter()) {
      ASSIGN_OR_RETURN(view.rolling_shutter,
                       RollingShutterFromProto(frame.rolling_shutter(), where + ".rollingShutter"));
    }
    if (auto mask = ego_masks.find(frame.camera()); mask != ego_masks.end()) {
      view.ego = mask->second;
    }

    absl::StatusOr<std::string> image_path =
        ResolveClipPath(loaded, frame.image(), options.allow_outside_paths);
    if (!image_path.ok()) return WithField(image_path.status(), where + ".image");
    absl::StatusOr<ImageF> rgb =
        ReadColourImage(*image_path, 3, encodings[frame.camera()], options.colour_encoding);
    if (!rgb.ok()) return WithField(rgb.status(), where + ".image");
    RETURN_IF_ERROR(CheckSize(*rgb, view.camera, where + ".image"));
    view.rgb = *std::move(rgb);

    if (options.read_depth && !frame.depth().empty()) {
      absl::StatusOr<std::string> depth_path =
          ResolveClipPath(loaded, frame.depth(), options.allow_outside_paths);
      if (!depth_path.ok()) return WithField(depth_path.status(), where + ".depth");
      absl::StatusOr<ImageF> depth = ReadDepth(*depth_path);
      if (!depth.ok()) return WithField(depth.status(), where + ".depth");
      RETURN_IF_ERROR(CheckSize(*depth, view.camera, where + ".depth"));
      view.depth = *std::move(depth);
    }
    views.push_back(std::move(view));
  }
  return views;
}

absl::StatusOr<std::vector<ContextView>> LoadViews(const LoadedClip& loaded,
                                                   FrameSelection selection,
                                                   const LoadViewsOptions& options) {
  std::vector<int> selected;
  for (int f = 0; f < loaded.clip.frames_size(); ++f) {
    if (IsSelected(loaded.clip.frames(f), selection)) selected.push_back(f);
  }
  return LoadFrames(loaded, selected, options);
}

absl::StatusOr<std::vector<ContextView>> LoadContextViews(const LoadedClip& loaded,
                                                          const LoadViewsOptions& options) {
  return LoadViews(loaded, FrameSelection::kContext, options);
}

absl::StatusOr<std::vector<InstanceTrack>> TracksFromClip(const Clip& clip) {
  std::vector<InstanceTrack> tracks;
  for (int i = 0; i < clip.instances_size(); ++i) {
    const auto& instance = clip.instances(i);
    InstanceTrack track;
    track.id = instance.id();
    track.category = instance.category();
    for (int b = 0; b < instance.boxes_size(); ++b) {
      const auto& box = instance.boxes(b);
      const std::string where = absl::StrCat("instances[", i, "].boxes[", b, "]");
      if (box.center_size() != 3 || box.size_size() != 3 || box.rotation_size() != 4) {
        return absl::InvalidArgumentError(
            absl::StrCat(where, ": needs 3 centre, 3 size and 4 rotation values, has ",
                         box.center_size(), ", ", box.size_size(), " and ", box.rotation_size()));
      }
      TrackBox tb;
      tb.timestamp_us = box.timestamp_us();
      tb.center = {box.center(0), box.center(1), box.center(2)};
      tb.size = {box.size(0), box.size(1), box.size(2)};
      const Quat q{box.rotation(0), box.rotation(1), box.rotation(2), box.rotation(3)};
      if (!(QuatNorm(q) > 1e-9)) {
        return absl::InvalidArgumentError(absl::StrCat(where, ".rotation: zero quaternion"));
      }
      tb.rotation = QuatNormalized(q);
      track.boxes.push_back(tb);
    }
    std::sort(track.boxes.begin(), track.boxes.end(),
              [](const TrackBox& a, const TrackBox& b) { return a.timestamp_us < b.timestamp_us; });
    for (size_t b = 1; b < track.boxes.size(); ++b) {
      if (track.boxes[b].timestamp_us == track.boxes[b - 1].timestamp_us) {
        return absl::InvalidArgumentError(
            absl::StrCat("instances[", i, "]: two boxes at ", track.boxes[b].timestamp_us, " us"));
      }
    }
    tracks.push_back(std::move(track));
  }
  return tracks;
}

int64_t ClipTimeOrigin(const Clip& clip) {
  if (clip.frames_size() == 0) return 0;
  int64_t origin = clip.frames(0).timestamp_us();
  for (const Frame& frame : clip.frames()) origin = std::min(origin, frame.timestamp_us());
  return origin;
}

}  // namespace pf
