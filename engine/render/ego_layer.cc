#include "engine/render/ego_layer.h"

#include <cmath>

#include "absl/strings/str_cat.h"

namespace pf {

const EgoLayer* FindEgoLayer(const GaussianScene& scene, const std::string& camera_id) {
  for (const EgoLayer& layer : scene.ego_layers) {
    if (layer.camera_id == camera_id) return &layer;
  }
  return nullptr;
}

bool ApplyEgoLayer(const EgoLayer& layer, RenderBuffers* buffers) {
  if (layer.width != buffers->width || layer.height != buffers->height) return false;
  const size_t pixels = static_cast<size_t>(layer.width) * layer.height;
  const int channels = buffers->channels;
  const bool features = !buffers->features.empty();
  for (size_t i = 0; i < pixels; ++i) {
    if (!layer.on_body(i)) continue;
    for (int c = 0; c < 3; ++c) {
      if (!buffers->rgb.empty()) buffers->rgb[i * 3 + c] = layer.rgb[i * 3 + c];
    }
    if (!buffers->alpha.empty()) buffers->alpha[i] = 1.f;
    if (!buffers->depth.empty()) buffers->depth[i] = 0.f;
    if (!buffers->instance.empty()) buffers->instance[i] = 0;
    if (features) {
      for (int c = 0; c < channels; ++c) {
        buffers->features[i * channels + c] = c < 3 ? layer.rgb[i * 3 + c] : 0.f;
      }
    }
  }
  return true;
}

absl::Status CheckEgoLayer(const EgoLayer& layer, const std::string& field) {
  if (layer.camera_id.empty())
    return absl::InvalidArgumentError(absl::StrCat(field, ": no camera id"));
  if (layer.width <= 0 || layer.height <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": size ", layer.width, "x", layer.height, " is not positive"));
  }
  const size_t pixels = static_cast<size_t>(layer.width) * layer.height;
  if (layer.mask.size() != pixels || layer.rgb.size() != pixels * 3) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": mask or colour is not ", layer.width, "x", layer.height));
  }
  for (float v : layer.rgb) {
    if (!std::isfinite(v))
      return absl::InvalidArgumentError(absl::StrCat(field, ": a colour is not finite"));
  }
  return absl::OkStatus();
}

}  // namespace pf
