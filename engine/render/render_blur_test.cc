// Tests of render_blur.h: the blur's weights and edges, and DeviceRenderer
// applying the scene's blur.
#include "engine/render/render_blur.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "engine/render/device_renderer.h"
#include "engine/render/random_scene_testing.h"

namespace pf {
namespace {

TEST(BlurImage, SpreadsAPointByTheGaussianAndKeepsAConstantImage) {
  // A unit point in the middle of a 31x25 image, two channels (the second
  // twice the first): each pixel takes g(dx) g(dy) / (sum g)^2, g(k) =
  // exp(-k^2 / (2 sigma^2)) over |k| <= ceil(3 sigma) (the image is wide
  // enough that no window the point reaches leaves it).
  const int w = 31, h = 25, channels = 2;
  const float sigma = 1.5f;
  std::vector<float> image(size_t(w) * h * channels, 0.f);
  image[(12 * w + 15) * channels] = 1.f;
  image[(12 * w + 15) * channels + 1] = 2.f;
  BlurImage(sigma, w, h, channels, &image);
  double norm = 0;
  for (int k = -5; k <= 5; ++k) norm += std::exp(-0.5 * k * k / (sigma * sigma));
  double total = 0;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const int dx = x - 15, dy = y - 12;
      const double want =
          std::abs(dx) > 5 || std::abs(dy) > 5
              ? 0.0
              : std::exp(-0.5 * (dx * dx + dy * dy) / (sigma * sigma)) / (norm * norm);
      EXPECT_NEAR(image[(y * w + x) * channels], want, 1e-6) << x << ", " << y;
      EXPECT_NEAR(image[(y * w + x) * channels + 1], 2 * want, 2e-6) << x << ", " << y;
      total += image[(y * w + x) * channels];
    }
  }
  EXPECT_NEAR(total, 1.0, 1e-5);  // Nothing reaches the edges here.
  // At the edges the weights that stay inside are renormalised: a constant
  // image stays constant.
  std::vector<float> flat(size_t(w) * h, 0.25f);
  BlurImage(2.f, w, h, 1, &flat);
  for (float v : flat) EXPECT_NEAR(v, 0.25f, 1e-6f);
  // No blur at sigma 0.
  std::vector<float> same = image;
  BlurImage(0.f, w, h, channels, &same);
  EXPECT_EQ(same, image);
}

TEST(DeviceRenderer, BlursByTheScenesRenderBlurAndLeavesDepth) {
  const RenderCamera camera = testing_scenes::SimpleCamera(48, 40, 48);
  GaussianScene scene = testing_scenes::RandomScene({.seed = 3, .count = 60}, camera);
  const absl::StatusOr<RenderBuffers> sharp = Render(scene, camera, 0, {});
  ASSERT_TRUE(sharp.ok()) << sharp.status();
  scene.render_blur = 1.25f;
  absl::StatusOr<std::unique_ptr<DeviceRenderer>> renderer =
      DeviceRenderer::Create(&scene, ComputeDevice{}, "device");
  ASSERT_TRUE(renderer.ok()) << renderer.status();
  const absl::StatusOr<RenderBuffers> blurred = (*renderer)->Render(camera, 0, {});
  ASSERT_TRUE(blurred.ok()) << blurred.status();
  RenderBuffers want = *sharp;
  BlurRender(1.25f, &want);
  EXPECT_EQ(blurred->rgb, want.rgb);
  EXPECT_EQ(blurred->alpha, want.alpha);
  EXPECT_EQ(blurred->features, want.features);
  EXPECT_NE(blurred->rgb, sharp->rgb);
  EXPECT_EQ(blurred->depth, sharp->depth);
  EXPECT_EQ(blurred->instance, sharp->instance);
  // Render() of rasterizer.h stays sharp.
  const absl::StatusOr<RenderBuffers> plain = Render(scene, camera, 0, {});
  ASSERT_TRUE(plain.ok());
  EXPECT_EQ(plain->rgb, sharp->rgb);
}

}  // namespace
}  // namespace pf
