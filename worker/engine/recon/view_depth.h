// Depth per context image (DESIGN.md section 3, step 1): the frame's own
// depth map when it has one, else the nearest LiDAR sweep in time projected
// into the image and densified by a classical completion. Pixels that end up
// with no trustworthy depth (sky, beyond the LiDAR's reach) are put on the
// far layer: a sphere around the context cameras, large enough to hold every
// measured point, onto which their rays are lifted instead of being dropped.
//
//   ASSIGN_OR_RETURN(std::vector<LidarSweepData> sweeps, LoadLidarSweeps(loaded));
//   FarLayer far = FarLayerFor(views, depths_so_far);
//   ViewDepth depth = DepthForView(view, sweeps, tracks, far, {});
#ifndef POINTFORWARD_WORKER_ENGINE_RECON_VIEW_DEPTH_H_
#define POINTFORWARD_WORKER_ENGINE_RECON_VIEW_DEPTH_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "common/geometry.h"
#include "worker/engine/clip/clip_io.h"
#include "worker/engine/recon/context_views.h"
#include "worker/engine/render/gaussian_scene.h"

namespace pf {

// One LiDAR sweep in world coordinates.
struct LidarSweepData {
  int64_t timestamp_us = 0;
  std::vector<float> points;  // [P, 3] world frame
};

// Reads every sweep of the clip (float32 little-endian x, y, z, intensity
// records in the sensor frame) and moves the points to the world.
// INVALID_ARGUMENT naming `lidar[i].points` for a file whose size is not a
// multiple of 16 bytes, `lidar[i].worldFromSensor` for a pose that is not 16
// numbers; NOT_FOUND for a missing file.
absl::StatusOr<std::vector<LidarSweepData>> LoadLidarSweeps(const LoadedClip& loaded,
                                                            bool allow_outside_paths = false);

// Returns the index of the sweep nearest in time to `timestamp_us`, -1 when
// there is none.
int NearestSweep(const std::vector<LidarSweepData>& sweeps, int64_t timestamp_us);

// Returns `sweep`'s points as seen at `timestamp_us`: points inside an
// instance's box (kMembershipMargin) at the sweep's time move with the box to its pose at
// `timestamp_us`; the rest stay. [P, 3] world frame.
std::vector<float> PointsAtTime(const LidarSweepData& sweep,
                                const std::vector<InstanceTrack>& tracks, int64_t timestamp_us);

// Projects world points into a camera: [H, W] z depth of the nearest point
// per pixel, 0 where none falls.
ImageF ProjectPoints(const std::vector<float>& points, const CameraModel& camera,
                     const Rigid& world_from_camera);

struct CompletionOptions {
  // Pixels further than this from any measured pixel stay unknown. <= 0:
  // CompletionRadius(image height), so the gap between LiDAR rings on the
  // road near the car (tens of pixels in a 1216-row image) is bridged.
  int max_distance_px = 0;
};

// Returns the automatic completion radius: max(12, 4 % of `height`) pixels.
int CompletionRadius(int height);

// Densifies a sparse depth map: every unknown pixel within
// `max_distance_px` of measured ones takes the depth of the nearest one,
// preferring the nearer surface among measurements within 1.5 px of the
// nearest distance (so background does not bleed over thin foreground).
// Measured pixels keep their value. A coarse grid of measured pixels keeps
// the search local.
ImageF CompleteDepth(const ImageF& sparse, const CompletionOptions& options = {});

// The far layer: a sphere that pixels without depth are lifted onto.
struct FarLayer {
  Vec3 center;
  double radius = 0;
};

// Returns the depth along z of the far-layer point seen through pixel centre
// (u, v), or 0 if the ray cannot be formed. The camera must lie inside the
// sphere.
double FarDepth(const FarLayer& far, const CameraModel& camera, const Rigid& world_from_camera,
                double u, double v);

// Returns the far layer of a set of views: centred on the mean camera
// centre, with radius max(min_radius, 2 x (largest camera distance from the
// centre + largest measured depth)).
FarLayer FarLayerFor(const std::vector<ContextView>& views, const std::vector<float>& max_depths,
                     double min_radius = 200.0);

// Where a pixel's depth came from.
enum class DepthSource : uint8_t { kDepthMap = 0, kLidar = 1, kFar = 2 };

// The depth of one view, ready for lifting.
struct ViewDepth {
  int width = 0, height = 0;
  std::vector<float> depth;     // [H, W] z depth, > 0 everywhere (far pixels: FarDepth)
  std::vector<uint8_t> source;  // [H, W] DepthSource
  bool is_far(size_t pixel) const { return source[pixel] == uint8_t(DepthSource::kFar); }
};

// Returns the measured depth of `view` before the far layer: its depth map
// when it has one, else the completed projection of the nearest sweep (moved
// to the view's time), else all unknown. [H, W], 0 unknown. `from_lidar` says
// which one was used.
ImageF MeasuredDepth(const ContextView& view, const std::vector<LidarSweepData>& sweeps,
                     const std::vector<InstanceTrack>& tracks, const CompletionOptions& options,
                     bool* from_lidar = nullptr);

// Fills the unknown pixels of `measured` from the far layer.
ViewDepth WithFarLayer(const ImageF& measured, bool from_lidar, const ContextView& view,
                       const FarLayer& far);

// What lies behind the near side of depth edges. A view sees one surface per
// pixel; the background next to a foreground edge continues behind it, and
// when the camera moves that hidden strip comes into view (disocclusion).
// `sources[k][i]` is the deepest pixel within `radii[k]` pixels (Chebyshev
// distance) of pixel i when it is deeper by more than `min_jump` (relative),
// else -1; radii are 1, 2, 4, ... up to the band, so a caller can take the
// nearest background that suits it. Far-layer pixels count with their far
// depth, so the sky beside a building's edge is found too.
struct BehindSources {
  std::vector<int> radii;
  std::vector<std::vector<int32_t>> sources;  // [scales][H * W]
};

// Returns the BehindSources of `depth` for radii 1, 2, 4, ... <= band_px
// (none when band_px < 1). Each scale's window maximum is the maximum of
// the previous scale's at 9 offsets, so the work is 9 look-ups per pixel and
// scale.
BehindSources FindBehindSources(const ViewDepth& depth, int band_px, double min_jump = 0.1);

}  // namespace pf

#endif  // POINTFORWARD_WORKER_ENGINE_RECON_VIEW_DEPTH_H_
