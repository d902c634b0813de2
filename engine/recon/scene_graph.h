// The scene graph of the paper's section 3.2: which points belong to a moving
// instance (inside its box at the image's time), the move of those points
// into the instance's canonical frame (the frame of its first box), and the
// dynamic masks of each view (the pixels whose rays cross a box).
//
// Column-vector form (geometry.h), with box b_t = (c_t, R_t) box-to-world:
//   inside:      |R_t^T (p - c_t)| <= m / 2 (element-wise)
//   canonical:   p~ = R_1 R_t^T (p - c_t) + c_1
// The paper writes row vectors with R^B world-to-box,
//   p~ = (p - c_t) R_t^T R_1 + c_1;
// transposed, with our box-to-world R = (R^B)^T, that is the line above:
// express p in box t, then place it in box 1. Boxes between track keyframes
// are interpolated as the renderer does (InterpolateBox: linear centre,
// slerp rotation).
#ifndef POINTFORWARD_ENGINE_RECON_SCENE_GRAPH_H_
#define POINTFORWARD_ENGINE_RECON_SCENE_GRAPH_H_

#include <cstdint>
#include <vector>

#include "common/geometry.h"
#include "engine/camera/camera_model.h"
#include "engine/render/gaussian_scene.h"

namespace pf {

// How a box is grown for membership tests. Tracked boxes often fit the
// actor's surface exactly (synth) or loosely cut it (detections), so points
// on the actor fall just outside them; growing the box catches them. The
// bottom face (box -z, boxes are z-up) is raised instead, so that the road
// the actor stands on stays static.
struct BoxMargin {
  double grow = 0.0;         // Metres added to the sides and the top.
  double floor_raise = 0.0;  // Metres the bottom face is raised.
};

// The margins reconstruction uses.
inline constexpr BoxMargin kMembershipMargin{0.15, 0.05};

// Returns true if world point `p` lies inside `box` changed by `margin`:
// |x| <= l/2 + grow, |y| <= w/2 + grow, -h/2 + floor_raise <= z <= h/2 + grow
// in the box frame.
bool PointInBox(const Vec3& p, const TrackBox& box, const BoxMargin& margin = {});

// A track whose boxes all lie within kStillCentre metres (centre) and
// kStillAngle radians (rotation) of its first: an actor that does not move
// over the clip (a parked car; a track of one box, which every time holds,
// too). Reconstruction
// samples, fuses and decodes its points as static ones, at the static
// density and with no box pose to misplace them, and then hands the
// Gaussians in its first box to it (AdoptStillInstances), so it can still be
// moved or removed.
inline constexpr double kStillCentre = 0.05;
inline constexpr double kStillAngle = 0.035;  // 2 degrees.
bool IsStillTrack(const InstanceTrack& track);

// Whether the pose (`centre`, `rotation`) lies within kStillCentre and
// kStillAngle of (`first_centre`, `first_rotation`): the rule of
// IsStillTrack, and of a camera that stands still (StillCameraViews).
bool WithinStillReach(const Vec3& first_centre, const Quat& first_rotation, const Vec3& centre,
                      const Quat& rotation);

// The tracks of `tracks` that move (not IsStillTrack), in order: the actors
// whose pixels pf eval's dynamic figures (dynamicPsnr) are taken over.
std::vector<InstanceTrack> MovingTracks(const std::vector<InstanceTrack>& tracks);

// Appends `still` to scene->instances and makes each Gaussian that is static
// (owner 0), not on the far layer (`far`, per Gaussian, may be shorter: not
// far) and inside a still track's first box grown by kMembershipMargin
// belong to it (the first such track). Its mean stays: the first box is the
// canonical frame, and the track's boxes do not move. Returns how many
// Gaussians each of `still` took, in order.
std::vector<int64_t> AdoptStillInstances(const std::vector<InstanceTrack>& still,
                                         const std::vector<uint8_t>& far, GaussianScene* scene);

// Returns the canonical-from-world transform of `track` at `timestamp_us`:
// the inverse of InstancePoseAt(track.boxes, timestamp_us).
Rigid CanonicalFromWorld(const InstanceTrack& track, int64_t timestamp_us);

// Returns the 1-based owner (index into `tracks` plus one) of world point
// `p` at `timestamp_us`, or 0 when it is in no box. With overlapping boxes the
// first track wins. Tracks without boxes own nothing.
uint32_t OwnerAt(const Vec3& p, const std::vector<InstanceTrack>& tracks, int64_t timestamp_us,
                 const BoxMargin& margin = {});

// The boxes of every track at one time, ready for many queries.
class BoxesAt {
 public:
  BoxesAt(const std::vector<InstanceTrack>& tracks, int64_t timestamp_us);
  // As OwnerAt().
  uint32_t Owner(const Vec3& p, const BoxMargin& margin = {}) const;
  const std::vector<TrackBox>& boxes() const { return boxes_; }
  // True for tracks with boxes.
  bool valid(size_t k) const { return valid_[k]; }

 private:
  std::vector<TrackBox> boxes_;
  std::vector<bool> valid_;
  // Per box, the rotation PointInBox takes it to its frame by, and the
  // squared distance from its centre to its farthest corner: a point farther
  // than that (with the margin) is in no box without the exact test.
  std::vector<Mat3> box_from_world_;
};

// Returns the dynamic mask of a view: [H, W] bytes, mask[y * W + x] = owner
// (1-based, saturated at 255) of the nearest box that the ray through pixel
// centre (x + 0.5, y + 0.5) crosses at `timestamp_us`, 0 where it crosses
// none. Boxes are grown by `margin` metres. Exact ray/box slab tests, so
// boxes partly behind the camera are handled.
std::vector<uint8_t> DynamicMask(const CameraModel& camera, const Rigid& world_from_camera,
                                 const std::vector<InstanceTrack>& tracks, int64_t timestamp_us,
                                 double margin = 0.0);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_SCENE_GRAPH_H_
