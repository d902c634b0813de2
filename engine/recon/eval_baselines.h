// The two baselines `pf eval` measures beside the reconstruction on every
// TARGET frame (evaluation.h), made from the clip alone: the CONTEXT images,
// camera models and poses, depth maps and LiDAR, and the classical depth
// completion of depth_completion.h. Nothing of the reconstruction (fusion,
// sampling, colour fit, ground plane, facades) goes into them, so they stay
// fixed while the method changes.
//
// - nearest: the CONTEXT image of the target's camera nearest in time,
//   unchanged.
// - warp: the two CONTEXT frames of the target's camera nearest in time,
//   each forward-warped into the target view (ForwardWarp) with its depth
//   (WarpSourceDepth); the nearer frame's warp, its holes filled from the
//   other's, then from the nearest filled pixel (CombineWarps). Moving actors
//   are not handled: they are warped as if they stood still where the
//   context frame saw them.
// A target whose camera has no CONTEXT frame takes the CONTEXT frames of
// every camera instead (NearestContextFrames); `nearest` is then resized
// (nearest pixel) to the target's size where the sizes differ.
//
//   EvalBaselines baselines(loaded, view_options);
//   ASSIGN_OR_RETURN(FrameBaselines b, baselines.Make(target));
#ifndef POINTFORWARD_ENGINE_RECON_EVAL_BASELINES_H_
#define POINTFORWARD_ENGINE_RECON_EVAL_BASELINES_H_

#include <cstdint>
#include <map>
#include <optional>
#include <vector>

#include "absl/status/statusor.h"
#include "common/geometry.h"
#include "engine/clip/clip_io.h"
#include "engine/recon/context_views.h"
#include "engine/recon/view_depth.h"

namespace pf {

// Returns up to `count` CONTEXT frames (ROLE_UNSPECIFIED counts) for frame
// `target` of `clip`, as indices into clip.frames, nearest in time first
// (ties: the earlier frame first). Only frames of the target's camera, unless
// it has none: then every camera's, ties in time broken by the distance
// between the camera centres. Empty when the clip has no CONTEXT frame.
std::vector<int> NearestContextFrames(const pointforward::v1::Clip& clip, int target, int count);

// Returns the depth a warp lifts `view` with ([H, W, 1] z depth, 0 none):
// its depth map when it has one (completed by CompleteDepthIpBasic when
// IsSparseDepth), else the points of the LiDAR sweeps nearest in time
// (every sweep within 10 ms of the nearest one's time gap, so the sweeps of
// a rig's LiDARs that fire together; not moved with the boxes) projected
// into it and completed, else none at all.
ImageF WarpSourceDepth(const ContextView& view, const std::vector<LidarSweepData>& sweeps);

// Returns the points of the LiDAR sweeps nearest in time to `view` (as
// WarpSourceDepth chooses them) projected into it: [H, W, 1] z depth, the
// nearest point per pixel, 0 none (everywhere when there is no sweep).
ImageF SweepDepth(const ContextView& view, const std::vector<LidarSweepData>& sweeps);

// One image warped into another view.
struct WarpedView {
  ImageF rgb;    // [H, W, 3]; 0 where nothing landed.
  ImageF depth;  // [H, W, 1] z depth in the target; 0 where no surface at a finite depth landed.
  std::vector<uint8_t> covered;  // [H, W] 1 where something landed.
};

// Forward-warps `source` (its colour, camera, pose and ego mask) into
// `camera` at `world_from_camera`: each pixel off the ego body is lifted
// along its ray to `depth` ([H, W, 1] z; pixels without depth are taken as
// infinitely far: only their direction moves), projected into the target and
// splatted onto the 2x2 pixels around where it lands with bilinear weights
// (no cracks up to 2x magnification). Each target pixel keeps the nearest
// surface landing inside it (z-buffer), or in a crack the nearest whose
// footprint reaches it (so no surface spreads a pixel over what lies behind
// its edge), and blends, by those weights, the splats within 3 % of that
// depth.
WarpedView ForwardWarp(const ContextView& source, const ImageF& depth, const CameraModel& camera,
                       const Rigid& world_from_camera);

// Returns the first warp with its uncovered pixels taken from the next warps
// that cover them, in order, and the rest (colour and depth) from the
// nearest pixel that one covered (8-connected distance); `covered` marks the
// pixels some warp covered. Every warp has the same size; at least one.
WarpedView CombineWarps(const std::vector<WarpedView>& warps);

// The baselines of one TARGET frame, at its size.
struct FrameBaselines {
  ImageF nearest_rgb;               // [H, W, 3]
  ImageF nearest_depth;             // [H, W, 1] its depth map; empty when it has none.
  std::vector<int> nearest_frames;  // Indices into clip.frames.
  WarpedView warp;
  std::vector<int> warp_frames;  // Nearer first.
  // The target's own LiDAR (SweepDepth of the target view), the truth of
  // lidarAbsRel; width 0 when the clip has no LiDAR.
  ImageF target_lidar;
};

// Makes the baselines of a clip's TARGET frames. Keeps each CONTEXT frame it
// decoded, with its warp depth, until the last TARGET frame (in manifest
// order) that uses it has been made.
class EvalBaselines {
 public:
  EvalBaselines(const LoadedClip& loaded, const LoadViewsOptions& options);

  // Returns the baselines of `target`, a frame of the clip (LoadViews).
  // INVALID_ARGUMENT when the clip has no CONTEXT frame; the errors of
  // LoadFrames and LoadLidarSweeps.
  absl::StatusOr<FrameBaselines> Make(const ContextView& target);

 private:
  struct Source {
    ContextView view;
    ImageF depth;  // WarpSourceDepth.
  };
  absl::StatusOr<const Source*> SourceFor(int frame);
  // The clip's LiDAR sweeps, read at first call.
  absl::StatusOr<const std::vector<LidarSweepData>*> Sweeps();

  const LoadedClip& loaded_;
  LoadViewsOptions options_;
  std::optional<std::vector<LidarSweepData>> sweeps_;  // Read at first need.
  std::map<int, Source> sources_;                      // By frame index.
  std::map<int, int> last_target_;  // CONTEXT frame -> the last TARGET frame using it.
};

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_EVAL_BASELINES_H_
