// `pf synth render`: the true images and depths of a synthetic clip at views
// it never saw (other poses, intrinsics, times), with actor edits, for
// extrapolated-view tests. The scene is regenerated from the clip's
// synth.json; the views come as a pointforward.v1.RenderViews message.
#ifndef POINTFORWARD_ENGINE_SYNTH_SYNTH_VIEW_RENDERER_H_
#define POINTFORWARD_ENGINE_SYNTH_SYNTH_VIEW_RENDERER_H_

#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "common/geometry.h"
#include "engine/camera/camera_model.h"
#include "engine/synth/synth_ray_caster.h"
#include "engine/synth/synth_scene.h"
#include "pointforward/v1/views.pb.h"

namespace pf {

// A view's rolling shutter (View.rolling_shutter): its lines are read from
// the view's pose and time to `world_from_camera_end`, `readout_s` later.
struct SynthReadout {
  pointforward::v1::RollingShutter::Readout readout;
  double readout_s = 0;
  Rigid world_from_camera_end;
};

// One view, checked and ready to render.
struct ResolvedView {
  std::string name;  // Output file stem.
  CameraModel camera;
  Rigid world_from_camera;
  double time_s = 0;
  std::optional<SynthReadout> rolling_shutter;  // Pinhole cameras only.
};

struct ResolvedViews {
  std::vector<ResolvedView> views;
  VehicleEdits edits;
};

// Checks `request` against `scene` and resolves it. A view's camera is looked
// up in request.cameras, then among the clip's own cameras. INVALID_ARGUMENT
// naming the field (`views[2].camera: unknown camera 'x'`) for unknown or
// duplicate ids and names, poses that are not 16 finite numbers of a rigid
// transform, bad intrinsics or images over 16384 pixels a side, unknown
// edited instances, edits without a kind, TRAJECTORY edits without valid
// boxes, and rolling shutters without a readout, with a negative readoutUs or
// a bad worldFromCameraEnd, or on a camera with lens distortion. A
// rolling-shutter view is rendered line by line, each line from its pose and
// at its time.
absl::StatusOr<ResolvedViews> ResolveViews(const pointforward::v1::RenderViews& request,
                                           const SynthScene& scene);

// Parses proto3 JSON text of a RenderViews message; INVALID_ARGUMENT
// prefixed with `where` when malformed or holding unknown fields.
absl::StatusOr<pointforward::v1::RenderViews> ParseRenderViews(const std::string& json,
                                                               const std::string& where);

// Regenerates the scene of the clip in `clip_dir` (its synth.json), renders
// every view of the RenderViews JSON file `views_path`, and writes
// `out_dir/<name>.png` and `out_dir/<name>.exr` (depth). Returns the names.
absl::StatusOr<std::vector<std::string>> RenderSynthViews(const std::string& clip_dir,
                                                          const std::string& views_path,
                                                          const std::string& out_dir);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_SYNTH_SYNTH_VIEW_RENDERER_H_
