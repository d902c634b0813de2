// The scene's render blur (GaussianScene::render_blur, grown away from the
// CONTEXT views by render_blur_growth): a Gaussian blur of a render's
// premultiplied colour, features and alpha, for detail a scene draws but
// cannot place at new views (docs/QUALITY.md, "Render blur").
//
//   BlurRender(RenderBlurAt(scene, camera), &buffers);
#ifndef POINTFORWARD_ENGINE_RENDER_RENDER_BLUR_H_
#define POINTFORWARD_ENGINE_RENDER_RENDER_BLUR_H_

#include <string>
#include <vector>

#include "absl/status/status.h"
#include "engine/render/gaussian_scene.h"
#include "engine/render/rasterizer.h"

namespace pf {

// A view's distance from a blur anchor: metres between the centres plus
// kBlurAnchorMetresPerRadian per radian between the optical axes.
inline constexpr float kBlurAnchorMetresPerRadian = 1.f;
// The most a blur grows to (pixels).
inline constexpr float kMaxGrownRenderBlur = 3.f;

// The blur of a render of `scene` from `camera` (std-dev, pixels):
// scene.render_blur, or more where the camera is far from every blur anchor:
// focal length x render_blur_growth (mrad/m) x the distance to the nearest
// anchor, up to kMaxGrownRenderBlur (never less than render_blur). The
// actors keep render_blur (DeviceRenderer: BlurRender with actor_sigma).
float RenderBlurAt(const GaussianScene& scene, const RenderCamera& camera);

// The blur anchor of a camera at `world_from_camera`: its centre and unit
// optical axis (+z of the camera).
BlurAnchor BlurAnchorOf(const Rigid& world_from_camera);

// INVALID_ARGUMENT naming `field` for an anchor with a coordinate that is not
// finite or an axis whose length is not 1 (within 1e-3).
absl::Status CheckBlurAnchor(const BlurAnchor& anchor, const std::string& field);

// Blurs `channels`-channel interleaved `image` ([height, width, channels]) in
// place by a Gaussian of std-dev `sigma` pixels, separable, truncated at
// 3 sigma and renormalised at the image's edges (no pixel from outside).
// Nothing changes for sigma <= 0.
void BlurImage(float sigma, int width, int height, int channels, std::vector<float>* image);

// Blurs the rgb, features and alpha of `buffers` (what is there) by `sigma`;
// depth and instance ids are left as rendered.
void BlurRender(float sigma, RenderBuffers* buffers);

// BlurRender(sigma) away from the actors and BlurRender(actor_sigma) on them
// (actor_sigma < sigma): mixed by the share of actor pixels (instance id
// over 0) around each pixel, that share blurred by sigma. Without instance
// ids, or none over 0, BlurRender(sigma).
void BlurRender(float sigma, float actor_sigma, RenderBuffers* buffers);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RENDER_RENDER_BLUR_H_
