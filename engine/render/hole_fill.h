// Filling what a render did not cover, for views that need an opaque colour.
//
// A render's rgb is premultiplied: where alpha < 1 part of the pixel saw no
// Gaussian (regions no context view saw, gaps between splats), and composited
// over black that part is black. Pixels with alpha >= covered_alpha count as
// covered: their rgb is what the colour fit matched to the context images
// (colour_refinement.h fits pixels with alpha >= 0.5, over black), so they
// are kept as they are. The others are composited over a background made of
// the render itself, by push-pull (a pyramid of 2x2 box averages of the
// premultiplied colour and the coverage, each level filled from the next
// coarser one, then composited back down): their uncovered part takes the
// coverage-weighted mean colour of the smallest neighbourhood around them
// that was covered, so a hole inside the road is filled with road, one
// between two surfaces with a blend of both. A render with nothing covered
// stays black. It invents no detail: the fill is as smooth as the hole is
// large, and the alpha layer still says where it is.
//
//   std::vector<float> opaque = FillUncovered(buffers.rgb, buffers.alpha,
//                                             buffers.width, buffers.height);
#ifndef POINTFORWARD_ENGINE_RENDER_HOLE_FILL_H_
#define POINTFORWARD_ENGINE_RENDER_HOLE_FILL_H_

#include <vector>

namespace pf {

// A pixel with at least this alpha counts as covered: the colour fit matches
// it to the context images (RefinementOptions::min_alpha), pf eval does not
// count it as a hole, and FillUncovered() keeps it.
inline constexpr float kCoveredAlpha = 0.5f;

// Returns the [H, W, 3] colour of the premultiplied `rgb` ([H, W, 3]) with
// coverage `alpha` ([H, W], clamped to [0, 1]): rgb where alpha >=
// covered_alpha, elsewhere rgb composited over its push-pull fill. Returns
// `rgb` as it is when it or `alpha` holds fewer than width x height pixels.
std::vector<float> FillUncovered(const std::vector<float>& rgb, const std::vector<float>& alpha,
                                 int width, int height, float covered_alpha = kCoveredAlpha);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RENDER_HOLE_FILL_H_
