// For LiDAR tests: a scene given a LiDAR intensity channel.
#ifndef POINTFORWARD_ENGINE_RENDER_LIDAR_TESTING_H_
#define POINTFORWARD_ENGINE_RENDER_LIDAR_TESTING_H_

#include <cstddef>
#include <utility>
#include <vector>

#include "engine/render/gaussian_scene.h"

namespace pf::testing {

// Appends a feature channel to `scene`, `value(i)` for Gaussian i, and makes
// it the scene's LiDAR intensity channel.
template <typename Value>
void AddIntensityChannel(GaussianScene* scene, Value value) {
  const int old = scene->num_channels, stride = old + 1;
  std::vector<float> features(static_cast<size_t>(stride) * scene->size());
  for (size_t i = 0; i < scene->size(); ++i) {
    for (int c = 0; c < old; ++c) features[i * stride + c] = scene->features[i * old + c];
    features[i * stride + old] = value(i);
  }
  scene->num_channels = stride;
  scene->features = std::move(features);
  scene->lidar_intensity_channel = old;
}

}  // namespace pf::testing

#endif  // POINTFORWARD_ENGINE_RENDER_LIDAR_TESTING_H_
