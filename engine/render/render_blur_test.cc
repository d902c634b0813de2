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

TEST(RenderBlurAt, GrowsWithTheDistanceFromTheNearestAnchorUpToItsBound) {
  // A camera of focal length 1000 px at the origin looking down +z.
  RenderCamera camera = testing_scenes::SimpleCamera(64, 48, 1000);
  camera.world_from_camera = Rigid{};
  GaussianScene scene;
  scene.render_blur = 0.5f;
  EXPECT_EQ(RenderBlurAt(scene, camera), 0.5f);  // No growth.
  scene.render_blur_growth = 2.f;
  EXPECT_EQ(RenderBlurAt(scene, camera), 0.5f);  // No anchors.
  // Anchors 1.25 m behind (same axis) and 0.2 m aside looking sideways
  // (1 m per radian: 0.2 + pi / 2).
  scene.blur_anchors = {{{0, 0, -1.25f}, {0, 0, 1}}, {{0.2f, 0, 0}, {1, 0, 0}}};
  EXPECT_NEAR(RenderBlurAt(scene, camera), 1000 * 2e-3 * 1.25, 1e-5);
  // The nearest anchor counts: one 0.4 m away gives 0.8 px.
  scene.blur_anchors.push_back({{0, 0.4f, 0}, {0, 0, 1}});
  EXPECT_NEAR(RenderBlurAt(scene, camera), 0.8, 1e-5);
  // Never less than render_blur: 0.1 m gives 0.2 px, so 0.5.
  scene.blur_anchors.push_back({{0.1f, 0, 0}, {0, 0, 1}});
  EXPECT_EQ(RenderBlurAt(scene, camera), 0.5f);
  // Turned around: the nearest anchor is the sideways one, 0.2 m + pi / 2
  // away: 1000 x 2e-3 x 1.77 = 3.5 px, bounded by kMaxGrownRenderBlur.
  const Mat3 half_turn{{{{-1, 0, 0}, {0, 1, 0}, {0, 0, -1}}}};
  camera.world_from_camera.rotation = half_turn;
  EXPECT_EQ(RenderBlurAt(scene, camera), kMaxGrownRenderBlur);
  // The focal length scales it: at 100 px the same view gets 0.65 px.
  camera = testing_scenes::SimpleCamera(64, 48, 100);
  camera.world_from_camera = Rigid{half_turn, Vec3{0.1, 0, 0}};
  scene.blur_anchors = {{{0, 0, 0}, {0, 0, 1}}};
  EXPECT_NEAR(RenderBlurAt(scene, camera), 100 * 2e-3 * (0.1 + M_PI), 1e-4);
}

TEST(DeviceRenderer, BlursByTheBlurAtItsCamera) {
  RenderCamera camera = testing_scenes::SimpleCamera(48, 40, 48);
  GaussianScene scene = testing_scenes::RandomScene({.seed = 5, .count = 60}, camera);
  const absl::StatusOr<RenderBuffers> sharp = Render(scene, camera, 0, {});
  ASSERT_TRUE(sharp.ok()) << sharp.status();
  // The camera 12.5 m from the one anchor along its axis: 48 x 2e-3 x 12.5 = 1.2 px.
  const Vec3 c = camera.world_from_camera.translation;
  const Vec3 axis = camera.world_from_camera.rotation * Vec3{0, 0, 1};
  scene.render_blur = 0.25f;
  scene.render_blur_growth = 2.f;
  scene.blur_anchors = {BlurAnchorOf({camera.world_from_camera.rotation, c - 12.5 * axis})};
  ASSERT_NEAR(RenderBlurAt(scene, camera), 1.2f, 1e-4);
  absl::StatusOr<std::unique_ptr<DeviceRenderer>> renderer =
      DeviceRenderer::Create(&scene, ComputeDevice{}, "device");
  ASSERT_TRUE(renderer.ok()) << renderer.status();
  const absl::StatusOr<RenderBuffers> blurred = (*renderer)->Render(camera, 0, {});
  ASSERT_TRUE(blurred.ok()) << blurred.status();
  // The actors (the scene's two instances) keep the scene's 0.25 px.
  RenderBuffers want = *sharp, floor = *sharp, uniform = *sharp;
  BlurRender(RenderBlurAt(scene, camera), 0.25f, &want);
  BlurRender(0.25f, &floor);
  BlurRender(RenderBlurAt(scene, camera), &uniform);
  EXPECT_EQ(blurred->rgb, want.rgb);
  EXPECT_EQ(blurred->alpha, want.alpha);
  EXPECT_EQ(blurred->instance, sharp->instance);
  EXPECT_NE(blurred->rgb, floor.rgb);
  EXPECT_NE(blurred->rgb, uniform.rgb);
  // Without instance ids asked for, the same colours and no ids.
  RenderOptions no_ids;
  no_ids.instance = false;
  const absl::StatusOr<RenderBuffers> without = (*renderer)->Render(camera, 0, {}, no_ids);
  ASSERT_TRUE(without.ok()) << without.status();
  EXPECT_EQ(without->rgb, want.rgb);
  EXPECT_TRUE(without->instance.empty());
}

TEST(BlurRender, KeepsTheActorsAtTheirBlur) {
  // A 60x40 render of noise whose left half is an actor (instance 2): its
  // pixels more than 3 sigma from the right half take the actor's blur, the
  // right half's pixels more than 3 sigma from the left the full blur, and
  // those between a mix of the two.
  const int w = 60, h = 40;
  RenderBuffers sharp;
  sharp.width = w;
  sharp.height = h;
  sharp.channels = 3;
  sharp.rgb.resize(size_t(w) * h * 3);
  sharp.alpha.resize(size_t(w) * h);
  sharp.instance.assign(size_t(w) * h, 0);
  uint32_t state = 7;
  auto noise = [&state] {
    return float((state = state * 1664525u + 1013904223u) >> 8) / 16777216.f;
  };
  for (float& v : sharp.rgb) v = noise();
  for (float& v : sharp.alpha) v = noise();
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w / 2; ++x) sharp.instance[y * w + x] = 2;
  }
  RenderBuffers mixed = sharp, wide = sharp, narrow = sharp;
  BlurRender(2.f, 0.5f, &mixed);
  BlurRender(2.f, &wide);
  BlurRender(0.5f, &narrow);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = size_t(y) * w + x;
      if (x < w / 2 - 12) {
        EXPECT_NEAR(mixed.rgb[3 * i], narrow.rgb[3 * i], 1e-6) << x << ", " << y;
        EXPECT_NEAR(mixed.alpha[i], narrow.alpha[i], 1e-6) << x << ", " << y;
      } else if (x >= w / 2 + 12) {
        EXPECT_NEAR(mixed.rgb[3 * i], wide.rgb[3 * i], 1e-6) << x << ", " << y;
        EXPECT_NEAR(mixed.alpha[i], wide.alpha[i], 1e-6) << x << ", " << y;
      }
    }
  }
  // At the edge, half of each.
  const size_t edge = size_t(20) * w + w / 2;
  EXPECT_NEAR(mixed.rgb[3 * edge], 0.5f * (narrow.rgb[3 * edge] + wide.rgb[3 * edge]), 0.1f);
  EXPECT_NE(mixed.rgb[3 * edge], narrow.rgb[3 * edge]);
  EXPECT_NE(mixed.rgb[3 * edge], wide.rgb[3 * edge]);
  // No actor in view, or no ids: the full blur.
  RenderBuffers none = sharp;
  none.instance.assign(none.instance.size(), 0);
  BlurRender(2.f, 0.5f, &none);
  EXPECT_EQ(none.rgb, wide.rgb);
  none = sharp;
  none.instance.clear();
  BlurRender(2.f, 0.5f, &none);
  EXPECT_EQ(none.rgb, wide.rgb);
}

TEST(CheckBlurAnchor, NamesTheFieldAndTheProblem) {
  EXPECT_TRUE(CheckBlurAnchor({{1, 2, 3}, {0, 0.6f, 0.8f}}, "a").ok());
  EXPECT_EQ(CheckBlurAnchor({{1, 2, 3}, {0, 0, 0.5f}}, "anchors[2]").message(),
            "anchors[2]: axis of length 0.5, not 1");
  EXPECT_EQ(CheckBlurAnchor({{INFINITY, 2, 3}, {0, 0, 1}}, "a").message(),
            "a: a coordinate is not finite");
}

}  // namespace
}  // namespace pf
