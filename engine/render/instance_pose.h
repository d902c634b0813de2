// Where a tracked actor is at a time: its box track interpolated (linear
// centre and size, slerp rotation between the two nearest boxes; the end box
// held outside the track) and the transform that moves its Gaussians from
// the canonical frame (its first box) to the world.
#ifndef POINTFORWARD_ENGINE_RENDER_INSTANCE_POSE_H_
#define POINTFORWARD_ENGINE_RENDER_INSTANCE_POSE_H_

#include <cstdint>
#include <vector>

#include "common/geometry.h"
#include "engine/render/gaussian_scene.h"

namespace pf {

// The box's pose (rotation, centre) as a rigid transform: world from box.
Rigid BoxPose(const TrackBox& box);

// Returns the box (centre, rotation, size) of `boxes` (sorted by time)
// interpolated at `timestamp_us`; the end box outside the track.
TrackBox InterpolateBox(const std::vector<TrackBox>& boxes, int64_t timestamp_us);

// Returns the world-from-canonical transform of `track` at `timestamp_us`:
// box pose at t' composed with the inverse of the first box's pose. Holds the
// end box outside the track.
Rigid InstancePoseAt(const std::vector<TrackBox>& boxes, int64_t timestamp_us);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RENDER_INSTANCE_POSE_H_
