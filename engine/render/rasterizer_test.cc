// Tests of the tile rasterizer: agreement with the slow reference renderer on
// random scenes, hand-made scenes with known composited values, time and
// actors, camera distortion, determinism.
#include "engine/render/rasterizer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "engine/render/bench_scene.h"
#include "engine/render/compositing_weights.h"
#include "engine/render/instance_pose.h"
#include "engine/render/random_scene_testing.h"
#include "engine/render/raster_tile.h"
#include "engine/render/reference_renderer.h"

namespace pf {
namespace {

using testing_scenes::MovedCamera;
using testing_scenes::MovedCameraOfModel;
using testing_scenes::MoveSecondActor;
using testing_scenes::RandomScene;
using testing_scenes::RandomSceneSpec;
using testing_scenes::SimpleCamera;
using testing_scenes::YawQuat;

constexpr double kPi = 3.14159265358979323846;
constexpr float kInf = std::numeric_limits<float>::infinity();

// Adds an isotropic Gaussian of std-dev `scale` and returns its index.
size_t AddGaussian(GaussianScene* scene, const Vec3& mean, double scale, double opacity,
                   std::vector<float> feature, uint32_t owner = 0) {
  const size_t i = scene->size();
  scene->Resize(i + 1);
  for (int c = 0; c < 3; ++c) {
    scene->means[3 * i + c] = static_cast<float>(mean[c]);
    scene->log_scales[3 * i + c] = static_cast<float>(std::log(scale));
  }
  scene->opacity_logits[i] = LogitOfOpacity(opacity);
  feature.resize(scene->num_channels, 0.f);
  for (int c = 0; c < scene->num_channels; ++c)
    scene->features[i * scene->num_channels + c] = feature[c];
  scene->owners[i] = owner;
  return i;
}

// The world point at depth z that the simple camera projects onto the centre
// of pixel (px, py).
Vec3 PointAtPixel(int px, int py, double z, const RenderCamera& camera) {
  const CameraModel& m = camera.model;
  return {(px + 0.5 - m.cx()) / m.fx() * z, (py + 0.5 - m.cy()) / m.fy() * z, z};
}

size_t Pixel(const RenderBuffers& b, int x, int y) { return static_cast<size_t>(y) * b.width + x; }

// Compares fast and reference outputs on every unambiguous pixel.
void ExpectMatchesReference(const GaussianScene& scene, const RenderCamera& camera,
                            int64_t timestamp_us, const std::vector<ActorEdit>& edits) {
  absl::StatusOr<RenderBuffers> fast = Render(scene, camera, timestamp_us, edits);
  ASSERT_TRUE(fast.ok()) << fast.status();
  std::vector<uint8_t> ambiguous;
  const RenderBuffers ref =
      testing::ReferenceRender(scene, camera, timestamp_us, edits, {}, &ambiguous);
  const size_t pixels = static_cast<size_t>(ref.width) * ref.height;
  const int nc = scene.num_channels;
  double max_feature = 0, max_rgb = 0, max_alpha = 0, max_depth = 0;
  size_t skipped = 0, instance_mismatch = 0, covered = 0;
  for (size_t p = 0; p < pixels; ++p) {
    if (ambiguous[p]) {
      ++skipped;
      continue;
    }
    if (ref.alpha[p] > 0.01f) ++covered;
    for (int c = 0; c < nc; ++c) {
      max_feature = std::max(
          max_feature, std::abs(double(fast->features[p * nc + c]) - ref.features[p * nc + c]));
    }
    for (int c = 0; c < 3; ++c) {
      max_rgb = std::max(max_rgb, std::abs(double(fast->rgb[3 * p + c]) - ref.rgb[3 * p + c]));
    }
    max_alpha = std::max(max_alpha, std::abs(double(fast->alpha[p]) - ref.alpha[p]));
    max_depth = std::max(max_depth, std::abs(double(fast->depth[p]) - ref.depth[p]));
    if (fast->instance[p] != ref.instance[p]) ++instance_mismatch;
  }
  EXPECT_LE(max_feature, 1e-4);
  EXPECT_LE(max_rgb, 1e-4);
  EXPECT_LE(max_alpha, 1e-4);
  EXPECT_LE(max_depth, 1e-4);
  EXPECT_EQ(instance_mismatch, 0u);
  EXPECT_LE(skipped, pixels / 200) << "too many close calls";
  EXPECT_GT(covered, pixels / 4) << "the scene should cover the image";
  EXPECT_GE(fast->stats.pairs_tested, fast->stats.pairs_contributing);
  EXPECT_GT(fast->stats.pairs_contributing, 0);
}

struct ReferenceCase {
  uint32_t seed;
  int count, width, height, channels, sh_degree;
};

class RasterizerReferenceTest : public ::testing::TestWithParam<ReferenceCase> {};

TEST_P(RasterizerReferenceTest, MatchesReference) {
  const ReferenceCase& c = GetParam();
  const RenderCamera camera = MovedCamera(c.width, c.height);
  RandomSceneSpec spec;
  spec.seed = c.seed;
  spec.count = c.count;
  spec.channels = c.channels;
  spec.sh_degree = c.sh_degree;
  const GaussianScene scene = RandomScene(spec, camera);
  // Mid-track, so instances move and lifespans fade.
  ExpectMatchesReference(scene, camera, scene.time_origin_us + 1'300'000, {});
}

INSTANTIATE_TEST_SUITE_P(RandomScenes, RasterizerReferenceTest,
                         ::testing::Values(ReferenceCase{1, 60, 40, 30, 3, -1},
                                           ReferenceCase{2, 300, 97, 61, 5, -1},
                                           ReferenceCase{3, 300, 97, 61, 8, 1},
                                           ReferenceCase{4, 1200, 128, 96, 4, -1},
                                           ReferenceCase{5, 1200, 130, 70, 3, 3},
                                           ReferenceCase{6, 3000, 160, 120, 3, -1},
                                           ReferenceCase{7, 500, 33, 17, 32, 2}));

TEST(Rasterizer, MatchesReferenceWithEditsAndDistortion) {
  for (int model = 0; model < testing_scenes::kCameraModels; ++model) {
    const RenderCamera camera = MovedCameraOfModel(model);
    RandomSceneSpec spec;
    spec.seed = 11 + model;
    spec.count = 800;
    GaussianScene scene = RandomScene(spec, camera);
    ActorEdit remove;
    remove.instance_id = "actor0";
    SCOPED_TRACE(model);
    ExpectMatchesReference(scene, camera, scene.time_origin_us + 700'000,
                           {remove, MoveSecondActor(scene)});
  }
}

TEST(Rasterizer, ColourGradientsMatchReference) {
  // Pinhole, OpenCV, fisheye and f-theta cameras, moving and edited actors,
  // features.
  for (int model = 0; model < testing_scenes::kCameraModels; ++model) {
    const RenderCamera camera = MovedCameraOfModel(model);
    RandomSceneSpec spec;
    spec.seed = 21 + model;
    spec.count = 800;
    spec.channels = model == 0 ? 3 : 7;
    spec.colour_gradients = true;
    GaussianScene scene = RandomScene(spec, camera);
    scene.low_pass = 0.1f;
    SCOPED_TRACE(model);
    ExpectMatchesReference(scene, camera, scene.time_origin_us + 700'000, {MoveSecondActor(scene)});
  }
}

TEST(Rasterizer, ColourGradientRampsAcrossAFacingDisc) {
  // A disc facing the camera, std-dev 8 px on screen, no low-pass, turned by
  // theta about the view axis: its first axis runs along (cos, sin) on the
  // screen, so a pixel at offset (dx, dy) is at u = (cos dx + sin dy) / 8,
  // v = (-sin dx + cos dy) / 8, and red = 0.5 + 0.3 u, green = 0.2 - 0.1 v.
  const RenderCamera camera = SimpleCamera(64, 64, 64);
  GaussianScene scene;
  scene.low_pass = 0.f;
  const double depth = 4.0, sigma = 8.0 * depth / 64;
  const size_t i =
      AddGaussian(&scene, PointAtPixel(32, 32, depth, camera), sigma, 0.98, {0.5f, 0.2f, 0.7f});
  scene.log_scales[3 * i + 2] = static_cast<float>(std::log(sigma * 1e-3));  // A flat disc.
  scene.colour_gradients = {0.3f, 0.f, 0.f, -0.1f, 0.f, 0.f};
  for (const double theta : {0.0, M_PI / 6}) {
    SCOPED_TRACE(theta);
    const Quat roll{std::cos(theta / 2), 0, 0, std::sin(theta / 2)};
    scene.rotations = {float(roll.w), float(roll.x), float(roll.y), float(roll.z)};
    absl::StatusOr<RenderBuffers> out = Render(scene, camera, 0, {});
    ASSERT_TRUE(out.ok()) << out.status();
    for (const auto& [x, y] :
         std::vector<std::pair<int, int>>{{32, 32}, {40, 32}, {24, 36}, {35, 26}}) {
      const size_t p = Pixel(*out, x, y);
      const double dx = x - 32, dy = y - 32;  // The centre is pixel (32, 32)'s centre.
      const double u = (std::cos(theta) * dx + std::sin(theta) * dy) / 8;
      const double v = (-std::sin(theta) * dx + std::cos(theta) * dy) / 8;
      const double alpha = out->alpha[p];
      ASSERT_GT(alpha, 0.3);
      SCOPED_TRACE(::testing::Message() << x << "," << y);
      EXPECT_NEAR(out->rgb[3 * p] / alpha, 0.5 + 0.3 * u, 2e-3);
      EXPECT_NEAR(out->rgb[3 * p + 1] / alpha, 0.2 - 0.1 * v, 2e-3);
      EXPECT_NEAR(out->rgb[3 * p + 2] / alpha, 0.7, 2e-3);
      // The first three feature channels are the colour the RGB shows.
      EXPECT_NEAR(out->features[3 * p], out->rgb[3 * p], 1e-6);
    }
  }
  absl::StatusOr<RenderBuffers> out;
  // Seen edge-on (the disc turned 90 degrees about y), the screen has no
  // room along u: the expected u goes to 0 and the disc shows its centre
  // colour, however large the gradient.
  const Quat turn{std::cos(M_PI / 4), 0, std::sin(M_PI / 4), 0};
  scene.rotations = {float(turn.w), float(turn.x), float(turn.y), float(turn.z)};
  scene.low_pass = 0.3f;
  scene.colour_gradients = {5.f, 0.f, 0.f, 0.f, 0.f, 0.f};
  out = Render(scene, camera, 0, {});
  ASSERT_TRUE(out.ok()) << out.status();
  const size_t p = Pixel(*out, 32, 32);
  ASSERT_GT(out->alpha[p], 0.3);
  EXPECT_NEAR(out->rgb[3 * p] / out->alpha[p], 0.5, 0.02);
}

TEST(Rasterizer, ACameraOfMorePixelsThanBuffersCanHoldIsAnErrorNotAnAbort) {
  // 1e9 x 1e9: the buffers' sizes once threw std::length_error out of Render.
  RenderCamera camera = SimpleCamera();
  camera.model = CameraModel(1'000'000'000, 1'000'000'000, 1e9, 1e9, 5e8, 5e8);
  GaussianScene scene;
  AddGaussian(&scene, {0, 0, 5}, 0.3, 0.9, {1, 0, 0});
  const absl::StatusOr<RenderBuffers> out = Render(scene, camera, 0, {});
  EXPECT_EQ(out.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(out.status().message(),
            "camera: image size 1000000000x1000000000 exceeds 2147483648 pixels");
}

TEST(Rasterizer, OpaqueFrontGaussianHidesBack) {
  const RenderCamera camera = SimpleCamera();
  GaussianScene scene;
  // The back one first in the arrays: order must come from depth.
  AddGaussian(&scene, PointAtPixel(32, 32, 4.0, camera), 0.3, 0.999, {0, 1, 0});
  AddGaussian(&scene, PointAtPixel(32, 32, 2.0, camera), 0.3, 0.999, {1, 0, 0});
  absl::StatusOr<RenderBuffers> out = Render(scene, camera, 0, {});
  ASSERT_TRUE(out.ok()) << out.status();
  const size_t p = Pixel(*out, 32, 32);
  // Front: alpha clamped to 0.99; back: 0.99 of the remaining 0.01.
  EXPECT_NEAR(out->rgb[3 * p], 0.99, 1e-5);
  EXPECT_NEAR(out->rgb[3 * p + 1], 0.01 * 0.99, 1e-5);
  EXPECT_NEAR(out->alpha[p], 1 - 0.01 * 0.01, 1e-5);
  EXPECT_NEAR(out->depth[p], (0.99 * 2 + 0.0099 * 4) / 0.9999, 1e-4);
}

TEST(Rasterizer, TwoHalfTransparentGaussiansBlendInDepthOrder) {
  const RenderCamera camera = SimpleCamera();
  for (bool red_in_front : {true, false}) {
    GaussianScene scene;
    scene.num_channels = 4;
    AddGaussian(&scene, PointAtPixel(20, 40, red_in_front ? 2.0 : 3.0, camera), 0.2, 0.5,
                {1, 0, 0, 7});
    AddGaussian(&scene, PointAtPixel(20, 40, red_in_front ? 3.0 : 2.0, camera), 0.2, 0.4,
                {0, 1, 0, 9});
    absl::StatusOr<RenderBuffers> out = Render(scene, camera, 0, {});
    ASSERT_TRUE(out.ok()) << out.status();
    const size_t p = Pixel(*out, 20, 40);
    const double front = red_in_front ? 0.5 : 0.4, back = red_in_front ? 0.4 : 0.5;
    const double w_front = front, w_back = (1 - front) * back;
    const double w_red = red_in_front ? w_front : w_back;
    const double w_green = red_in_front ? w_back : w_front;
    EXPECT_NEAR(out->rgb[3 * p], w_red, 1e-5);
    EXPECT_NEAR(out->rgb[3 * p + 1], w_green, 1e-5);
    EXPECT_NEAR(out->features[4 * p + 3], 7 * w_red + 9 * w_green, 1e-4);
    EXPECT_NEAR(out->alpha[p], 1 - (1 - front) * (1 - back), 1e-5);
    EXPECT_NEAR(out->depth[p], (2 * w_front + 3 * w_back) / (w_front + w_back), 1e-4);
  }
}

// Within the scene's order band two Gaussians keep one order (by their
// indices' hash: Gaussian 0 ranks before Gaussian 1) whichever is nearer;
// farther apart, depth decides.
TEST(Rasterizer, AnOrderBandKeepsNearlyCoincidentGaussiansInOneOrder) {
  const RenderCamera camera = SimpleCamera();
  auto top_is_red = [&](double red_depth, double green_depth, float band) {
    GaussianScene scene;
    scene.order_band = band;
    AddGaussian(&scene, PointAtPixel(32, 32, red_depth, camera), 0.3, 0.999, {1, 0, 0});
    AddGaussian(&scene, PointAtPixel(32, 32, green_depth, camera), 0.3, 0.999, {0, 1, 0});
    absl::StatusOr<RenderBuffers> out = Render(scene, camera, 0, {});
    EXPECT_TRUE(out.ok()) << out.status();
    const size_t p = Pixel(*out, 32, 32);
    EXPECT_NE(out->rgb[3 * p] > 0.5f, out->rgb[3 * p + 1] > 0.5f);
    return out->rgb[3 * p] > 0.5f;
  };
  // 2 mm apart at 4 m (0.05 %): depth order without a band, either way.
  EXPECT_FALSE(top_is_red(4.002, 4.0, 0));
  EXPECT_TRUE(top_is_red(4.0, 4.002, 0));
  // Within a band of 1 % (Gaussian 1 sorts 0.62 % deeper): red on top both ways.
  EXPECT_TRUE(top_is_red(4.002, 4.0, 0.01f));
  EXPECT_TRUE(top_is_red(4.0, 4.002, 0.01f));
  // 10 cm apart (2.5 %): depth order again.
  EXPECT_FALSE(top_is_red(4.1, 4.0, 0.01f));
}

TEST(Rasterizer, MatchesReferenceWithAnOrderBand) {
  const RenderCamera camera = MovedCamera(97, 61);
  RandomSceneSpec spec;
  spec.seed = 11;
  spec.count = 1200;
  GaussianScene scene = RandomScene(spec, camera);
  scene.order_band = 0.02f;
  ExpectMatchesReference(scene, camera, scene.time_origin_us + 1'300'000, {});
  // The band changes the picture: the same scene without it differs.
  absl::StatusOr<RenderBuffers> banded = Render(scene, camera, scene.time_origin_us, {});
  scene.order_band = 0;
  absl::StatusOr<RenderBuffers> strict = Render(scene, camera, scene.time_origin_us, {});
  ASSERT_TRUE(banded.ok() && strict.ok());
  EXPECT_NE(banded->rgb, strict->rgb);
}

class RasterizerLowPass : public ::testing::TestWithParam<float> {};

TEST_P(RasterizerLowPass, AlphaFollowsEwaFootprintWithTheScenesLowPass) {
  // An isotropic Gaussian off the axis: 2D covariance s^2 J J^T + low_pass I,
  // for the 3DGS low-pass (the default) and the one our reconstruction uses.
  const RenderCamera camera = SimpleCamera();
  GaussianScene scene;
  scene.low_pass = GetParam();
  const Vec3 mean = PointAtPixel(40, 25, 3.0, camera);
  const double s = 0.05, opacity = 0.8;
  AddGaussian(&scene, mean, s, opacity, {1, 1, 1});
  absl::StatusOr<RenderBuffers> out = Render(scene, camera, 0, {});
  ASSERT_TRUE(out.ok()) << out.status();
  const double f = 64, z = mean.z;
  const double j[2][3] = {{f / z, 0, -f * mean.x / (z * z)}, {0, f / z, -f * mean.y / (z * z)}};
  double cov[2][2];
  for (int r = 0; r < 2; ++r)
    for (int c = 0; c < 2; ++c)
      cov[r][c] = s * s * (j[r][0] * j[c][0] + j[r][1] * j[c][1] + j[r][2] * j[c][2]) +
                  (r == c ? GetParam() : 0.0);
  const double det = cov[0][0] * cov[1][1] - cov[0][1] * cov[1][0];
  int inside = 0;
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x < 64; ++x) {
      const double dx = x - 40, dy = y - 25;  // Pixel centres minus the mean.
      const double d2 = (cov[1][1] * dx * dx - 2 * cov[0][1] * dx * dy + cov[0][0] * dy * dy) / det;
      double expected = std::min(0.99, opacity * std::exp(-0.5 * d2));
      if (expected < 1 / 255.0) expected = 0;
      if (expected > 0) ++inside;
      ASSERT_NEAR(out->alpha[Pixel(*out, x, y)], expected, 1e-5) << x << "," << y;
    }
  }
  // The opacity-aware extent: about pi * sqrt(det) * 2 ln(255 o) pixels.
  const double area = kPi * std::sqrt(det) * 2 * std::log(255 * opacity);
  EXPECT_NEAR(inside, area, 0.1 * area);
}

INSTANTIATE_TEST_SUITE_P(ThreeDgsAndOurs, RasterizerLowPass,
                         ::testing::Values(kThreeDgsLowPass, 0.1f));

TEST(Rasterizer, FaintGaussianHasSmallerExtent) {
  const RenderCamera camera = SimpleCamera(128, 128, 64);
  auto covered = [&](double opacity) {
    GaussianScene scene;
    AddGaussian(&scene, PointAtPixel(64, 64, 3.0, camera), 0.3, opacity, {1, 1, 1});
    absl::StatusOr<RenderBuffers> out = Render(scene, camera, 0, {});
    int count = 0;
    for (float a : out->alpha) count += a > 0;
    return count;
  };
  const int strong = covered(0.9), faint = covered(0.02);
  EXPECT_GT(faint, 0);
  // Area ratio ln(255 * 0.02) / ln(255 * 0.9) = 0.30.
  EXPECT_NEAR(static_cast<double>(faint) / strong, std::log(5.1) / std::log(229.5), 0.05);
}

// The colour of one near-opaque Gaussian (opacity 0.999, alpha 0.99 at its
// centre) with spherical harmonics `sh` of `degree`, at its pixel (45, 20),
// and the direction it is seen along.
struct ShPixel {
  std::array<float, 3> rgb{};
  Vec3 direction;
};

ShPixel RenderShGaussian(int degree, std::vector<float> sh) {
  const RenderCamera camera = SimpleCamera();
  GaussianScene scene;
  scene.sh_degree = degree;
  const Vec3 mean = PointAtPixel(45, 20, 2.0, camera);
  AddGaussian(&scene, mean, 0.2, 0.999, {0, 0, 0});
  scene.sh = std::move(sh);
  ShPixel out;
  out.direction = Normalized(mean);
  absl::StatusOr<RenderBuffers> buffers = Render(scene, camera, 0, {});
  EXPECT_TRUE(buffers.ok()) << buffers.status();
  if (!buffers.ok()) return out;
  for (int c = 0; c < 3; ++c) out.rgb[c] = buffers->rgb[3 * Pixel(*buffers, 45, 20) + c];
  return out;
}

TEST(Rasterizer, ShColourSeenAlongViewDirection) {
  // Per channel: dc, then the three degree-1 coefficients.
  const std::vector<float> sh = {0.5, 0.1, 0.2, 0.3, -0.4, 0.0, 0.0, 0.6, 1.0, -0.3, 0.1, 0.0};
  const ShPixel out = RenderShGaussian(1, sh);
  const Vec3& d = out.direction;
  const double c0 = 0.28209479177387814, c1 = 0.4886025119029199;
  for (int c = 0; c < 3; ++c) {
    const float* k = &sh[4 * c];
    const double expected =
        std::max(0.0, c0 * k[0] - c1 * d.y * k[1] + c1 * d.z * k[2] - c1 * d.x * k[3] + 0.5);
    EXPECT_NEAR(out.rgb[c], 0.99 * expected, 1e-5) << c;
  }
}

// Degrees 2 and 3, one basis function per channel, against the real
// spherical harmonics written out here (normalisations from their
// definitions, signs as 3DGS uses them), not raster_sh.h's table.
TEST(Rasterizer, ShColourOfDegreesTwoAndThree) {
  std::vector<float> sh(3 * 16, 0.f);
  for (int c = 0; c < 3; ++c) sh[16 * c] = 0.3f;
  sh[6] = 0.7f;        // Red: degree 2, m = 0.
  sh[16 + 10] = 0.9f;  // Green: degree 3, x y z.
  sh[32 + 15] = 0.8f;  // Blue: degree 3, x (x^2 - 3 y^2) ...
  sh[32 + 8] = -0.6f;  // ... and degree 2, x^2 - y^2.
  const ShPixel out = RenderShGaussian(3, sh);
  const double x = out.direction.x, y = out.direction.y, z = out.direction.z;
  const double pi = std::acos(-1.0);
  ASSERT_GT(std::abs(x * y), 1e-3);  // Off-axis, so every term counts.
  const double dc = 0.3 * 0.5 / std::sqrt(pi);
  const double red = dc + 0.7 * std::sqrt(5 / pi) / 4 * (2 * z * z - x * x - y * y);
  const double green = dc + 0.9 * std::sqrt(105 / pi) / 2 * x * y * z;
  const double blue = dc - 0.8 * std::sqrt(35 / (2 * pi)) / 4 * x * (x * x - 3 * y * y) -
                      0.6 * std::sqrt(15 / pi) / 4 * (x * x - y * y);
  const double expected[3] = {red, green, blue};
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(out.rgb[c], 0.99 * std::max(0.0, expected[c] + 0.5), 1e-5) << c;
  }
}

// One Gaussian of opacity 0.8 at pixel (10, 10) of `camera`, of time 1 s
// after the scene's origin and lifespan 0.5 s.
GaussianScene OneFadingGaussian(const RenderCamera& camera) {
  GaussianScene scene;
  scene.time_origin_us = 5'000'000;
  AddGaussian(&scene, PointAtPixel(10, 10, 2.0, camera), 0.05, 0.8, {1, 1, 1});
  scene.times[0] = 1.0f;
  scene.lifespans[0] = 0.5f;
  return scene;
}

TEST(Rasterizer, LifespanFadesOpacityAwayFromItsTime) {
  const RenderCamera camera = SimpleCamera();
  GaussianScene scene = OneFadingGaussian(camera);
  const size_t p = 10 * 64 + 10;
  for (double t : {1.0, 1.4, 2.0, 0.2, 3.5}) {
    absl::StatusOr<RenderBuffers> out =
        Render(scene, camera, scene.time_origin_us + static_cast<int64_t>(t * 1e6), {});
    ASSERT_TRUE(out.ok());
    const double u = (t - 1.0) / 1.5;
    double expected = 0.8 * std::exp(-0.5 * u * u);
    if (expected < 1 / 255.0) expected = 0;
    EXPECT_NEAR(out->alpha[p], expected, 1e-5) << "t' = " << t;
  }
  // sigma = +inf never fades.
  scene.lifespans[0] = kInf;
  absl::StatusOr<RenderBuffers> out = Render(scene, camera, scene.time_origin_us + 90'000'000, {});
  EXPECT_NEAR(out->alpha[p], 0.8, 1e-5);
}

TEST(Rasterizer, TheFadeSpanHoldsTheFadesTime) {
  // With a fade span [0.6, 1.8] s a render at t' fades as at t' held within
  // it: before 0.6 as at 0.6, after 1.8 as at 1.8, between as at t'; the
  // compositing weights and the reference renderer hold it alike.
  const RenderCamera camera = SimpleCamera();
  GaussianScene scene = OneFadingGaussian(camera);
  scene.fade_span = {0.6f, 1.8f};
  const size_t p = 10 * 64 + 10;
  for (double t : {-3.0, 0.2, 0.6, 1.4, 1.8, 2.5, 40.0}) {
    const int64_t at = scene.time_origin_us + static_cast<int64_t>(std::llround(t * 1e6));
    absl::StatusOr<RenderBuffers> out = Render(scene, camera, at, {});
    ASSERT_TRUE(out.ok());
    const double u = (std::clamp(t, 0.6, 1.8) - 1.0) / 1.5;
    EXPECT_NEAR(out->alpha[p], 0.8 * std::exp(-0.5 * u * u), 1e-5) << "t' = " << t;
    absl::StatusOr<CompositingWeights> a = ComputeCompositingWeights(scene, camera, at);
    ASSERT_TRUE(a.ok());
    EXPECT_EQ(a->alpha[p], out->alpha[p]) << "t' = " << t;
    const RenderBuffers reference = testing::ReferenceRender(scene, camera, at, {});
    EXPECT_NEAR(reference.alpha[p], out->alpha[p], 1e-5) << "t' = " << t;
  }
  // Unbounded (the default): 40 s away it has faded out.
  scene.fade_span = FadeSpan{};
  absl::StatusOr<RenderBuffers> out = Render(scene, camera, scene.time_origin_us + 40'000'000, {});
  ASSERT_TRUE(out.ok());
  EXPECT_EQ(out->alpha[p], 0.f);
}

// A scene with one moving car (instance 1) in front of a background wall.
GaussianScene ActorScene() {
  GaussianScene scene;
  InstanceTrack track;
  track.id = "car";
  TrackBox a, b;
  a.timestamp_us = 0;
  a.center = {-1, 0, 5};
  a.rotation = YawQuat(0);
  b.timestamp_us = 1'000'000;
  b.center = {1, 0.4, 5};
  b.rotation = QuatNormalized({std::cos(kPi / 4), 0, std::sin(kPi / 4), 0});
  track.boxes = {a, b};
  scene.instances.push_back(track);
  // Wall: one big Gaussian far away (blue).
  AddGaussian(&scene, {0, 0, 20}, 10.0, 0.999, {0, 0, 1});
  // Car: a small cluster around its first box centre, offset along box x.
  for (int k = -2; k <= 2; ++k) {
    const size_t i = AddGaussian(&scene, {-1 + 0.2 * k, 0, 5}, 0.1, 0.95, {1, 0, 0}, 1);
    scene.log_scales[3 * i + 1] = std::log(0.05f);
  }
  return scene;
}

// Returns the centroid of the pixels whose instance id is `id`, and their count.
int Centroid(const RenderBuffers& b, uint32_t id, double* x, double* y) {
  double sx = 0, sy = 0;
  int n = 0;
  for (int v = 0; v < b.height; ++v) {
    for (int u = 0; u < b.width; ++u) {
      if (b.instance[Pixel(b, u, v)] != id) continue;
      sx += u + 0.5;
      sy += v + 0.5;
      ++n;
    }
  }
  *x = n > 0 ? sx / n : 0;
  *y = n > 0 ? sy / n : 0;
  return n;
}

TEST(Rasterizer, MovingInstanceAppearsWhereItsBoxIs) {
  const RenderCamera camera = SimpleCamera(128, 96, 100);
  const GaussianScene scene = ActorScene();
  // Mid-track, at the end and after it (the end box is held).
  for (int64_t t : {int64_t{0}, int64_t{500'000}, int64_t{1'000'000}, int64_t{3'000'000}}) {
    const TrackBox box = InterpolateBox(scene.instances[0].boxes, t);
    double u, v;
    ASSERT_TRUE(camera.model.Project(box.center, &u, &v));
    absl::StatusOr<RenderBuffers> out = Render(scene, camera, t, {});
    ASSERT_TRUE(out.ok());
    double x, y;
    ASSERT_GT(Centroid(*out, 1, &x, &y), 20) << "t = " << t;
    EXPECT_NEAR(x, u, 0.75) << "t = " << t;
    EXPECT_NEAR(y, v, 0.75) << "t = " << t;
  }
  // The box rotates by 90 degrees about y: the car, long along box x at the
  // start, is long along the camera's z at the end (narrow in the image).
  auto extent_x = [&](int64_t t) {
    absl::StatusOr<RenderBuffers> out = Render(scene, camera, t, {});
    int lo = 1 << 20, hi = -1;
    for (int v = 0; v < out->height; ++v)
      for (int u = 0; u < out->width; ++u)
        if (out->instance[Pixel(*out, u, v)] == 1) lo = std::min(lo, u), hi = std::max(hi, u);
    return hi - lo;
  };
  EXPECT_GT(extent_x(0), 2 * extent_x(1'000'000));
}

TEST(Rasterizer, RemovedInstanceLeavesBackgroundVisible) {
  const RenderCamera camera = SimpleCamera(128, 96, 100);
  const GaussianScene scene = ActorScene();
  ActorEdit remove;
  remove.instance_id = "car";
  absl::StatusOr<RenderBuffers> with = Render(scene, camera, 0, {});
  absl::StatusOr<RenderBuffers> without = Render(scene, camera, 0, {remove});
  ASSERT_TRUE(with.ok() && without.ok());
  // Where the car was: now the wall (blue), instance 0.
  double u, v;
  ASSERT_TRUE(camera.model.Project({-1, 0, 5}, &u, &v));
  const size_t p = Pixel(*with, static_cast<int>(u), static_cast<int>(v));
  EXPECT_EQ(with->instance[p], 1u);
  EXPECT_GT(with->rgb[3 * p], 0.8);
  EXPECT_EQ(without->instance[p], 0u);
  EXPECT_NEAR(without->rgb[3 * p], 0, 1e-6);
  EXPECT_GT(without->rgb[3 * p + 2], 0.9);
  EXPECT_NEAR(without->depth[p], 20, 0.1);
  for (uint32_t id : without->instance) ASSERT_EQ(id, 0u);
}

TEST(Rasterizer, TrajectoryEditMovesTheActor) {
  const RenderCamera camera = SimpleCamera(128, 96, 100);
  const GaussianScene scene = ActorScene();
  ActorEdit edit;
  edit.kind = ActorEdit::Kind::kTrajectory;
  edit.instance_id = "car";
  TrackBox box = scene.instances[0].boxes[0];
  box.center = {0.5, -0.6, 6};
  edit.boxes = {box};
  absl::StatusOr<RenderBuffers> out = Render(scene, camera, 500'000, {edit});
  ASSERT_TRUE(out.ok());
  double u, v, x, y;
  ASSERT_TRUE(camera.model.Project(box.center, &u, &v));
  ASSERT_GT(Centroid(*out, 1, &x, &y), 20);
  EXPECT_NEAR(x, u, 0.75);
  EXPECT_NEAR(y, v, 0.75);
}

TEST(Rasterizer, InstanceIdIsTheLargestContributor) {
  const RenderCamera camera = SimpleCamera();
  GaussianScene scene;
  for (const char* id : {"a", "b"}) {
    InstanceTrack track;
    track.id = id;
    track.boxes = {TrackBox{}};
    scene.instances.push_back(track);
  }
  // Front: weight 0.3; back: 0.7 * 0.9 = 0.63, so the back one wins.
  AddGaussian(&scene, PointAtPixel(30, 30, 2.0, camera), 0.2, 0.3, {1, 0, 0}, 1);
  AddGaussian(&scene, PointAtPixel(30, 30, 3.0, camera), 0.2, 0.9, {0, 1, 0}, 2);
  absl::StatusOr<RenderBuffers> out = Render(scene, camera, 0, {});
  ASSERT_TRUE(out.ok());
  EXPECT_EQ(out->instance[Pixel(*out, 30, 30)], 2u);
  scene.opacity_logits[0] = LogitOfOpacity(0.7);  // Now 0.7 versus 0.27.
  out = Render(scene, camera, 0, {});
  EXPECT_EQ(out->instance[Pixel(*out, 30, 30)], 1u);
  EXPECT_EQ(out->instance[Pixel(*out, 0, 0)], 0u);
}

// Renders a tiny Gaussian at each point and checks that its alpha-weighted
// centroid lands where CameraModel::Project puts the point.
void ExpectPointsLandWhereProjected(const RenderCamera& camera, double tolerance_px) {
  const CameraModel& m = camera.model;
  int checked = 0;
  for (double fy : {0.08, 0.3, 0.5, 0.75, 0.93}) {
    for (double fx : {0.06, 0.25, 0.5, 0.7, 0.95}) {
      Vec3 ray;
      ASSERT_TRUE(m.Unproject(fx * m.width(), fy * m.height(), &ray));
      const Vec3 point = 4.0 * ray;
      double u, v;
      ASSERT_TRUE(m.Project(point, &u, &v));
      GaussianScene scene;
      // About 0.5 px: the 0.3 px^2 low-pass dominates the footprint.
      AddGaussian(&scene, camera.world_from_camera * point, 0.5 * 4.0 / m.fx(), 0.9, {1, 1, 1});
      absl::StatusOr<RenderBuffers> out = Render(scene, camera, 0, {});
      ASSERT_TRUE(out.ok());
      double sw = 0, sx = 0, sy = 0;
      for (int y = 0; y < m.height(); ++y) {
        for (int x = 0; x < m.width(); ++x) {
          const double a = out->alpha[Pixel(*out, x, y)];
          sw += a, sx += a * (x + 0.5), sy += a * (y + 0.5);
        }
      }
      ASSERT_GT(sw, 0);
      EXPECT_NEAR(sx / sw, u, tolerance_px) << "point at " << fx << ", " << fy;
      EXPECT_NEAR(sy / sw, v, tolerance_px) << "point at " << fx << ", " << fy;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 25);
}

TEST(Rasterizer, PinholePointsLandWhereProjected) {
  RenderCamera camera = SimpleCamera(160, 120, 110);
  camera.world_from_camera.translation = {1, 2, 3};
  ExpectPointsLandWhereProjected(camera, 0.05);
}

TEST(Rasterizer, OpenCvPointsLandWhereProjected) {
  RenderCamera camera = SimpleCamera(160, 120, 110);
  camera.model.SetOpenCv(-0.3, 0.1, 0.001, -0.002, -0.01);
  camera.world_from_camera.rotation = ToMatrix(YawQuat(0.3));
  ExpectPointsLandWhereProjected(camera, 0.05);
}

TEST(Rasterizer, FisheyePointsLandWhereProjected) {
  RenderCamera camera = SimpleCamera(160, 120, 60);
  camera.model.SetFisheye(0.08, -0.02, 0.005, -0.001);
  ExpectPointsLandWhereProjected(camera, 0.05);
}

TEST(Rasterizer, FThetaPointsLandWhereProjected) {
  RenderCamera camera = SimpleCamera(160, 120, 60);
  camera.model.SetFTheta({0, 70, 0, -3.5, 0, 0});
  camera.world_from_camera.rotation = ToMatrix(YawQuat(-0.2));
  ExpectPointsLandWhereProjected(camera, 0.05);
}

// Every layer of two renders, and what they tested, bit for bit.
void ExpectSameBits(const RenderBuffers& a, const RenderBuffers& b) {
  EXPECT_EQ(a.features, b.features);
  EXPECT_EQ(a.rgb, b.rgb);
  EXPECT_EQ(a.alpha, b.alpha);
  EXPECT_EQ(a.depth, b.depth);
  EXPECT_EQ(a.instance, b.instance);
  EXPECT_EQ(a.stats.pairs_tested, b.stats.pairs_tested);
  EXPECT_EQ(a.stats.pairs_contributing, b.stats.pairs_contributing);
}

TEST(Rasterizer, DeterministicAcrossRuns) {
  const BenchScene bench = MakeBenchScene(30000, 200, 150, 5, 3);
  absl::StatusOr<RenderBuffers> a = Render(bench.scene, bench.camera, bench.timestamp_us, {});
  absl::StatusOr<RenderBuffers> b = Render(bench.scene, bench.camera, bench.timestamp_us, {});
  ASSERT_TRUE(a.ok() && b.ok());
  ExpectSameBits(*a, *b);
}

TEST(Rasterizer, EveryKernelGivesTheBaselinesBits) {
  // Flat colours, then colour gradients (the kernels' other instantiation),
  // with every kernel this CPU runs against the baseline's.
  BenchScene bench = MakeBenchScene(20000, 200, 150, 7, 5);
  std::vector<float> flat_rgb;
  int compared = 0;
  for (bool gradients : {false, true}) {
    SCOPED_TRACE(gradients);
    if (gradients) {
      std::mt19937 rng(3);
      std::uniform_real_distribution<float> u(-0.5f, 0.5f);
      bench.scene.colour_gradients.resize(6 * bench.scene.size());
      for (float& g : bench.scene.colour_gradients) g = u(rng);
    }
    ASSERT_TRUE(raster::UseTileKernelForTesting("baseline"));
    EXPECT_STREQ(raster::TileKernelName(), "baseline");
    absl::StatusOr<RenderBuffers> base = Render(bench.scene, bench.camera, bench.timestamp_us, {});
    ASSERT_TRUE(base.ok());
    for (const char* kernel : {"avx2", "avx512"}) {
      SCOPED_TRACE(kernel);
      if (!raster::UseTileKernelForTesting(kernel)) continue;
      EXPECT_STREQ(raster::TileKernelName(), kernel);
      absl::StatusOr<RenderBuffers> fast =
          Render(bench.scene, bench.camera, bench.timestamp_us, {});
      ASSERT_TRUE(fast.ok());
      ExpectSameBits(*fast, *base);
      ++compared;
    }
    raster::UseTileKernelForTesting(nullptr);
    if (!gradients) flat_rgb = base->rgb;
    if (gradients) EXPECT_NE(base->rgb, flat_rgb);  // The gradients were used.
  }
  EXPECT_FALSE(raster::UseTileKernelForTesting("avx1024"));
  if (compared == 0) {
    GTEST_SKIP() << "this CPU runs the " << raster::TileKernelName()
                 << " kernel only: there is no other kernel to compare";
  }
}

TEST(Rasterizer, BlendPeakBlendsFrontToBackAlikeOnEveryKernel) {
  // Five round Gaussians over one tile; at every pixel the peak loop's
  // transmittance and RGB are the front-to-back blend computed here in double
  // (its exp is a polynomial: 1e-5), and every kernel gives the same bits.
  std::vector<raster::PeakGaussian> gaussians;
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  for (int k = 0; k < 5; ++k) {
    const float sigma = 1.f + 4.f * u(rng);
    gaussians.push_back({16 * u(rng),
                         16 * u(rng),
                         1 / (sigma * sigma),
                         0.f,
                         1 / (sigma * sigma),
                         0.2f + 0.7f * u(rng),
                         {u(rng), u(rng), u(rng)}});
  }
  std::vector<float> base(4 * raster::kTilePixels);
  raster::BlendPeakTileBaseline(gaussians.data(), 5, base.data());
  for (int p = 0; p < raster::kTilePixels; ++p) {
    const double x = p % raster::kTile + 0.5, y = p / raster::kTile + 0.5;
    double t = 1, rgb[3] = {0, 0, 0};
    for (const raster::PeakGaussian& g : gaussians) {
      const double dx = x - g.mx, dy = y - g.my;
      const double d2 = g.ca * dx * dx + 2 * g.cb * dx * dy + g.cc * dy * dy;
      const double alpha = std::min(0.99, g.opacity * std::exp(-0.5 * d2));
      for (int c = 0; c < 3; ++c) rgb[c] += alpha * t * g.rgb[c];
      t *= 1 - alpha;
    }
    ASSERT_NEAR(base[p], t, 1e-5) << "pixel " << p;
    for (int c = 0; c < 3; ++c) {
      ASSERT_NEAR(base[(c + 1) * raster::kTilePixels + p], rgb[c], 1e-5) << "pixel " << p;
    }
  }
  EXPECT_LT(*std::min_element(base.begin(), base.begin() + raster::kTilePixels), 0.5f);
  using Blend = void (*)(const raster::PeakGaussian*, int, float*);
  for (const auto& [name, blend] :
       {std::pair<const char*, Blend>{"avx2", raster::BlendPeakTileAvx2},
        {"avx512", raster::BlendPeakTileAvx512}}) {
    if (!raster::UseTileKernelForTesting(name)) continue;  // The CPU lacks it.
    raster::UseTileKernelForTesting(nullptr);
    std::vector<float> out(4 * raster::kTilePixels);
    blend(gaussians.data(), 5, out.data());
    EXPECT_EQ(std::memcmp(out.data(), base.data(), out.size() * sizeof(float)), 0) << name;
  }
  std::vector<float> widest(4 * raster::kTilePixels);
  raster::BlendPeakTile(gaussians.data(), 5, widest.data());
  EXPECT_EQ(widest, base) << raster::BlendPeakKernelName();
}

TEST(Rasterizer, BenchSceneIsReproducibleAndCoversTheImage) {
  const BenchScene a = MakeBenchScene(20000, 160, 120, 4, 9);
  const BenchScene b = MakeBenchScene(20000, 160, 120, 4, 9);
  ASSERT_EQ(a.scene.size(), 20000u);
  EXPECT_EQ(a.scene.means, b.scene.means);
  EXPECT_EQ(a.scene.features, b.scene.features);
  EXPECT_EQ(a.description, b.description);
  EXPECT_NE(MakeBenchScene(20000, 160, 120, 4, 10).scene.means, a.scene.means);
  absl::StatusOr<RenderBuffers> out = Render(a.scene, a.camera, a.timestamp_us, {});
  ASSERT_TRUE(out.ok());
  double coverage = 0;
  for (float alpha : out->alpha) coverage += alpha;
  EXPECT_GT(coverage / out->alpha.size(), 0.6);
  // Tight extents: few evaluated pairs are wasted.
  EXPECT_LT(static_cast<double>(out->stats.pairs_tested) / out->stats.pairs_contributing, 2.0);
}

TEST(Rasterizer, OptionsLeaveOutBuffers) {
  const BenchScene bench = MakeBenchScene(5000, 64, 48, 6, 1);
  RenderOptions options;
  options.features = options.depth = options.instance = false;
  absl::StatusOr<RenderBuffers> lean =
      Render(bench.scene, bench.camera, bench.timestamp_us, {}, options);
  absl::StatusOr<RenderBuffers> full = Render(bench.scene, bench.camera, bench.timestamp_us, {});
  ASSERT_TRUE(lean.ok() && full.ok());
  EXPECT_TRUE(lean->features.empty() && lean->depth.empty() && lean->instance.empty());
  EXPECT_EQ(lean->channels, 6);
  EXPECT_EQ(lean->rgb, full->rgb);
  EXPECT_EQ(lean->alpha, full->alpha);
}

TEST(Rasterizer, EmptySceneAndOddImageSizes) {
  GaussianScene empty;
  absl::StatusOr<RenderBuffers> out = Render(empty, SimpleCamera(1, 1, 1), 0, {});
  ASSERT_TRUE(out.ok()) << out.status();
  EXPECT_EQ(out->alpha, std::vector<float>{0.f});
  EXPECT_EQ(out->depth, std::vector<float>{0.f});
  // A Gaussian much larger than the image and the tiles, on a 17x3 image.
  GaussianScene big;
  AddGaussian(&big, {0, 0, 2}, 50.0, 0.5, {1, 2, 3});
  out = Render(big, SimpleCamera(17, 3, 10), 0, {});
  ASSERT_TRUE(out.ok()) << out.status();
  for (size_t p = 0; p < out->alpha.size(); ++p) {
    EXPECT_NEAR(out->alpha[p], 0.5, 1e-3);
    EXPECT_NEAR(out->features[3 * p + 2], 1.5, 3e-3);
    EXPECT_NEAR(out->depth[p], 2.0, 1e-5);
  }
}

TEST(Rasterizer, RejectsBadInput) {
  const GaussianScene scene = ActorScene();
  RenderCamera camera = SimpleCamera();
  ActorEdit edit;
  edit.instance_id = "bus";
  absl::StatusOr<RenderBuffers> out = Render(scene, camera, 0, {edit});
  EXPECT_EQ(out.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(std::string(out.status().message()).find("bus"), std::string::npos);

  edit.instance_id = "car";
  edit.kind = ActorEdit::Kind::kTrajectory;
  EXPECT_EQ(Render(scene, camera, 0, {edit}).status().code(), absl::StatusCode::kInvalidArgument);

  EXPECT_EQ(Render(scene, SimpleCamera(0, 10), 0, {}).status().code(),
            absl::StatusCode::kInvalidArgument);

  GaussianScene broken = scene;
  broken.features.pop_back();
  out = Render(broken, camera, 0, {});
  EXPECT_EQ(out.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(std::string(out.status().message()).find("features"), std::string::npos);

  broken = scene;
  broken.owners[0] = 7;
  out = Render(broken, camera, 0, {});
  EXPECT_NE(std::string(out.status().message()).find("owners[0]"), std::string::npos);

  broken = scene;
  broken.colour_gradients.assign(6 * scene.size() - 1, 0.f);
  out = Render(broken, camera, 0, {});
  EXPECT_NE(std::string(out.status().message()).find("colour_gradients"), std::string::npos);
}

// -- Rolling shutter -------------------------------------------------------

// PSNR of the premultiplied RGB of `a` against `b`, over rows [row0, row1).
double RowsPsnr(const RenderBuffers& a, const RenderBuffers& b, int row0, int row1) {
  double sum = 0;
  size_t n = 0;
  for (int y = row0; y < row1; ++y) {
    for (int x = 0; x < a.width; ++x) {
      for (int c = 0; c < 3; ++c) {
        const double d = double(a.rgb[3 * Pixel(a, x, y) + c]) - b.rgb[3 * Pixel(b, x, y) + c];
        sum += d * d;
        ++n;
      }
    }
  }
  return sum == 0 ? 200 : 10 * std::log10(double(n) / sum);
}

// The street camera moving 0.5 m to its right and turning 1 degree during
// the readout (a car at 17 m/s over a 30 ms readout, turning).
RollingShutter StreetReadout(const RenderCamera& camera) {
  RollingShutter shutter;
  shutter.readout = RollingShutter::Readout::kTopToBottom;
  shutter.readout_us = 30'000;
  Rigid move;
  move.rotation = ToMatrix(QuatNormalized({std::cos(kPi / 360), 0, std::sin(kPi / 360), 0}));
  move.translation = {0.5, 0, 0};
  shutter.world_from_camera_end = camera.world_from_camera * move;
  return shutter;
}

// Each row of a rolling-shutter render, against the same row of a whole
// render from that row's pose (what a ray caster gives: every pixel from its
// line's pose). The rasterizer projects each Gaussian whole from its
// centre's line, so only Gaussians that span several lines differ.
TEST(Rasterizer, ARollingShutterRendersEachLineFromItsPose) {
  const BenchScene bench = MakeBenchScene(30000, 160, 120, 3, 7);
  RenderCamera rolling = bench.camera;
  rolling.rolling_shutter = StreetReadout(bench.camera);
  absl::StatusOr<RenderBuffers> ours = Render(bench.scene, rolling, bench.timestamp_us, {});
  ASSERT_TRUE(ours.ok()) << ours.status();
  absl::StatusOr<RenderBuffers> global = Render(bench.scene, bench.camera, bench.timestamp_us, {});
  ASSERT_TRUE(global.ok());
  RenderBuffers truth = *global;
  const int h = truth.height;
  for (int y = 0; y < h; ++y) {
    const double f = double(y) / (h - 1);
    RenderCamera line = bench.camera;
    line.world_from_camera = InterpolateRigid(bench.camera.world_from_camera,
                                              rolling.rolling_shutter->world_from_camera_end, f);
    absl::StatusOr<RenderBuffers> at_line =
        Render(bench.scene, line, bench.timestamp_us + std::llround(f * 30'000), {});
    ASSERT_TRUE(at_line.ok());
    const size_t row = static_cast<size_t>(y) * truth.width;
    std::copy_n(&at_line->rgb[3 * row], 3 * truth.width, &truth.rgb[3 * row]);
  }
  const double ours_psnr = RowsPsnr(*ours, truth, 0, h);
  const double global_psnr = RowsPsnr(*global, truth, 0, h);
  // Measured 48.5 dB, against 23.8 dB for the global render.
  EXPECT_GT(ours_psnr, 40.0);
  EXPECT_GT(ours_psnr, global_psnr + 15) << global_psnr;
  // The first lines are read at the camera's own pose: there the global
  // render is right too; the last ones, 0.5 m away, it is not.
  EXPECT_GT(RowsPsnr(*global, truth, 0, 4), 30.0);
  EXPECT_LT(RowsPsnr(*global, truth, h - 4, h), RowsPsnr(*ours, truth, h - 4, h) - 8);

  // Read bottom to top from the end pose back to the start: the same lines
  // at the same poses.
  RenderCamera reversed = bench.camera;
  reversed.world_from_camera = rolling.rolling_shutter->world_from_camera_end;
  reversed.rolling_shutter = rolling.rolling_shutter;
  reversed.rolling_shutter->readout = RollingShutter::Readout::kBottomToTop;
  reversed.rolling_shutter->world_from_camera_end = bench.camera.world_from_camera;
  absl::StatusOr<RenderBuffers> bottom_up = Render(bench.scene, reversed, bench.timestamp_us, {});
  ASSERT_TRUE(bottom_up.ok());
  EXPECT_GT(RowsPsnr(*bottom_up, *ours, 0, h), 60.0);

  // A readout that neither moves nor takes time is the global render (to
  // float rounding).
  RenderCamera still = bench.camera;
  still.rolling_shutter =
      RollingShutter{RollingShutter::Readout::kLeftToRight, 0, bench.camera.world_from_camera};
  absl::StatusOr<RenderBuffers> unmoved = Render(bench.scene, still, bench.timestamp_us, {});
  ASSERT_TRUE(unmoved.ok());
  EXPECT_GT(RowsPsnr(*unmoved, *global, 0, h), 80.0);
}

// Actors are where they are at their line's time: a car crossing the image
// during a 1 s readout, read left to right, is drawn where its box is when
// its column is read.
TEST(Rasterizer, ARollingShutterShowsActorsAtTheirLinesTime) {
  const RenderCamera camera = SimpleCamera(128, 96, 100);
  const GaussianScene scene = ActorScene();
  RenderCamera rolling = camera;
  rolling.rolling_shutter =
      RollingShutter{RollingShutter::Readout::kTopToBottom, 1'000'000, camera.world_from_camera};
  absl::StatusOr<RenderBuffers> out = Render(scene, rolling, 0, {});
  ASSERT_TRUE(out.ok()) << out.status();
  double x, y;
  ASSERT_GT(Centroid(*out, 1, &x, &y), 10);
  // The car's row at the time that row is read: y0 + (v(t) - ...) solved by
  // scanning the track for the time whose projected row is read then.
  double best_u = 0, best_gap = 1e9;
  for (int64_t t = 0; t <= 1'000'000; t += 1000) {
    const TrackBox box = InterpolateBox(scene.instances[0].boxes, t);
    double u, v;
    ASSERT_TRUE(camera.model.Project(box.center, &u, &v));
    const double gap = std::abs((v - 0.5) / 95.0 - t * 1e-6);
    if (gap < best_gap) best_gap = gap, best_u = u;
  }
  ASSERT_LT(best_gap, 0.01);
  EXPECT_NEAR(x, best_u, 1.0);
  // At the start of the track it would be 19 px to the left.
  double u0, v0;
  ASSERT_TRUE(camera.model.Project(InterpolateBox(scene.instances[0].boxes, 0).center, &u0, &v0));
  EXPECT_GT(x - u0, 5);
}

TEST(InstancePose, InterpolatesLinearCentreAndSlerpRotation) {
  TrackBox a, b;
  a.timestamp_us = 1'000'000;
  a.center = {0, 0, 0};
  a.rotation = YawQuat(0);
  b.timestamp_us = 3'000'000;
  b.center = {4, 2, 0};
  b.rotation = YawQuat(kPi / 2);
  const std::vector<TrackBox> boxes = {a, b};

  const TrackBox mid = InterpolateBox(boxes, 1'500'000);
  EXPECT_NEAR(mid.center.x, 1, 1e-12);
  EXPECT_NEAR(mid.center.y, 0.5, 1e-12);
  const Quat q = YawQuat(kPi / 8);
  EXPECT_NEAR(mid.rotation.w, q.w, 1e-12);
  EXPECT_NEAR(mid.rotation.z, q.z, 1e-12);
  // Held outside the track.
  EXPECT_NEAR(InterpolateBox(boxes, 0).center.x, 0, 1e-12);
  EXPECT_NEAR(InterpolateBox(boxes, 9'000'000).center.x, 4, 1e-12);

  // world_from_canonical maps the first box's centre to the box centre at t,
  // and rotates by the yaw change.
  const Rigid pose = InstancePoseAt(boxes, 3'000'000);
  const Vec3 c = pose * a.center;
  EXPECT_NEAR(c.x, 4, 1e-12);
  EXPECT_NEAR(c.y, 2, 1e-12);
  const Vec3 ahead = pose * Vec3{1, 0, 0};  // One metre along the first box's x.
  EXPECT_NEAR(ahead.x, 4, 1e-12);
  EXPECT_NEAR(ahead.y, 3, 1e-12);
  EXPECT_NEAR(InstancePoseAt(boxes, 0).translation.x, 0, 1e-12);
}

}  // namespace
}  // namespace pf
