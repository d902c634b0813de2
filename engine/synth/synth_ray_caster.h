// The ground-truth renderer of the synthetic scene: a ray caster over its
// analytic primitives (the ground plane z = 0, static boxes, and vehicle part
// boxes placed at one time). It is independent of the Gaussian rasterizer and
// exact: a hit's distance is the analytic ray-primitive intersection.
//
//   SceneSnapshot snapshot = SnapshotAt(scene, 0.5);
//   RenderedView view = RenderView(snapshot, camera, world_from_camera, 2);
//
// RenderView traces one ray through each pixel centre for depth and instance
// id, and antialias^2 stratified rays per pixel (a regular sub-pixel grid,
// deterministic) for colour. Rows of 16x16 tiles run on DefaultThreadPool();
// each tile tests only the primitives whose bounding boxes meet its frustum.
#ifndef POINTFORWARD_ENGINE_SYNTH_SYNTH_RAY_CASTER_H_
#define POINTFORWARD_ENGINE_SYNTH_SYNTH_RAY_CASTER_H_

#include <cstdint>
#include <limits>
#include <map>
#include <set>
#include <vector>

#include "common/geometry.h"
#include "engine/camera/camera_model.h"
#include "engine/image/image_io.h"
#include "engine/synth/synth_scene.h"

namespace pf {

// One pose of a replacement track.
struct TrackPose {
  double time_s = 0;
  Vec3 center;    // World position of the box centre.
  Quat rotation;  // Box-to-world.
};

// Changes to the vehicles for one render, keyed by Vehicle::instance_id.
struct VehicleEdits {
  std::set<int> removed;  // Not rendered.
  // Replacement tracks (sorted by time): the vehicle's box follows these,
  // linear in the centre and slerp in rotation, held constant beyond the ends.
  std::map<int, std::vector<TrackPose>> trajectories;
};

// Returns the box-to-world pose of `track` (non-empty, sorted) at `time_s`.
Rigid InterpolateTrack(const std::vector<TrackPose>& track, double time_s);

// A vehicle placed at one time.
struct PlacedVehicle {
  const Vehicle* vehicle = nullptr;
  Rigid box_to_world;
  Rigid world_to_box;
  Vec3 lo, hi;  // World-frame bounding box of the oriented box.
};

// The scene frozen at one time with edits applied; what rays are cast into.
// Holds a pointer to the scene, which must outlive it.
struct SceneSnapshot {
  const SynthScene* scene = nullptr;
  double time_s = 0;
  std::vector<PlacedVehicle> vehicles;
};

// Places the vehicles of `scene` at `time_s`, without removed ones.
SceneSnapshot SnapshotAt(const SynthScene& scene, double time_s, const VehicleEdits& edits = {});

// The primitives a ray is tested against: indices into scene->boxes and
// snapshot.vehicles.
struct Candidates {
  std::vector<int> statics;
  std::vector<int> vehicles;
};

// Returns every primitive of `snapshot`.
Candidates AllCandidates(const SceneSnapshot& snapshot);

// Returns the primitives whose bounding boxes meet the pyramid with apex
// `apex` spanned by the four edge directions `corners` (in order around it).
Candidates CullToPyramid(const SceneSnapshot& snapshot, const Candidates& from, const Vec3& apex,
                         const Vec3 corners[4]);

// The nearest surface along a ray.
struct RayHit {
  bool hit = false;  // False: the ray reached the sky (or max_distance).
  double distance = std::numeric_limits<double>::infinity();  // Along the unit direction.
  Vec3 point;                                                 // World position.
  Vec3 normal;                                                // World unit normal, facing the ray.
  Vec3 albedo;                                                // Texture colour before lighting.
  int instance = 0;  // Vehicle::instance_id, or 0 for the static world.
};

// Casts the ray `origin + s * dir` (dir a unit vector, s in (0,
// max_distance)) against `candidates` of `snapshot` and the ground.
RayHit CastRay(const SceneSnapshot& snapshot, const Candidates& candidates, const Vec3& origin,
               const Vec3& dir, double max_distance = std::numeric_limits<double>::infinity());

// Casts against everything in `snapshot`.
RayHit CastRay(const SceneSnapshot& snapshot, const Vec3& origin, const Vec3& dir,
               double max_distance = std::numeric_limits<double>::infinity());

// Returns the colour a ray along unit `dir` sees for `hit`: the lit surface,
// or the sky when there is no hit. Components in [0, 1].
Vec3 RayColour(const RayHit& hit, const Vec3& dir);

// One rendered image with its ground-truth layers.
struct RenderedView {
  ImageF rgb;                     // [H, W, 3] in [0, 1]
  ImageF depth;                   // [H, W, 1] metres along the camera z axis; 0 for sky.
  std::vector<int32_t> instance;  // [H * W] row-major; 0 static world or sky.
};

// Renders `snapshot` through `camera` at `world_from_camera` (OpenCV axes)
// with antialias x antialias colour samples per pixel (antialias >= 1).
RenderedView RenderView(const SceneSnapshot& snapshot, const CameraModel& camera,
                        const Rigid& world_from_camera, int antialias);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_SYNTH_SYNTH_RAY_CASTER_H_
