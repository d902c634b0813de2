// The ego vehicle's body in renders: a scene's EgoLayer (gaussian_scene.h)
// is drawn over every render of its camera, as the recorded frames show it.
//
//   if (const EgoLayer* ego = FindEgoLayer(scene, view.camera_id)) {
//     ApplyEgoLayer(*ego, view.timestamp_us, &buffers);
//   }
#ifndef POINTFORWARD_ENGINE_RENDER_EGO_LAYER_H_
#define POINTFORWARD_ENGINE_RENDER_EGO_LAYER_H_

#include <cstdint>
#include <string>
#include <vector>

#include "engine/render/gaussian_scene.h"
#include "engine/render/rasterizer.h"

namespace pf {

// The layer of camera `camera_id` in `scene`, or null.
const EgoLayer* FindEgoLayer(const GaussianScene& scene, const std::string& camera_id);

// Draws the body over `buffers` where the layer's size is the render's (a
// render of another size, e.g. a resized camera, is left as it is; returns
// false then): on its pixels rgb is the body's colour at the render's time
// `timestamp_us` (EgoLayer::frames), alpha 1, depth 0 (the body's depth is
// unknown), instance 0, and the feature channels the colour in the first
// three, 0 in the rest.
bool ApplyEgoLayer(const EgoLayer& layer, int64_t timestamp_us, RenderBuffers* buffers);

// The layer's mean colour (EgoLayer::rgb) of its B body pixels, [B, 3] in
// pixel order (as the scene file stores it).
std::vector<float> MeanBodyColours(const EgoLayer& layer);

// The body's colours at `timestamp_us`, [B, 3] in pixel order: the layer's
// frames either side of it mixed linearly in time (the first frame before
// it, the last after it), or the mean colour where it has no frames.
std::vector<float> EgoColoursAt(const EgoLayer& layer, int64_t timestamp_us);

// Checks a layer: a camera id, a positive size, a mask of W x H, a colour
// of W x H x 3 and frames in strictly ascending time, each of B x 3 colours
// (all finite). INVALID_ARGUMENT naming `field`.
absl::Status CheckEgoLayer(const EgoLayer& layer, const std::string& field);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RENDER_EGO_LAYER_H_
