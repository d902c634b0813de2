#include "engine/render/ego_layer.h"

#include "gtest/gtest.h"

namespace pf {
namespace {

// A 4x2 render of 5 channels with every buffer, and a layer whose body is
// pixels 1 and 6.
RenderBuffers FourByTwo() {
  RenderBuffers b;
  b.width = 4, b.height = 2, b.channels = 5;
  b.rgb.assign(24, 0.2f);
  b.alpha.assign(8, 0.4f);
  b.depth.assign(8, 12.f);
  b.instance.assign(8, 3);
  b.features.assign(40, 0.7f);
  return b;
}

EgoLayer TwoPixelBody() {
  EgoLayer layer{"front", 4, 2, {0, 1, 0, 0, 0, 0, 1, 0}, std::vector<float>(24, 0.f)};
  for (int c = 0; c < 3; ++c) layer.rgb[1 * 3 + c] = 0.1f * (c + 1), layer.rgb[6 * 3 + c] = 0.9f;
  return layer;
}

TEST(EgoLayerTest, DrawsTheBodyOverEveryBufferOfItsPixels) {
  RenderBuffers b = FourByTwo();
  ASSERT_TRUE(ApplyEgoLayer(TwoPixelBody(), 0, &b));
  for (size_t i = 0; i < 8; ++i) {
    const bool body = i == 1 || i == 6;
    EXPECT_EQ(b.alpha[i], body ? 1.f : 0.4f) << i;
    EXPECT_EQ(b.depth[i], body ? 0.f : 12.f) << i;
    EXPECT_EQ(b.instance[i], body ? 0u : 3u) << i;
    for (int c = 0; c < 3; ++c) {
      const float want = i == 1 ? 0.1f * (c + 1) : i == 6 ? 0.9f : 0.2f;
      EXPECT_FLOAT_EQ(b.rgb[i * 3 + c], want) << i;
    }
    for (int c = 0; c < 5; ++c) {
      const float want = !body ? 0.7f : c >= 3 ? 0.f : b.rgb[i * 3 + c];
      EXPECT_FLOAT_EQ(b.features[i * 5 + c], want) << i << " " << c;
    }
  }
}

TEST(EgoLayerTest, DrawsTheFramesEitherSideOfTheRenderTimeMixedLinearly) {
  EgoLayer layer = TwoPixelBody();
  // Body pixels 1 and 6 at 1.0 s, 1.2 s and 1.6 s.
  layer.frames = {{1'000'000, {0.1f, 0.2f, 0.3f, 0.5f, 0.5f, 0.5f}},
                  {1'200'000, {0.3f, 0.4f, 0.5f, 0.9f, 0.7f, 0.5f}},
                  {1'600'000, {0.7f, 0.4f, 0.1f, 0.1f, 0.1f, 0.1f}}};
  ASSERT_TRUE(CheckEgoLayer(layer, "ego").ok());
  struct Case {
    int64_t time_us;
    float pixel1[3], pixel6[3];
  };
  for (const Case& want : {Case{0, {0.1f, 0.2f, 0.3f}, {0.5f, 0.5f, 0.5f}},  // before: the first
                           Case{1'000'000, {0.1f, 0.2f, 0.3f}, {0.5f, 0.5f, 0.5f}},
                           Case{1'100'000, {0.2f, 0.3f, 0.4f}, {0.7f, 0.6f, 0.5f}},   // halfway
                           Case{1'300'000, {0.4f, 0.4f, 0.4f}, {0.7f, 0.55f, 0.4f}},  // a quarter
                           Case{1'600'000, {0.7f, 0.4f, 0.1f}, {0.1f, 0.1f, 0.1f}},
                           Case{9'000'000, {0.7f, 0.4f, 0.1f}, {0.1f, 0.1f, 0.1f}}}) {  // after
    RenderBuffers b = FourByTwo();
    ASSERT_TRUE(ApplyEgoLayer(layer, want.time_us, &b));
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(b.rgb[1 * 3 + c], want.pixel1[c], 1e-6) << want.time_us << " " << c;
      EXPECT_NEAR(b.rgb[6 * 3 + c], want.pixel6[c], 1e-6) << want.time_us << " " << c;
      EXPECT_NEAR(b.features[6 * 5 + c], want.pixel6[c], 1e-6) << want.time_us << " " << c;
      EXPECT_EQ(b.rgb[0 * 3 + c], 0.2f);  // Off the body: the render.
    }
    EXPECT_EQ(b.alpha[6], 1.f);
  }
  // Without frames, the mean colour at every time.
  layer.frames.clear();
  RenderBuffers b = FourByTwo();
  ASSERT_TRUE(ApplyEgoLayer(layer, 1'100'000, &b));
  EXPECT_FLOAT_EQ(b.rgb[6 * 3], 0.9f);
}

TEST(EgoLayerTest, ARenderOfAnotherSizeIsLeftAlone) {
  RenderBuffers b = FourByTwo();
  EgoLayer layer = TwoPixelBody();
  layer.width = 2, layer.height = 4;
  EXPECT_FALSE(ApplyEgoLayer(layer, 0, &b));
  EXPECT_EQ(b.alpha, std::vector<float>(8, 0.4f));
}

TEST(EgoLayerTest, FindsTheLayerOfACamera) {
  GaussianScene scene;
  scene.ego_layers = {TwoPixelBody()};
  ASSERT_NE(FindEgoLayer(scene, "front"), nullptr);
  EXPECT_EQ(FindEgoLayer(scene, "front")->camera_id, "front");
  EXPECT_EQ(FindEgoLayer(scene, "back"), nullptr);
  EXPECT_TRUE(CheckEgoLayer(scene.ego_layers[0], "ego").ok());
  scene.ego_layers[0].rgb[0] = std::nanf("");
  EXPECT_EQ(CheckEgoLayer(scene.ego_layers[0], "ego").message(), "ego: a colour is not finite");
}

}  // namespace
}  // namespace pf
