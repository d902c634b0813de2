// The procedural driving scene behind `pf synth`: a straight road along the
// world x axis with a junction, lane markings, kerbs and pavements, textured
// building facades and poles on both sides, a sky, and moving vehicles, all
// made of analytic primitives (a ground plane and boxes) so that a ray caster
// (synth_ray_caster.h) gives exact ground truth at any pose and time.
//
// Usage (what the README section can say):
//
//   pf synth --out DIR [--seed N] [--cameras 3] [--frames 20]
//            [--width 768 --height 576] [--antialias 2]
//     writes DIR/clip.json (a pointforward.v1.Clip), images/<cam>_<t>.png,
//     depth/<cam>_<t>.exr (metres along the camera z axis, 0 = sky),
//     lidar/<t>.bin (float32 x, y, z, intensity in the sensor frame; 32
//     beams x 1024 azimuths, 80 m), box tracks of every vehicle at every
//     frame time, and synth.json (seed, sizes, generator version). Cameras
//     cam_left, cam_front, cam_right look 40 degrees apart with a 75 degree
//     horizontal field of view, at 10 Hz; frames at 0, 0.5, 1.0, 1.5 s are
//     CONTEXT, the rest TARGET.
//   pf synth render --clip DIR --cameras VIEWS.json --out DIR2
//     reads a pointforward.v1.RenderViews (views.proto) and writes the true
//     DIR2/<name>.png and DIR2/<name>.exr of each view, honouring REMOVE and
//     TRAJECTORY edits of the instances (vehicle_1 ...).
//
// The scene is a pure function of the seed (the other options only size the
// sensors): GenerateSynthScene(options) always builds the same SynthScene for
// the same options, so a clip written by `pf synth` can be re-rendered later
// from its synth.json alone. Vehicles: vehicle_1 ahead in the ego lane,
// vehicle_2 oncoming, vehicle_3 crossing at the junction, vehicle_4
// overtaking on the right; drawn so that they do not collide in the first
// 2 s.
//
// World frame: metres, z up, the road runs along +x, +y is the ego's left; the
// road surface is the plane z = 0. The ego car drives along +x in the right
// lane; its frame ("ego") has x forward, y left, z up, origin on the ground.
// Cameras use OpenCV axes (x right, y down, z forward) as everywhere else.
//
// Layout of the parts (see also the files beside this one):
//   synth_scene       scene description, trajectories, camera rig
//   synth_shading     procedural textures and lighting
//   synth_ray_caster  ray/scene intersection and image rendering
//   synth_lidar       the spinning LiDAR
//   synth_clip_writer writes a clip directory (clip.json, images, depth, ...)
//   synth_view_renderer  `pf synth render`: ground truth at requested views
#ifndef POINTFORWARD_ENGINE_SYNTH_SYNTH_SCENE_H_
#define POINTFORWARD_ENGINE_SYNTH_SYNTH_SCENE_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "common/geometry.h"
#include "engine/camera/camera_model.h"

namespace pf {

// Bumped whenever the scene a seed produces changes; synth.json records it.
inline constexpr int kSynthVersion = 1;

// What `pf synth` takes. Everything that shapes the scene or its sensors.
enum class SynthLens { kPinhole, kFTheta };

struct SynthOptions {
  uint64_t seed = 1;    // [0, 2^53): stored in JSON as a number.
  int num_cameras = 3;  // Front-facing cameras spread in yaw, [1, 8].
  int num_frames = 20;  // Frames per camera at frame_rate_hz, [1, 600].
  int width = 768;      // Image size in pixels, [16, 8192].
  int height = 576;
  int antialias = 2;  // Colour samples per pixel axis, [1, 4].
  // kPinhole: 75 degrees across; kFTheta: an f-theta lens 120 degrees across
  // (SynthFThetaPolynomial).
  SynthLens lens = SynthLens::kPinhole;
};

// The f-theta polynomial (pixels at theta^0 .. theta^5) of a synth camera
// `width` pixels wide: f (theta - 0.05 theta^3), f such that the image's
// sides lie 60 degrees off the axis.
std::vector<double> SynthFThetaPolynomial(int width);

// Returns INVALID_ARGUMENT naming the option when one is out of range.
absl::Status ValidateSynthOptions(const SynthOptions& options);

inline constexpr double kFrameRateHz = 10.0;
// The paper's protocol: frames at these times are CONTEXT, the rest TARGET.
inline constexpr int64_t kContextTimestampsUs[] = {0, 500000, 1000000, 1500000};

// Returns true if a frame at `timestamp_us` is a CONTEXT frame.
bool IsContextTimestamp(int64_t timestamp_us);

// What a static box is made of; selects its texture.
enum class StaticKind : uint8_t {
  kPavement,  // Top: paving slabs; sides: kerb stones.
  kBuilding,  // Sides: facades with windows and signs; top: roof.
  kPole,      // Lamp posts and their arms.
};

// An axis-aligned box of the static world.
struct StaticBox {
  Vec3 lo, hi;  // World-frame corners, lo < hi on every axis.
  StaticKind kind = StaticKind::kBuilding;
  uint32_t texture_seed = 0;  // Varies windows, signs, tones per box.
  Vec3 albedo{0.5, 0.5, 0.5};
};

// The parts a vehicle is built from, in its box frame.
enum class VehiclePartKind : uint8_t { kBody, kCabin, kWheel };

struct VehiclePart {
  Vec3 lo, hi;  // Box-frame corners (origin at the box centre, x forward, z up).
  VehiclePartKind kind = VehiclePartKind::kBody;
};

// A moving vehicle: an oriented 3D box (its track) holding a few part boxes.
// It follows a circular arc (a straight line when yaw_rate is 0) at constant
// speed on the ground.
struct Vehicle {
  std::string id;        // Instance id in the clip, e.g. "vehicle_1".
  std::string category;  // "car", "van", ...
  int instance_id = 0;   // 1-based id in instance buffers; 0 is the static world.
  Vec3 size;             // (length, width, height) of the box.
  Vec3 albedo;           // Paint colour.
  uint32_t texture_seed = 0;
  std::vector<VehiclePart> parts;  // All inside the box.

  Vec3 start_position;       // Box centre at t = 0 (z = height / 2).
  double start_heading = 0;  // Yaw of the box x axis at t = 0, radians from +x.
  double speed = 0;          // Metres per second along the heading.
  double yaw_rate = 0;       // Radians per second.

  // Returns the box-to-world transform at time `t` seconds.
  Rigid BoxToWorldAt(double t) const;
};

// One camera of the rig, fixed to the ego car.
struct RigCamera {
  std::string id;
  double yaw = 0;    // Radians, positive to the left (about ego z).
  double pitch = 0;  // Radians, positive up.
  Vec3 position;     // In the ego frame.
  CameraModel model;
};

// Road layout numbers shared by the generator and the textures.
struct RoadLayout {
  double lane_width = 3.5;
  double half_width = 7.0;    // Kerb line at |y| = half_width.
  double kerb_height = 0.15;  // Pavement top.
  double pavement_width = 3.5;
  double junction_x = 45.0;  // Centre of the cross street (along y).
  double junction_half_width = 7.0;
};

// The whole scene. Tests may edit a generated one (e.g. drop boxes) before
// rendering it.
struct SynthScene {
  SynthOptions options;
  RoadLayout road;
  std::vector<StaticBox> boxes;
  std::vector<Vehicle> vehicles;
  std::vector<RigCamera> cameras;
  Vec3 lidar_position;  // In the ego frame.
  double ego_lane_y = -1.75;
  double ego_start_x = 0;
  double ego_speed = 8.0;  // Metres per second along +x.

  // Returns world_from_ego at time `t` seconds.
  Rigid EgoPoseAt(double t) const;
  // Returns world_from_camera (OpenCV axes) of cameras[index] at time `t`.
  Rigid WorldFromCamera(int index, double t) const;
  // Returns world_from_sensor of the roof LiDAR (x forward, y left, z up).
  Rigid WorldFromLidar(double t) const;
  // Returns the frame timestamps: options.num_frames at kFrameRateHz from 0.
  std::vector<int64_t> FrameTimestampsUs() const;
  // Returns the index of the camera named `id`, or -1.
  int FindCamera(const std::string& id) const;
};

// Builds the scene for `options` (validated first).
absl::StatusOr<SynthScene> GenerateSynthScene(const SynthOptions& options);

// Returns true if the ground footprints (length x width rectangles) of boxes
// `a` and `b` (box-to-world poses, yawed about z) come closer than `margin`.
bool FootprintsOverlap(const Rigid& a, const Vec3& size_a, const Rigid& b, const Vec3& size_b,
                       double margin = 0.0);

// Returns the rotation taking ego-frame vectors (x forward, y left, z up) of
// a camera with `yaw` and `pitch` to OpenCV camera axes, as camera-to-ego.
Mat3 EgoFromOpenCvCamera(double yaw, double pitch);

// Returns the rotation about world z by `yaw` radians.
Mat3 YawRotation(double yaw);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_SYNTH_SYNTH_SCENE_H_
