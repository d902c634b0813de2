// The reconstruction's depth stage (DESIGN.md section 3, step 1) as one
// call: each CONTEXT view's measured depth (view_depth.h: a dense depth map,
// or sparse measurements completed with the ground plane), facades above the
// highest measurements (facade_depth.h), a plane sweep over the pixels still
// unknown (stereo_depth.h) and the depth below continued up where the other
// views agree (facade_depth.h), the gaps these leave enclosed by known depth
// (FillEnclosedGaps), then the far layer for the rest.
// The reconstruction and `pf depth-eval` (depth_holdout.h) both run it.
//
//   DepthStage stage = MeasureViewDepths(views, sweeps, tracks, options);
//   std::vector<ViewDepth> depths = AddFarLayer(views, &stage);
#ifndef POINTFORWARD_ENGINE_RECON_DEPTH_STAGE_H_
#define POINTFORWARD_ENGINE_RECON_DEPTH_STAGE_H_

#include <cstdint>
#include <vector>

#include "engine/recon/context_views.h"
#include "engine/recon/view_depth.h"

namespace pf {

struct DepthStage {
  std::vector<ImageF> measured;         // [H, W] per view, 0 unknown (before the far layer).
  std::vector<MeasuredSource> sources;  // What each view's depth started from.
  std::vector<GroundPlane> grounds;     // Each completed view's ground plane.
  int lidar_views = 0;                  // Views completed from a LiDAR sweep.
  int sparse_map_views = 0;             // Views completed from a sparse depth map.
  int64_t ground_pixels = 0;            // Pixels the ground fill set, in all views.
  int64_t facade_pixels = 0;            // Pixels facades set, in all views.
  int64_t stereo_pixels = 0;            // Pixels the plane sweep set, in all views.
  int64_t upward_pixels = 0;            // Pixels ExtendUpward set, in all views.
  int64_t enclosed_pixels = 0;          // Pixels FillEnclosedGaps set, in all views.
  // Set by AddFarLayer: views with no known pixel off the ego body, and the
  // far layer.
  int views_without_depth = 0;
  FarLayer far;
};

// Measures the depth of every view: MeasuredDepth by `options`, then, with
// `options.facades`, ExtendFacades over the completed views, and with
// `options.stereo`, ExtendByStereo, ExtendUpward and FillEnclosedGaps over
// them.
DepthStage MeasureViewDepths(const std::vector<ContextView>& views,
                             const std::vector<LidarSweepData>& sweeps,
                             const std::vector<InstanceTrack>& tracks,
                             const CompletionOptions& options);

// For every view v with `extend[v]`, sets each unknown pixel of
// `(*measured)[v]` off the view's ego body that has a known pixel within
// `max_gap_px` in each of the four directions along its row and column
// (the sky and leaves between a crown's measured leaves, a gap the sweep
// left in a facade) to the deepest of those four depths: on the far layer
// such a pixel is drawn hundreds of metres behind the surfaces around it,
// where every other view sees it slide across them. Pixels open to one
// side (the sky above a roof line, beyond a tree's outline) stay unknown.
// Returns how many pixels it set.
int64_t FillEnclosedGaps(const std::vector<ContextView>& views, const std::vector<bool>& extend,
                         std::vector<ImageF>* measured, int max_gap_px = 64);

// Returns each view's depth with its unknown pixels on the far layer
// (FarLayerFor over the views' deepest measured non-ego pixels), which it
// records in `stage->far`, with `stage->views_without_depth`; frees
// `stage->measured` as it goes.
std::vector<ViewDepth> AddFarLayer(const std::vector<ContextView>& views, DepthStage* stage);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_DEPTH_STAGE_H_
