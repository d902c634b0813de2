// Tests of decoding fused queries into Gaussians.
#include "engine/recon/gaussian_decoder.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace pf {
namespace {

TEST(GaussianDecoder, DiscFrameLiesOnTheSurfaceAndStretchesWithSlant) {
  double stretch = 0;
  const Vec3 normal{0, 0, 1};
  const Vec3 ray = Normalized(Vec3{1, 0, -1});  // 45 degrees to the surface.
  const Mat3 r = ToMatrix(DiscFrame(normal, ray, 4.0, &stretch));
  EXPECT_NEAR(stretch, std::sqrt(2.0), 1e-9);
  EXPECT_NEAR(r.Col(2).z, 1.0, 1e-9);  // Third axis is the normal.
  EXPECT_NEAR(r.Col(0).x, 1.0, 1e-9);  // First axis along the ray's tangent part.
  EXPECT_NEAR(Determinant(r), 1.0, 1e-9);
  // Grazing views are capped.
  DiscFrame(normal, Normalized(Vec3{1, 0, -0.01}), 4.0, &stretch);
  EXPECT_DOUBLE_EQ(stretch, 4.0);
  // Head-on: no stretch, still a valid frame.
  const Mat3 head_on = ToMatrix(DiscFrame(normal, Vec3{0, 0, -1}, 4.0, &stretch));
  EXPECT_DOUBLE_EQ(stretch, 1.0);
  EXPECT_NEAR(head_on.Col(2).z, 1.0, 1e-9);
}

TEST(GaussianDecoder, DecodesScaleOpacityFeaturesAndTime) {
  QuerySet q;
  q.positions = {1, 2, 3, 4, 5, 6};
  q.rgb = {0, 0, 0, 0, 0, 0};
  q.normals = {0, 0, -1, 0, 0, -1};
  q.rays = {0, 0, 1, 0, 0, 1};
  q.depths = {3, 6};
  q.footprints = {0.5f, 0.1f};
  q.views = {0, 1};
  q.pixels = {0, 0};
  q.owners = {0, 1};
  q.far = {0, 0};
  FusedQueries f;
  f.rgb = {0.2f, 0.4f, 0.6f, 1.5f, 0.5f, -1.f};
  f.agreement = {1.f, 0.f};
  f.lifespans = {std::numeric_limits<float>::infinity(), 0.25f};
  f.observations = {3, 1};
  InstanceTrack car;
  car.id = "car";
  car.boxes = {{0, {0, 0, 0}, {1, 1, 1}, Quat{}}};
  DecoderOptions options;
  const GaussianScene scene = DecodeGaussians(q, f, {1000000, 1500000}, 1000000, {car}, options);
  ASSERT_EQ(scene.size(), 2u);
  EXPECT_EQ(scene.num_channels, kReconChannels);
  EXPECT_EQ(scene.low_pass, 0.1f);  // Not the 3DGS default the renderer assumes otherwise.
  EXPECT_FLOAT_EQ(scene.means[4], 5.f);
  EXPECT_NEAR(std::exp(scene.log_scales[0]), 0.65 * 0.5, 1e-6);  // Head-on: no stretch.
  EXPECT_NEAR(std::exp(scene.log_scales[1]), 0.65 * 0.5, 1e-6);
  EXPECT_NEAR(std::exp(scene.log_scales[2]), 0.1 * 0.5, 1e-6);
  EXPECT_NEAR(1 / (1 + std::exp(-scene.opacity_logits[0])), 0.98, 1e-5);
  EXPECT_NEAR(1 / (1 + std::exp(-scene.opacity_logits[1])), 0.5, 1e-5);
  EXPECT_FLOAT_EQ(scene.features[1], 0.4f);
  EXPECT_FLOAT_EQ(scene.features[kReconChannels + 0], 1.f);  // Clamped to [0, 1].
  EXPECT_FLOAT_EQ(scene.features[kReconChannels + 2], 0.f);
  EXPECT_FLOAT_EQ(scene.features[5], -1.f);  // Normal z.
  EXPECT_FLOAT_EQ(scene.features[6], 1.f);   // Agreement.
  EXPECT_FLOAT_EQ(scene.times[0], 0.f);
  EXPECT_FLOAT_EQ(scene.times[1], 0.5f);
  EXPECT_TRUE(std::isinf(scene.lifespans[0]));
  EXPECT_FLOAT_EQ(scene.lifespans[1], 0.25f);
  EXPECT_EQ(scene.owners[1], 1u);
  ASSERT_EQ(scene.instances.size(), 1u);
  EXPECT_EQ(scene.instances[0].id, "car");
}

TEST(GaussianDecoder, QueriesThatThreeViewsSeePastAllButVanish) {
  // (agreement, observations): contradictions are observations x (1 / a - 1).
  const std::vector<std::pair<float, uint16_t>> cases = {
      {0.25f, 1},  // 3 views see past it: a floater.
      {0.4f, 2},   // 3 as well.
      {0.5f, 2},   // 2: the usual opacity.
      {0.2f, 1},   // 4.
      {1.f, 5}};   // None.
  QuerySet q;
  FusedQueries f;
  for (size_t i = 0; i < cases.size(); ++i) {
    for (float x : {0.f, 0.f, 5.f + float(i)}) q.positions.push_back(x);
    for (float x : {0.5f, 0.5f, 0.5f}) q.rgb.push_back(x);
    for (float x : {0.f, 0.f, -1.f}) q.normals.push_back(x);
    for (float x : {0.f, 0.f, 1.f}) q.rays.push_back(x);
    q.depths.push_back(5.f + float(i));
    q.footprints.push_back(0.1f);
    q.views.push_back(0);
    q.pixels.push_back(0);
    q.owners.push_back(0);
    q.far.push_back(0);
    for (float x : {0.5f, 0.5f, 0.5f}) f.rgb.push_back(x);
    f.agreement.push_back(cases[i].first);
    f.observations.push_back(cases[i].second);
    f.lifespans.push_back(std::numeric_limits<float>::infinity());
  }
  auto opacity = [](const GaussianScene& scene, size_t i) {
    return 1 / (1 + std::exp(-double(scene.opacity_logits[i])));
  };
  const GaussianScene scene = DecodeGaussians(q, f, {0}, 0, {}, DecoderOptions{});
  EXPECT_NEAR(opacity(scene, 0), 0.01 + 0.97 * 0.25 * 0.25 * 0.25, 1e-5);
  EXPECT_NEAR(opacity(scene, 1), 0.01 + 0.97 * 0.4 * 0.4 * 0.4, 1e-5);
  EXPECT_NEAR(opacity(scene, 2), 0.5 + 0.48 * 0.5, 1e-5);
  EXPECT_NEAR(opacity(scene, 3), 0.01 + 0.97 * 0.2 * 0.2 * 0.2, 1e-5);
  EXPECT_NEAR(opacity(scene, 4), 0.98, 1e-5);
  // Off: the agreement alone, as for every query before.
  DecoderOptions off;
  off.contradicted_views = 0;
  const GaussianScene plain = DecodeGaussians(q, f, {0}, 0, {}, off);
  EXPECT_NEAR(opacity(plain, 0), 0.5 + 0.48 * 0.25, 1e-5);
  EXPECT_NEAR(opacity(plain, 3), 0.5 + 0.48 * 0.2, 1e-5);
}

TEST(GaussianDecoder, HiddenQueriesKeepTheirColourAndAreMarked) {
  // Query 1 is hidden: fusion saw the foreground in front of it (fused
  // colour green), its own colour is the background's (red). It keeps red,
  // is opaque like a fully agreeing surface and has agreement 0; query 0 is
  // decoded as usual (a fused agreement of 0 is not written as 0).
  QuerySet q;
  q.positions = {0, 0, 5, 0, 0, 10};
  q.rgb = {0, 0, 1, 1, 0, 0};
  q.normals = {0, 0, -1, 0, 0, -1};
  q.rays = {0, 0, 1, 0, 0, 1};
  q.depths = {5, 10};
  q.footprints = {0.1f, 0.2f};
  q.views = {0, 0};
  q.pixels = {0, 0};
  q.owners = {0, 0};
  q.far = {0, 0};
  q.hidden = {0, 1};
  FusedQueries f;
  f.rgb = {0, 1, 0, 0, 1, 0};
  f.agreement = {0.f, 0.5f};
  f.lifespans.assign(2, std::numeric_limits<float>::infinity());
  f.observations = {1, 1};
  const GaussianScene scene = DecodeGaussians(q, f, {0}, 0, {}, DecoderOptions{});
  ASSERT_EQ(scene.size(), 2u);
  EXPECT_FLOAT_EQ(scene.features[0], 0.f);  // Query 0: fused green.
  EXPECT_FLOAT_EQ(scene.features[1], 1.f);
  EXPECT_GT(scene.features[kAgreementChannel], 0.f);
  EXPECT_NEAR(1 / (1 + std::exp(-scene.opacity_logits[0])), 0.5, 1e-5);
  const float* hidden = &scene.features[kReconChannels];
  EXPECT_FLOAT_EQ(hidden[0], 1.f);  // Its own red, not the fused green.
  EXPECT_FLOAT_EQ(hidden[1], 0.f);
  EXPECT_FLOAT_EQ(hidden[kAgreementChannel], 0.f);
  EXPECT_NEAR(1 / (1 + std::exp(-scene.opacity_logits[1])), 0.98, 1e-5);
}

TEST(GaussianDecoder, StaticGaussiansFadeOverTheFramesAroundTheirOwn) {
  // Two cameras, CONTEXT every 0.2 s (one of them with a time twice), and a
  // third seen once: g = 0.2 s, so fade_frames 10 gives sigma = 10 x 0.2 - 1 =
  // 1 s to static Gaussians off the far layer, unless theirs is shorter; the
  // far layer and instances keep theirs; the fade span is the CONTEXT times.
  const std::vector<std::string> cameras = {"a", "a", "a", "b", "b", "b", "c"};
  const std::vector<int64_t> times = {1'000'000, 1'200'000, 1'400'000, 1'100'000,
                                      1'300'000, 1'300'000, 2'000'000};
  GaussianScene scene;
  scene.time_origin_us = 900'000;
  scene.Resize(5);
  scene.lifespans[1] = 0.25f;
  const std::vector<uint32_t> owners = {0, 0, 0, 1, 0};
  const std::vector<uint8_t> far = {0, 0, 1, 0, 0};
  const float kInf = std::numeric_limits<float>::infinity();
  EXPECT_NEAR(FadeSigma(cameras, times, 10).value_or(-1), 1.0, 1e-9);
  EXPECT_EQ(FadeSigma(cameras, times, 2).value_or(-1), 0.0);
  EXPECT_FALSE(FadeSigma(cameras, times, 0).has_value());
  EXPECT_FALSE(FadeSigma({"a", "b"}, {1'000'000, 1'200'000}, 10).has_value());
  {
    GaussianScene faded = scene;
    FadeStaticGaussians(cameras, times, owners, far, 10, &faded);
    EXPECT_NEAR(faded.lifespans[0], 1.0f, 1e-5f);
    EXPECT_EQ(faded.lifespans[1], 0.25f);  // Shorter already.
    EXPECT_EQ(faded.lifespans[2], kInf);   // The far layer.
    EXPECT_EQ(faded.lifespans[3], kInf);   // An instance's.
    EXPECT_NEAR(faded.lifespans[4], 1.0f, 1e-5f);
    EXPECT_NEAR(faded.fade_span.begin, 0.1f, 1e-6f);
    EXPECT_NEAR(faded.fade_span.end, 1.1f, 1e-6f);
  }
  {
    // Five frames: 5 x 0.2 - 1 = 0, the shortest (a 1 s fade).
    GaussianScene faded = scene;
    FadeStaticGaussians(cameras, times, owners, far, 5, &faded);
    EXPECT_EQ(faded.lifespans[0], 0.f);
    EXPECT_TRUE(faded.fade_span.bounded());
  }
  {
    // fade_frames 0: nothing changes.
    GaussianScene same = scene;
    FadeStaticGaussians(cameras, times, owners, far, 0, &same);
    EXPECT_EQ(same.lifespans, scene.lifespans);
    EXPECT_FALSE(same.fade_span.bounded());
  }
  {
    // No camera with two CONTEXT times: nothing changes.
    GaussianScene same = scene;
    FadeStaticGaussians({"a", "b"}, {1'000'000, 1'200'000}, owners, far, 10, &same);
    EXPECT_EQ(same.lifespans, scene.lifespans);
    EXPECT_FALSE(same.fade_span.bounded());
  }
}

}  // namespace
}  // namespace pf
