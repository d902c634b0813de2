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
#ifndef POINTFORWARD_ENGINE_RECON_VIEW_DEPTH_H_
#define POINTFORWARD_ENGINE_RECON_VIEW_DEPTH_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "common/geometry.h"
#include "engine/clip/clip_io.h"
#include "engine/recon/context_views.h"
#include "engine/render/gaussian_scene.h"
#include "engine/render/line_poses.h"

namespace pf {

// One LiDAR sweep in world coordinates.
struct LidarSweepData {
  int64_t timestamp_us = 0;
  std::vector<float> points;       // [P, 3] world frame
  std::vector<float> intensities;  // [P] as recorded; empty where not known.
  Vec3 sensor_origin;              // World position of the sensor.
  Vec3 sensor_up{0, 0, 1};         // World direction of the sensor's z axis (up on a level mount).
};

// Reads every sweep of the clip (float32 little-endian x, y, z, intensity
// records in the sensor frame) and moves the points to the world, keeping
// their intensities.
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

// Returns `depth` with every value that is not a positive finite depth set
// to 0 (unknown).
ImageF KnownDepthOnly(const ImageF& depth);

// Projects world points into a camera: [H, W] z depth of the nearest point
// per pixel, 0 where none falls. Through `lines`, each point lands on the
// line that reads it, its depth that line's.
ImageF ProjectPoints(const std::vector<float>& points, const LinePoses& lines);
ImageF ProjectPoints(const std::vector<float>& points, const CameraModel& camera,
                     const Rigid& world_from_camera);

struct CompletionOptions {
  // How the projected LiDAR is densified: kNearest, each pixel the nearest
  // measurement's depth (CompleteDepth); kIpBasic, IP-Basic
  // (depth_completion.h) without its upward extension, so the region above
  // the top beam stays unknown for the facades and the far layer, and
  // CompleteDepth where IP-Basic leaves a pixel unknown.
  enum class Method { kNearest, kIpBasic };
  Method method = Method::kNearest;
  // Pixels further than this from any measured pixel stay unknown. <= 0:
  // CompletionRadius(image height), so the gap between LiDAR rings on the
  // road near the car (tens of pixels in a 1216-row image) is bridged.
  int max_distance_px = 0;
  // Pixels whose ray meets the sweep's ground plane (FitGroundPlane) within
  // the ground's measured reach take the plane's depth where completion left
  // them unknown (the road below the lowest ring, next to the car, and in
  // gaps between distant rings: instead of the far layer) or gave them the
  // depth of a LiDAR point on the road (the road between rings: their own
  // depth instead of the nearest ring's); see FillFromGround.
  bool ground_fill = true;
  // LiDAR views' pixels above the highest measured point of a facade
  // continue its vertical plane where other views agree (facade_depth.h).
  bool facades = true;
  // The completed views' pixels still unknown then take the depth a plane
  // sweep over the nearby context views finds, where it is clear
  // (stereo_depth.h), and then the depth below them continued up, where
  // other views agree (ExtendUpward, facade_depth.h); the gaps these leave
  // enclosed by known depth take the depth around them (FillEnclosedGaps,
  // depth_stage.h).
  bool stereo = true;
};

// The road surface around a LiDAR: the points p with Dot(normal, p) = offset
// (world frame; `normal` is a unit vector on the sensor's up side), measured
// out to `reach` metres from the sensor along the plane.
struct GroundPlane {
  bool valid = false;
  Vec3 normal{0, 0, 1};
  double offset = 0;
  double reach = 0;
  size_t inliers = 0;
};

// Sets `e1`, `e2` to two unit vectors that complete the unit vector `up` to
// a right-handed orthonormal frame (e1 x e2 = up): axes of the level plane.
void LevelAxes(const Vec3& up, Vec3* e1, Vec3* e2);

// The views that check view `v`'s depth against their images (facades,
// stereo): the other views whose cameras are `min_baseline` to
// `max_baseline` metres away and whose forward axes make a cosine above
// `min_cos` with v's, the same camera's first, then nearest first (then by
// index); at most `count`.
std::vector<size_t> CheckingViews(const std::vector<ContextView>& views, size_t v,
                                  double min_baseline, double max_baseline, double min_cos,
                                  int count);

// Fits the ground plane under a sweep: RANSAC (a fixed seed, so the result
// is reproducible) over the points 1.5-60 m from the sensor and at most 2 m
// above the lowest of them (their 1st percentile height), planes within 20
// degrees of level, inliers within 0.1 m; then a least-squares fit to the
// inliers. Not valid when fewer than 50 points (or
// 10 % of the candidates) lie on the best plane.
GroundPlane FitGroundPlane(const LidarSweepData& sweep);

// Sets the pixels of `depth` that see `ground` (their ray, through the pixel
// centre, goes down to it at most `ground.reach` metres from the sensor at
// `sensor_origin`, along the plane) to the z depth of that point, where
// `depth` is unknown (0), and where completion copied the depth of a
// measured point that lies on the road (within 0.15 m of the plane) and the
// plane's depth is within 15 % of it: between rings, completion gives the
// road the nearest ring's depth, the plane gives each pixel its own. The
// plane's depth is scaled by the road's local departure from it: the mean
// ratio of measured to plane depth over the road measurements (within 15 %
// of the plane) within CompletionRadius of the pixel, 1 where there is none.
// `sources` is CompleteDepth's (measured pixels are their own source).
// Measured pixels and other surfaces are kept. Returns how many pixels it
// set.
// Each pixel's ray leaves from its line's pose (`lines`).
int64_t FillFromGround(const GroundPlane& ground, const Vec3& sensor_origin, const LinePoses& lines,
                       const std::vector<int32_t>& sources, ImageF* depth);

// Returns the automatic completion radius: max(12, 4 % of `height`) pixels.
int CompletionRadius(int height);

// Densifies a sparse depth map: every unknown pixel within
// `max_distance_px` of measured ones takes the depth of the nearest one,
// preferring the nearer surface among measurements within 1.5 px of the
// nearest distance (so background does not bleed over thin foreground).
// Measured pixels keep their value. The search keeps to the 3 x 3 cells of
// max_distance_px around the pixel's cell; equal depths go to the first
// measurement in cell order, then raster order. `sources`, when given,
// receives for every pixel the measured pixel (y * W + x) whose depth it
// took, itself when measured, -1 when unknown.
ImageF CompleteDepth(const ImageF& sparse, const CompletionOptions& options = {},
                     std::vector<int32_t>* sources = nullptr);

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

// Where a pixel's depth came from: a dense depth map, completion of sparse
// measurements (LiDAR, a sparse depth map) with the ground plane and
// facades, or the far layer.
enum class DepthSource : uint8_t { kDepthMap = 0, kCompleted = 1, kFar = 2 };

// The depth of one view, ready for lifting.
struct ViewDepth {
  int width = 0, height = 0;
  std::vector<float> depth;     // [H, W] z depth, > 0 everywhere (far pixels: FarDepth)
  std::vector<uint8_t> source;  // [H, W] DepthSource
  bool is_far(size_t pixel) const { return source[pixel] == uint8_t(DepthSource::kFar); }
};

// What MeasuredDepth started from.
enum class MeasuredSource {
  kNone,            // No depth map and no LiDAR sweep: all unknown.
  kDepthMap,        // The frame's dense depth map, as it is.
  kSparseDepthMap,  // The frame's sparse depth map (IsSparseDepth), completed.
  kLidar,           // The nearest LiDAR sweep, projected and completed.
};

// True when MeasuredDepth completed sparse measurements (facades may extend
// such a view above its highest measurement).
inline bool IsCompleted(MeasuredSource source) {
  return source == MeasuredSource::kSparseDepthMap || source == MeasuredSource::kLidar;
}

// Returns the measured depth of `view` before the far layer, 0 unknown,
// [H, W]:
// - a dense depth map as it is (0 and non-finite values unknown);
// - a sparse one (IsSparseDepth: LiDAR or stereo points written into the
//   manifest) completed as LiDAR is, its ground plane fitted to its own
//   points lifted to the world (the camera's image-up axis as "up");
// - without a depth map, the nearest sweep (moved to the view's time)
//   projected and completed;
// completion and ground fill by `options`. `source` says which one was used;
// `ground_pixels` how many pixels the ground fill set, `ground` the plane it
// used.
ImageF MeasuredDepth(const ContextView& view, const std::vector<LidarSweepData>& sweeps,
                     const std::vector<InstanceTrack>& tracks, const CompletionOptions& options,
                     MeasuredSource* source = nullptr, int64_t* ground_pixels = nullptr,
                     GroundPlane* ground = nullptr);

// Fills the unknown pixels of `measured` from the far layer; the known ones
// are DepthSource::kCompleted when `completed`, else kDepthMap.
ViewDepth WithFarLayer(const ImageF& measured, bool completed, const ContextView& view,
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

#endif  // POINTFORWARD_ENGINE_RECON_VIEW_DEPTH_H_
