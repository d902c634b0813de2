// Lifting pixels to the paper's 12-dimensional queries (section 3.1): the
// world point from the pixel's depth and camera, its RGB, and the Plücker
// coordinates (d, o x d) of the pixel's ray, d a unit world direction and o
// the camera centre. Also the local surface normal of each pixel, from its
// neighbours' lifted points, that the Gaussian decoder flattens along.
#ifndef POINTFORWARD_ENGINE_RECON_QUERY_LIFTING_H_
#define POINTFORWARD_ENGINE_RECON_QUERY_LIFTING_H_

#include <array>
#include <cstdint>
#include <vector>

#include "common/geometry.h"
#include "engine/camera/camera_model.h"
#include "engine/recon/context_views.h"
#include "engine/recon/view_depth.h"

namespace pf {

// Returns the Plücker coordinates (d, o x d) of the ray from `origin` along
// `direction` (normalised here).
std::array<float, 6> PluckerRay(const Vec3& origin, const Vec3& direction);

// One query as the paper has it: [x, y, z, r, g, b, d (3), o x d (3)].
using Query12 = std::array<float, 12>;

// Returns the 12-d query of pixel (x, y) of `view` (pixel centre), false when
// it cannot be lifted.
bool LiftQuery(const ContextView& view, const ViewDepth& depth, int x, int y, Query12* query);

// Every pixel of a view lifted to the world.
struct LiftedView {
  int width = 0, height = 0;
  std::vector<float> points;   // [H, W, 3] world
  std::vector<float> normals;  // [H, W, 3] world, unit, facing the camera
  std::vector<uint8_t> valid;  // [H, W] 1 where the pixel could be lifted (never on the ego body)
};

// Lifts every pixel of `view` with `depth`. Normals come from central
// differences of the lifted points, one-sided across depth jumps (the side
// with the smaller relative jump); far-layer pixels face the camera.
LiftedView LiftView(const ContextView& view, const ViewDepth& depth);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_QUERY_LIFTING_H_
