// The ego vehicle's body in renders: a scene's EgoLayer (gaussian_scene.h)
// is drawn over every render of its camera, as the recorded frames show it.
//
//   if (const EgoLayer* ego = FindEgoLayer(scene, view.camera_id)) {
//     ApplyEgoLayer(*ego, &buffers);
//   }
#ifndef POINTFORWARD_ENGINE_RENDER_EGO_LAYER_H_
#define POINTFORWARD_ENGINE_RENDER_EGO_LAYER_H_

#include <string>

#include "engine/render/gaussian_scene.h"
#include "engine/render/rasterizer.h"

namespace pf {

// The layer of camera `camera_id` in `scene`, or null.
const EgoLayer* FindEgoLayer(const GaussianScene& scene, const std::string& camera_id);

// Draws the body over `buffers` where the layer's size is the render's (a
// render of another size, e.g. a resized camera, is left as it is; returns
// false then): on its pixels rgb is the body's colour, alpha 1, depth 0 (the
// body's depth is unknown), instance 0, and the feature channels the colour
// in the first three, 0 in the rest.
bool ApplyEgoLayer(const EgoLayer& layer, RenderBuffers* buffers);

// Checks a layer: a camera id, a positive size, a mask of W x H and a colour
// of W x H x 3 (finite). INVALID_ARGUMENT naming `field`.
absl::Status CheckEgoLayer(const EgoLayer& layer, const std::string& field);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RENDER_EGO_LAYER_H_
