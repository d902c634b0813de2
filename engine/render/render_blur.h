// The scene's render blur (GaussianScene::render_blur): a Gaussian blur of a
// render's premultiplied colour, features and alpha, for detail a scene draws
// but cannot place at new views (docs/QUALITY.md, "Render blur").
//
//   BlurRender(scene.render_blur, &buffers);
#ifndef POINTFORWARD_ENGINE_RENDER_RENDER_BLUR_H_
#define POINTFORWARD_ENGINE_RENDER_RENDER_BLUR_H_

#include <vector>

#include "engine/render/rasterizer.h"

namespace pf {

// Blurs `channels`-channel interleaved `image` ([height, width, channels]) in
// place by a Gaussian of std-dev `sigma` pixels, separable, truncated at
// 3 sigma and renormalised at the image's edges (no pixel from outside).
// Nothing changes for sigma <= 0.
void BlurImage(float sigma, int width, int height, int channels, std::vector<float>* image);

// Blurs the rgb, features and alpha of `buffers` (what is there) by `sigma`;
// depth and instance ids are left as rendered.
void BlurRender(float sigma, RenderBuffers* buffers);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RENDER_RENDER_BLUR_H_
