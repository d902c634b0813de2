#include "engine/render/ego_layer.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"

namespace pf {

const EgoLayer* FindEgoLayer(const GaussianScene& scene, const std::string& camera_id) {
  for (const EgoLayer& layer : scene.ego_layers) {
    if (layer.camera_id == camera_id) return &layer;
  }
  return nullptr;
}

std::vector<float> MeanBodyColours(const EgoLayer& layer) {
  std::vector<float> colours;
  for (size_t i = 0; i < layer.mask.size(); ++i) {
    if (layer.on_body(i)) colours.insert(colours.end(), &layer.rgb[i * 3], &layer.rgb[i * 3 + 3]);
  }
  return colours;
}

std::vector<float> EgoColoursAt(const EgoLayer& layer, int64_t timestamp_us) {
  if (layer.frames.empty()) return MeanBodyColours(layer);
  std::vector<float> colours;
  // The first frame at or after the time; the one before it mixed in.
  const auto after = std::lower_bound(
      layer.frames.begin(), layer.frames.end(), timestamp_us,
      [](const EgoLayer::Frame& frame, int64_t t) { return frame.timestamp_us < t; });
  if (after == layer.frames.begin()) return after->rgb;
  if (after == layer.frames.end()) return layer.frames.back().rgb;
  const EgoLayer::Frame& before = *(after - 1);
  const float share = static_cast<float>(double(timestamp_us - before.timestamp_us) /
                                         double(after->timestamp_us - before.timestamp_us));
  colours.resize(before.rgb.size());
  for (size_t k = 0; k < colours.size(); ++k) {
    colours[k] = before.rgb[k] + share * (after->rgb[k] - before.rgb[k]);
  }
  return colours;
}

bool ApplyEgoLayer(const EgoLayer& layer, int64_t timestamp_us, RenderBuffers* buffers) {
  if (layer.width != buffers->width || layer.height != buffers->height) return false;
  const std::vector<float> colours = EgoColoursAt(layer, timestamp_us);
  const size_t pixels = static_cast<size_t>(layer.width) * layer.height;
  const int channels = buffers->channels;
  const bool features = !buffers->features.empty();
  size_t next = 0;  // The body pixel's index in `colours`.
  for (size_t i = 0; i < pixels; ++i) {
    if (!layer.on_body(i)) continue;
    const float* rgb = &colours[3 * next++];
    for (int c = 0; c < 3; ++c) {
      if (!buffers->rgb.empty()) buffers->rgb[i * 3 + c] = rgb[c];
    }
    if (!buffers->alpha.empty()) buffers->alpha[i] = 1.f;
    if (!buffers->depth.empty()) buffers->depth[i] = 0.f;
    if (!buffers->instance.empty()) buffers->instance[i] = 0;
    if (features) {
      for (int c = 0; c < channels; ++c) {
        buffers->features[i * channels + c] = c < 3 ? rgb[c] : 0.f;
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
  const uint64_t body = layer.body_pixels();
  for (size_t k = 0; k < layer.frames.size(); ++k) {
    const EgoLayer::Frame& frame = layer.frames[k];
    if (k > 0 && frame.timestamp_us <= layer.frames[k - 1].timestamp_us) {
      return absl::InvalidArgumentError(absl::StrCat(field, ".frames[", k, "]: time ",
                                                     frame.timestamp_us, " us is not after ",
                                                     layer.frames[k - 1].timestamp_us, " us"));
    }
    if (frame.rgb.size() != body * 3) {
      return absl::InvalidArgumentError(absl::StrCat(field, ".frames[", k, "]: ", frame.rgb.size(),
                                                     " colours for ", body,
                                                     " body pixels (3 each)"));
    }
    for (float v : frame.rgb) {
      if (!std::isfinite(v)) {
        return absl::InvalidArgumentError(
            absl::StrCat(field, ".frames[", k, "]: a colour is not finite"));
      }
    }
  }
  return absl::OkStatus();
}

}  // namespace pf
