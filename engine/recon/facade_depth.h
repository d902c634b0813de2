// Depth above the LiDAR's top beam (DESIGN.md section 3, step 1): a
// spinning LiDAR's beams stop some degrees above the horizontal, so the
// upper floors of nearby buildings get no point and would go to the far
// layer, hundreds of metres away, where every other view sees them slide
// against the floors below. Building fronts are vertical planes: where the
// highest measured points of a column of the image lie on one (a line when
// seen from above), the pixels above them may continue it, up to the roof.
// Whether a pixel does is asked of the other context views: its colour patch
// is compared with what another view sees at the plane's point and at the
// far point along the same ray, and the plane is taken only where it matches
// clearly better. Scanning up a column stops after a few pixels where the
// far point matches better (the sky above the roof), so the sky, and flat
// walls that cannot be told apart, stay on the far layer. What no plane
// explains (a tree's crown) may take the depth of the surface below it,
// asked the same way (ExtendUpward, after the plane sweep).
//
//   std::vector<ImageF> measured = ...;  // MeasuredDepth per view, 0 unknown
//   ExtendFacades(views, lidar_views, grounds, &measured);
//   ExtendUpward(views, lidar_views, &measured);
#ifndef POINTFORWARD_ENGINE_RECON_FACADE_DEPTH_H_
#define POINTFORWARD_ENGINE_RECON_FACADE_DEPTH_H_

#include <cstdint>
#include <vector>

#include "engine/recon/context_views.h"
#include "engine/recon/view_depth.h"

namespace pf {

struct FacadeOptions {
  int window_px = 6;            // Half width of the columns whose top points make the plane.
  int band_px = 6;              // Rows of each column's top counted as its top points.
  double max_plane_rms = 0.15;  // Metres: the top points' spread off their vertical plane.
  double min_height = 0.5;      // Metres above the ground for a top point to count.
  double max_rise = 40.0;       // Metres above the highest top point a facade may go.
  double min_baseline = 0.5;    // Metres between a view and the views that check it.
  int partners = 2;             // Views that check each view.
  double accept_ratio = 0.6;    // Plane's patch cost below this x the far point's: accept.
  double min_contrast = 0.03;   // Far point's mean absolute difference below this: no test.
  int stop_after = 3;           // Consecutive rejections that end a column's scan.
};

// For every view v with `extend[v]` (LiDAR views; depth maps are complete)
// and a valid `grounds[v]` (its "up"), sets the unknown pixels of
// `(*measured)[v]` above each column's highest known pixel that the plane of
// that column's facade explains better than the far layer (see above), up
// to the last such pixel of the column. Returns how many pixels it set, in
// all views. Views are checked against the `partners` other views nearest
// to them whose cameras are at least `min_baseline` away; a colour patch
// that touches a view's ego body (ContextView::ego) is no evidence.
int64_t ExtendFacades(const std::vector<ContextView>& views, const std::vector<bool>& extend,
                      const std::vector<GroundPlane>& grounds, std::vector<ImageF>* measured,
                      const FacadeOptions& options = {});

// The depth below a run of unknown pixels, continued up it: a tree's crown
// above the LiDAR's hits on its lower leaves, the part of a pole or a sign
// between two measured ones. The plane sweep leaves such pixels unknown
// where no depth is clearly best; one depth, that of the surface just
// below, is asked instead, as ExtendFacades asks of its plane.
struct UpwardOptions {
  int window_px = 6;           // Half width of the columns whose known pixels give the depth.
  int band_px = 6;             // Rows under the run counted.
  double min_baseline = 0.5;   // Metres between a view and the views that check it.
  int partners = 2;            // Views that check each view.
  double accept_ratio = 0.6;   // Patch cost at the depth below this x the far point's: set.
  double min_contrast = 0.03;  // Far point's mean absolute difference below this: no test.
  int stop_after = 30;         // Consecutive rejections that end a run's scan.
};

// For every view v with `extend[v]`, scans each column of `(*measured)[v]`
// upwards; each run of unknown pixels directly above a known one takes the
// median depth of the known pixels in the `band_px` rows under it (of the
// columns within `window_px`, at least 8 of them), pixel by pixel, where the
// `partners` views nearest to v at least `min_baseline` away match the
// pixel's 3x3 colour patch at that depth clearly better than at the far
// point along its ray (PatchCost, as ExtendFacades); after `stop_after`
// pixels in a row that the far point matches better (the sky above a crown)
// the run's scan ends. Pixels where the far point's patch is as flat as the
// pixel's (the sky, a blank wall) are left unknown. Returns how many pixels
// it set, in all views.
int64_t ExtendUpward(const std::vector<ContextView>& views, const std::vector<bool>& extend,
                     std::vector<ImageF>* measured, const UpwardOptions& options = {});

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_FACADE_DEPTH_H_
