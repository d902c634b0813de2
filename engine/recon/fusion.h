// Spatial-temporal fusion (paper section 3.3), the analytic version: every
// query is projected into every context view (an instance's queries first
// move from the canonical frame to the world by the box pose at that view's
// time) and the view's colour there is an observation of it.
//
// For a query at z depth z in view i, with the view's depth D_i at that
// pixel, the relative depth difference is d_i = (z - D_i) / z:
//   |d_i| <= visibility_tolerance   the view sees the query: an observation;
//   d_i >  visibility_tolerance     something is in front: occluded, ignored;
//   d_i < -visibility_tolerance     the view sees past it (also for every
//                                   pixel in a 3x3 neighbourhood): evidence
//                                   that the point was not there at t_i.
// Static queries are zeroed in views whose dynamic mask covers the pixel
// (except their own source view). Every query, under every weighting, is
// zeroed in a view whose pixel is on the ego vehicle's body
// (ContextView::ego); body pixels give no colour to the bilinear sample and
// block the 3x3 "sees past" test. Far-layer queries agree with far-layer
// pixels and are occluded by anything else.
//
// Weights are a softmax over the observing views of -|d_i| / tau, each
// also scaled by (z_source / z_i)^2 when resolution_weighting is on (a view
// that sees the point from twice as far sees it at half the resolution); the
// fused colour is the weighted mean of the bilinearly sampled colours. Agreement is
// observations / (observations + contradictions), the source view included.
// Lifespan (FusionOptions::lifespan, off by default; otherwise every one is
// +inf): +inf (never fades) for dynamic queries and for static ones no
// view contradicts; otherwise the largest time gap between the query's own
// view and a view that observes it, in seconds (so it fades away from the
// times it was seen, exp(-0.5 ((t' - t) / (sigma + 1))^2) at render time).
#ifndef POINTFORWARD_ENGINE_RECON_FUSION_H_
#define POINTFORWARD_ENGINE_RECON_FUSION_H_

#include <cstdint>
#include <vector>

#include "engine/recon/context_views.h"
#include "engine/recon/query_set.h"
#include "engine/recon/view_depth.h"
#include "engine/render/gaussian_scene.h"

namespace pf {

// How the observations of a query are weighed (the paper's table 5
// ablations).
enum class FusionWeights {
  kDepthSoftmax,  // softmax of -|d_i| / tau over the observing views (default)
  kPlainAverage,  // equal weights over the observing views
  kNoDepth,       // equal weights over every view the query projects into,
                  // unmasked, with no depth test (occluded views included)
};

struct FusionOptions {
  FusionWeights weights = FusionWeights::kDepthSoftmax;
  double tau = 0.01;                   // Softmax temperature on relative |d_i|.
  double visibility_tolerance = 0.03;  // Relative |d_i| of an observation.
  bool lifespan = false;               // false: every lifespan is +inf.
  bool resolution_weighting = true;    // Prefer views that see the point closer.
};

// The fused queries, aligned with the QuerySet.
struct FusedQueries {
  std::vector<float> rgb;              // [N, 3]
  std::vector<float> agreement;        // [N] in (0, 1]
  std::vector<float> lifespans;        // [N] seconds, +inf never fades
  std::vector<uint16_t> observations;  // [N] views that contributed
};

// One view as fusion sees it.
struct FusionView {
  const ContextView* view = nullptr;
  const ViewDepth* depth = nullptr;
  const std::vector<uint8_t>* mask = nullptr;  // [H, W] DynamicMask at the view's time
};

// Returns fused queries for `n` queries before any view is seen: colour 0,
// agreement 1, lifespan +inf, no observation.
FusedQueries NewFusedQueries(size_t n);

// Fuses every query of `queries` over `views`. `tracks` place instance
// queries at each view's time.
FusedQueries FuseQueries(const QuerySet& queries, const std::vector<FusionView>& views,
                         const std::vector<InstanceTrack>& tracks, const FusionOptions& options);

// Returns the queries' own colours, agreement 1 and lifespan +inf: no fusion
// (the pixel-aligned model).
FusedQueries UnfusedQueries(const QuerySet& queries);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_FUSION_H_
