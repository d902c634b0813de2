// Depth from the context views themselves where no sensor measured it
// (DESIGN.md section 3, step 1): a plane sweep over each view's unknown
// pixels (above the LiDAR's top beam, beyond its reach) against the nearby
// context views. Each pixel's ray is cut at depths evenly spaced in inverse
// depth, about one pixel of parallax apart in the widest pair; at each the
// other views are sampled and compared with the view by normalised
// cross-correlation (NCC) of grey patches, on images reduced to about
// `max_width` pixels across. A pixel takes the best depth only where the
// evidence is clear:
//   - its patch has texture (the sky and flat walls have none: they stay on
//     the far layer);
//   - the NCC there is high, in every view that sees the point (where two
//     views check it, a consistency check between them, not only their
//     mean);
//   - no depth away from the best one scores nearly as well (repeated
//     texture, such as railings, is left alone);
//   - the best depth is not among the sweep's farthest few (under a few
//     pixels of parallax: the far layer's business).
// The NCC of the best depth is the pixel's confidence (StereoStats).
//
//   std::vector<ImageF> measured = ...;  // MeasuredDepth per view, 0 unknown
//   StereoStats stats = ExtendByStereo(views, extend, &measured);
#ifndef POINTFORWARD_ENGINE_RECON_STEREO_DEPTH_H_
#define POINTFORWARD_ENGINE_RECON_STEREO_DEPTH_H_

#include <cstdint>
#include <vector>

#include "engine/recon/context_views.h"
#include "engine/recon/view_depth.h"

namespace pf {

struct StereoOptions {
  int max_width = 480;        // Images are reduced by a whole factor to at most this width.
  int partners = 2;           // Views that check each view.
  double min_baseline = 0.3;  // Metres between a view and the views that check it.
  double max_baseline = 8.0;  // Metres: farther views see too little of the same scene.
  double min_depth = 2.0;     // Metres: the sweep's nearest depth.
  double max_depth = 400.0;   // Metres: its farthest.
  // A best depth fewer than this many planes nearer than the farthest is not
  // told from the far layer (and picks there were mostly wrong:
  // docs/QUALITY.md).
  int far_planes = 3;
  double step_px = 1.0;          // Parallax between neighbouring depths in the widest pair.
  int max_planes = 160;          // The sweep's depths at most.
  int window_radius = 3;         // NCC patch: (2r+1)^2 pixels of the reduced image.
  double min_texture = 0.02;     // Grey std-dev of the patch under which it is not tried.
  double min_ncc = 0.7;          // Mean NCC over the checking views at the best depth.
  double min_partner_ncc = 0.5;  // Each checking view's NCC there.
  // (1 - NCC) of the best depth at most this x that of the best depth at
  // least `unique_planes` planes away.
  double uniqueness = 0.5;
  int unique_planes = 3;
};

struct StereoStats {
  int64_t pixels = 0;      // Pixels (full resolution) the sweep set, in all views.
  int64_t candidates = 0;  // Unknown pixels it tried (full resolution).
  double mean_ncc = 0;     // Mean confidence of the pixels it set.
  int views = 0;           // Views swept (with unknown pixels and a checking view).
};

// For every view v with `extend[v]`, sets the unknown (0), non-ego pixels of
// `(*measured)[v]` where the plane sweep above finds a depth (z, metres).
// Views are checked against the `partners` other views nearest to them whose
// cameras are `min_baseline` to `max_baseline` away and look within 60
// degrees of the same way, the same camera's first; at each depth the
// partners that see the point (inside their image, no patch pixel on their
// ego body) are the checking views, and a pixel none sees there is not
// tried at that depth. Deterministic: the result does not depend on the
// thread count.
StereoStats ExtendByStereo(const std::vector<ContextView>& views, const std::vector<bool>& extend,
                           std::vector<ImageF>* measured, const StereoOptions& options = {});

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_STEREO_DEPTH_H_
