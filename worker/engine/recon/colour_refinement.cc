// Jacobi refinement of Gaussian colours against the context images.
#include "worker/engine/recon/colour_refinement.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "common/status_macros.h"
#include "common/thread_pool.h"
#include "worker/engine/render/rasterizer.h"

namespace pf {

absl::Status RefineColours(const std::vector<ContextView>& views, const QuerySet& queries,
                           const RefinementOptions& options, GaussianScene* scene) {
  const size_t n = scene->size();
  if (queries.size() != n) {
    return absl::InvalidArgumentError(
        absl::StrCat("RefineColours: ", queries.size(), " queries for ", n, " Gaussians"));
  }
  // Gaussians by source view, so each render is used once.
  std::vector<std::vector<int64_t>> by_view(views.size());
  for (size_t i = 0; i < n; ++i) by_view[queries.views[i]].push_back(static_cast<int64_t>(i));
  RenderOptions render_options;
  render_options.features = false;
  render_options.depth = false;
  render_options.instance = false;
  const int channels = scene->num_channels;
  std::vector<float> delta(n * 3, 0.f);
  for (int iteration = 0; iteration < options.iterations; ++iteration) {
    std::fill(delta.begin(), delta.end(), 0.f);
    for (size_t v = 0; v < views.size(); ++v) {
      if (by_view[v].empty()) continue;
      const ContextView& view = views[v];
      ASSIGN_OR_RETURN(const RenderBuffers render,
                       Render(*scene, {view.camera, view.world_from_camera}, view.timestamp_us, {},
                              render_options));
      const std::vector<int64_t>& members = by_view[v];
      DefaultThreadPool().ParallelFor(
          0, static_cast<int64_t>(members.size()), 4096, [&](int64_t b, int64_t e) {
            for (int64_t m = b; m < e; ++m) {
              const int64_t i = members[m];
              const size_t pixel = static_cast<size_t>(queries.pixels[i]);
              const float alpha = render.alpha[pixel];
              if (alpha < options.min_alpha) continue;
              for (int c = 0; c < 3; ++c) {
                const float rendered = render.rgb[3 * pixel + c] / alpha;
                delta[3 * i + c] = view.rgb.pixels[3 * pixel + c] - rendered;
              }
            }
          });
    }
    const float step = static_cast<float>(options.step);
    DefaultThreadPool().ParallelFor(0, static_cast<int64_t>(n), 8192, [&](int64_t b, int64_t e) {
      for (int64_t i = b; i < e; ++i) {
        float* feat = &scene->features[static_cast<size_t>(i) * channels];
        for (int c = 0; c < 3; ++c) {
          feat[c] =
              std::clamp(feat[c] + step * delta[3 * i + c], options.min_colour, options.max_colour);
        }
      }
    });
  }
  return absl::OkStatus();
}

}  // namespace pf
