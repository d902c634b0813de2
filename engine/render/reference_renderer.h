// A slow, obviously-correct Gaussian renderer for the rasterizer's tests.
//
// For every pixel it walks every Gaussian in depth order and composites the
// ones whose alpha reaches 1/255, in double precision, with no tiles, no
// extents and no early-outs other than the transmittance stop that the
// specification itself has. The fast Render() must match it.
#ifndef POINTFORWARD_ENGINE_RENDER_REFERENCE_RENDERER_H_
#define POINTFORWARD_ENGINE_RENDER_REFERENCE_RENDERER_H_

#include <cstdint>
#include <vector>

#include "engine/render/rasterizer.h"

namespace pf::testing {

// Renders like Render() (same conventions and outputs, stats left zero).
// Edits must name existing instances (the test's responsibility); a rolling
// shutter is not modelled (the camera's pose is the whole image's). If
// `ambiguous` is given it receives [H, W] flags for pixels whose result hangs
// on a threshold by a hair (an alpha within 2e-5 relative of 1/255, a
// transmittance within 1e-4 relative of 1e-4, two largest weights within
// 1e-5 relative): there float and double may rightly disagree, so tests
// leave those pixels out (and check that they are rare).
RenderBuffers ReferenceRender(const GaussianScene& scene, const RenderCamera& camera,
                              int64_t timestamp_us, const std::vector<ActorEdit>& edits,
                              const RenderOptions& options = {},
                              std::vector<uint8_t>* ambiguous = nullptr);

}  // namespace pf::testing

#endif  // POINTFORWARD_ENGINE_RENDER_REFERENCE_RENDERER_H_
