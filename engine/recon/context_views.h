// The inputs of a reconstruction: the CONTEXT frames of a clip with their
// camera model, pose, time, colour and (optional) depth map, and the clip's
// box tracks in the form the Gaussian scene stores them.
//
//   ASSIGN_OR_RETURN(LoadedClip loaded, LoadClip(path));
//   ASSIGN_OR_RETURN(std::vector<ContextView> views, LoadContextViews(loaded));
//
// Frames with role ROLE_UNSPECIFIED count as CONTEXT (clip.proto). Paths are
// resolved inside the clip directory (ResolveClipPath).
#ifndef POINTFORWARD_ENGINE_RECON_CONTEXT_VIEWS_H_
#define POINTFORWARD_ENGINE_RECON_CONTEXT_VIEWS_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "common/geometry.h"
#include "engine/camera/camera_model.h"
#include "engine/clip/clip_io.h"
#include "engine/image/image_io.h"
#include "engine/render/gaussian_scene.h"
#include "engine/render/line_poses.h"
#include "engine/render/rasterizer.h"

namespace pf {

// One image of the clip, decoded.
struct ContextView {
  int frame_index = -1;  // Index into clip.frames.
  std::string camera_id;
  CameraModel camera;
  Rigid world_from_camera;   // Of the first line read, with a rolling shutter.
  int64_t timestamp_us = 0;  // Likewise.
  // The frame's rolling shutter (Frame.rolling_shutter); unset, the whole
  // image is at one pose and time. Reconstruction lifts each pixel from its
  // line's pose and projects into the view onto the line that reads a point
  // (lines()); box membership and canonical frames take each line's time
  // (sparse_sampling.h LineTime), fusion the actors at timestamp_us.
  std::optional<RollingShutter> rolling_shutter;
  ImageF rgb;    // [H, W, 3] in [0, 1], in LoadViewsOptions::colour_encoding.
  ImageF depth;  // [H, W, 1] metres along z, 0 unknown; empty (width 0) when the frame has none.
  // [H, W] 1 on the ego vehicle's body (Camera.ego_mask), 0 elsewhere; empty
  // when the camera has no mask. Such pixels are never lifted; they neither
  // see nor see past anything, in sampling's visibility tests and in fusion
  // (nor give colour to its bilinear samples); they are left out of the far
  // layer's radius, the colour fit and eval's figures.
  std::vector<uint8_t> ego;

  bool is_ego(size_t pixel) const { return !ego.empty() && ego[pixel] != 0; }

  int width() const { return camera.width(); }
  int height() const { return camera.height(); }
  LinePoses lines() const { return LinePoses(camera, world_from_camera, rolling_shutter); }
  // The middle line's time (timestamp_us without a rolling shutter): the one
  // time for uses that take a single time per image, with
  // lines().MiddleWorldFromCamera().
  int64_t middle_time_us() const {
    return rolling_shutter.has_value() ? timestamp_us + rolling_shutter->readout_us / 2
                                       : timestamp_us;
  }
  // The camera centre of the line through continuous pixel (u, v).
  Vec3 centre_at(double u, double v) const {
    if (!rolling_shutter.has_value()) return world_from_camera.translation;
    const double f = ReadoutFraction(rolling_shutter->readout, width(), height(), u, v);
    const Vec3& a = world_from_camera.translation;
    return a + f * (rolling_shutter->world_from_camera_end.translation - a);
  }
  RenderCamera render_camera() const { return {camera, world_from_camera, rolling_shutter}; }
};

// Which frames LoadViews() reads.
enum class FrameSelection { kContext, kTarget };

struct LoadViewsOptions {
  bool read_depth = true;  // Read the frames' depth maps when they name one.
  bool allow_outside_paths = false;
  // The encoding ContextView::rgb holds: each image is converted from its
  // camera's colour space (Camera.color_space; unspecified: by its file
  // format, image_io.h ReadColourImage).
  ColourEncoding colour_encoding = ColourEncoding::kSrgb;
};

// Decodes the frames of `loaded` with the selected role, in manifest order.
// INVALID_ARGUMENT naming the field (`frames[3].image: ...`) for an unknown
// camera, a pose that is not 16 numbers, or an image/depth map whose size is
// not the camera's, and likewise for a camera's ego mask
// (`cameras[1].egoMask: ...`); NOT_FOUND for a missing file.
absl::StatusOr<std::vector<ContextView>> LoadViews(const LoadedClip& loaded,
                                                   FrameSelection selection,
                                                   const LoadViewsOptions& options = {});

// Decodes the frames `frame_indices` (indices into clip.frames, any role) of
// `loaded`, in that order; errors as LoadViews, and INVALID_ARGUMENT naming
// `frames` for an index out of range. Only the ego masks of their cameras are
// read.
absl::StatusOr<std::vector<ContextView>> LoadFrames(const LoadedClip& loaded,
                                                    const std::vector<int>& frame_indices,
                                                    const LoadViewsOptions& options = {});

// LoadViews(loaded, FrameSelection::kContext, options).
absl::StatusOr<std::vector<ContextView>> LoadContextViews(const LoadedClip& loaded,
                                                          const LoadViewsOptions& options = {});

// Returns the clip's box tracks, boxes sorted by time, in the order of
// clip.instances. INVALID_ARGUMENT naming the field for a box whose centre,
// size or rotation has the wrong number of values, a zero quaternion, or two
// boxes of one instance at the same time. Instances without boxes are kept
// (they never own a point).
absl::StatusOr<std::vector<InstanceTrack>> TracksFromClip(const pointforward::v1::Clip& clip);

// Returns the earliest frame timestamp of the clip (0 when it has none); the
// reconstruction's scene time origin.
int64_t ClipTimeOrigin(const pointforward::v1::Clip& clip);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_CONTEXT_VIEWS_H_
