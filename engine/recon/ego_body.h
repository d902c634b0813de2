// The ego vehicle's body in the context images, found from the images and
// their depth: pixels that stay the same in a camera's frames while the rig
// moves, where the scene behind them (the pixel's depth, lifted and seen from
// the other frame) would have changed. The reconstruction lifts none of them
// (ContextView::ego) and keeps them as the scene's ego layer of the camera
// (EgoLayer, drawn over every render of it).
//
//   std::vector<EgoLayer> layers = DetectEgoBodies(views, depths, tracks);
//
// Per camera, over the pairs of its CONTEXT frames at least
// `min_travel_m` apart (each frame with the one farthest from it; a camera
// with many frames in runs of `run_frames`, the body where at least half of
// the runs find it), on images reduced to about `work_width` pixels across
// (block means):
// - still: the 5x5 mean of |frame a - frame b| at the same pixel is under
//   `still_threshold` (sRGB-like units; every pair);
// - moved: in either direction, the pixel lifted with its frame's depth and
//   seen in the other frame differs by more than max(`moved_threshold`,
//   `moved_ratio` x still) (5x5 mean; some pair). Says nothing: a pixel on
//   the far layer or in a box (moving actors) in either frame, seen outside
//   the other frame, hidden there (the other frame's depth is under 0.9 of
//   the point's), seen on a block the same in both frames and not
//   near-white (the body may hide it), or near-white itself (every channel
//   >= 0.9 in either frame: an overexposed road, or a white body, looks the
//   same from anywhere);
// - still patches, for a body about the colour of what it hides (a white
//   trunk over grey asphalt): in either direction, a textured 7x7-block
//   patch (grey std-dev >= 0.03) that the depth moves at least 3 blocks and
//   that the other frame sees, unhidden, at no less than 0.67 of its size,
//   whose mean difference from the other frame at the same place is under a
//   third of that where each of its blocks lands (itself >= 0.03); on the
//   still pixels connected to the bottom row, not on the far layer or in a
//   box;
// - the body: the still pixels connected to the image's bottom row, of those
//   the moved ones where most (half) of the 7x7 blocks around are too (a
//   lone block is noise: the edge of a thin line seen at two scales), closed
//   by 2 blocks, grown by 2 blocks into blocks still on their own (not by
//   the 5x5 mean), continued from its side edges along its rows across
//   blocks in a box in a frame of a pair that are still (by the 5x5 mean
//   and connected to the bottom row, or on their own: a box takes the
//   evidence away, and a body in front of a moving car would end at the
//   box's edge), and down its columns across still blocks (below the body
//   there is only body); each column filled down from its topmost body
//   block when at least three quarters of that span is body (the body rises
//   from the bottom), gaps in a row between two stretches of body narrower
//   than a fifth of the image filled, and between the body and the image's
//   side narrower than a twentieth (a curved corner mirrors the street),
//   and the enclosed holes (a hole open only to
//   the bottom row counts as enclosed); of that, the parts that reach the
//   bottom row; and below each run of still patches in the lower half of
//   the image at least a quarter of its width long, every column it covers
//   from its edge (the first strong grey step under the run's top) down,
//   where three quarters of that is still and connected to the bottom row
//   (a lone edge given a wrong depth is short); and below each run of moved
//   blocks in the lower half of the image at least half its width long, the
//   blocks that are not still where most of the 7x7 around are not either (a
//   body that mirrors the street changes between frames, and the motion
//   explains none of its outline). Kept when it holds at least `min_area` of
//   the image.
// A camera with a mask of its own (Camera.ego_mask) keeps it; its layer is
// that mask. The layer's colour is the mean of the camera's CONTEXT images,
// and its frames the body in each of them (EgoLayer::frames), which renders
// draw by their time.
#ifndef POINTFORWARD_ENGINE_RECON_EGO_BODY_H_
#define POINTFORWARD_ENGINE_RECON_EGO_BODY_H_

#include <vector>

#include "engine/recon/context_views.h"
#include "engine/recon/view_depth.h"
#include "engine/render/gaussian_scene.h"

namespace pf {

struct EgoBodyOptions {
  double min_travel_m = 0.6;
  int work_width = 480;
  float still_threshold = 0.03f;
  float moved_threshold = 0.15f;
  float moved_ratio = 2.f;
  double min_area = 0.002;
  // A camera with at least twice this many CONTEXT frames is searched in
  // runs of this many consecutive frames, and a block is body where at least
  // half of the runs that had a pair find it: a body that mirrors the street
  // changes over a long drive, but stays within a short one. 0: one search
  // over all its frames.
  int run_frames = 4;
};

// One layer per camera whose body was found (or that has its own mask), in
// the order of the cameras' first views. `depths` are the views' (the depth
// stage's, with the far layer).
std::vector<EgoLayer> DetectEgoBodies(const std::vector<ContextView>& views,
                                      const std::vector<ViewDepth>& depths,
                                      const std::vector<InstanceTrack>& tracks,
                                      const EgoBodyOptions& options = {});

// Sets the ego mask of every view of a layer's camera to the layer's mask
// (ContextView::ego).
void SetEgoMasks(const std::vector<EgoLayer>& layers, std::vector<ContextView>* views);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_EGO_BODY_H_
