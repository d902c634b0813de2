// Colour refinement against the context views: the last step of the
// analytic decoder. Splatting blurs (each Gaussian's footprint, the
// rasterizer's 0.3 px low-pass, front-to-back compositing of overlapping
// discs), so fused colours rendered back into their own views come out
// softer than the images they came from. Each iteration renders every
// context view at its own pose and time and moves each Gaussian's colour
// by `step` times the residual (image - render / alpha) at its source pixel
// (a Jacobi step of the least-squares fit of the colours to the context
// images). Only CONTEXT images are used; geometry, opacity and time are not
// touched. Pixels the render barely covers (alpha < min_alpha) are skipped.
#ifndef POINTFORWARD_WORKER_ENGINE_RECON_COLOUR_REFINEMENT_H_
#define POINTFORWARD_WORKER_ENGINE_RECON_COLOUR_REFINEMENT_H_

#include <vector>

#include "absl/status/status.h"
#include "worker/engine/recon/context_views.h"
#include "worker/engine/recon/query_set.h"
#include "worker/engine/render/gaussian_scene.h"

namespace pf {

struct RefinementOptions {
  int iterations = 2;
  double step = 0.5;  // 1.0 overshoots where Gaussians of several views overlap.
  double min_alpha = 0.5;
  float min_colour = -0.5f;  // Colours are kept in [min_colour, max_colour].
  float max_colour = 1.5f;
};

// Refines the first three feature channels of `scene` in place. Gaussian i
// came from pixel queries.pixels[i] of views[queries.views[i]].
// INVALID_ARGUMENT when `queries` and `scene` differ in size; errors of
// Render otherwise.
absl::Status RefineColours(const std::vector<ContextView>& views, const QuerySet& queries,
                           const RefinementOptions& options, GaussianScene* scene);

}  // namespace pf

#endif  // POINTFORWARD_WORKER_ENGINE_RECON_COLOUR_REFINEMENT_H_
