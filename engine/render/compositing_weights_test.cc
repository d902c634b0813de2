// Tests of the recorded compositing weights: hand-computed weights of
// stacked Gaussians, Render()'s image on random scenes (moving actors,
// lifespans, distortion) within the weights' 16-bit rounding, a tile with
// more Gaussians than one table holds, and that the transposed product is
// the adjoint.
#include "engine/render/compositing_weights.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <utility>

#include "engine/render/raster_tile.h"

namespace pf {
namespace {

// A pinhole camera at the world origin looking down +z.
RenderCamera SimpleCamera(int width, int height, double f) {
  RenderCamera camera;
  camera.model = CameraModel(width, height, f, f, width / 2.0, height / 2.0);
  return camera;
}

void AddGaussian(GaussianScene* scene, const Vec3& mean, const Vec3& scale, const Quat& rotation,
                 double opacity, const Vec3& rgb, uint32_t owner = 0) {
  const size_t i = scene->size();
  scene->Resize(i + 1);
  for (int c = 0; c < 3; ++c) {
    scene->means[3 * i + c] = static_cast<float>(mean[c]);
    scene->log_scales[3 * i + c] = static_cast<float>(std::log(scale[c]));
    scene->features[i * scene->num_channels + c] = static_cast<float>(rgb[c]);
  }
  scene->rotations[4 * i] = static_cast<float>(rotation.w);
  scene->rotations[4 * i + 1] = static_cast<float>(rotation.x);
  scene->rotations[4 * i + 2] = static_cast<float>(rotation.y);
  scene->rotations[4 * i + 3] = static_cast<float>(rotation.z);
  scene->opacity_logits[i] = LogitOfOpacity(opacity);
  scene->owners[i] = owner;
}

// Colours of `scene` in the local order of `a`.
std::vector<float> LocalColours(const GaussianScene& scene, const CompositingWeights& a) {
  std::vector<float> colours;
  for (uint32_t i : a.gaussians)
    for (int c = 0; c < 3; ++c) colours.push_back(scene.features[i * scene.num_channels + c]);
  return colours;
}

TEST(CompositingWeights, StackedGaussiansAtAPixelCentre) {
  // Two small Gaussians on the ray through the centre of pixel (5, 7), at 4
  // and 6 m, opacity 0.6 in front and 0.5 behind: at that pixel d^2 = 0, so
  // w_front = 0.6 and w_back = 0.5 x (1 - 0.6) = 0.2. A third one elsewhere
  // (pixel (12, 2)) contributes nowhere near.
  const RenderCamera camera = SimpleCamera(16, 16, 16);
  GaussianScene scene;
  auto at_pixel = [](double px, double py, double z) {
    return Vec3{(px + 0.5 - 8) / 16 * z, (py + 0.5 - 8) / 16 * z, z};
  };
  const Quat identity{1, 0, 0, 0};
  AddGaussian(&scene, at_pixel(5, 7, 6), {0.01, 0.01, 0.01}, identity, 0.5, {0, 0, 1});
  AddGaussian(&scene, at_pixel(5, 7, 4), {0.01, 0.01, 0.01}, identity, 0.6, {1, 0, 0});
  AddGaussian(&scene, at_pixel(12, 2, 5), {0.01, 0.01, 0.01}, identity, 0.9, {0, 1, 0});
  absl::StatusOr<CompositingWeights> a = ComputeCompositingWeights(scene, camera, 0);
  ASSERT_TRUE(a.ok()) << a.status();
  // Listed by first entry: pixel (12, 2) comes before (5, 7) in the one
  // tile, and at (5, 7) the front Gaussian before the one behind.
  EXPECT_EQ(a->gaussians, (std::vector<uint32_t>{2, 1, 0}));
  const size_t pixel = 7 * 16 + 5;
  ASSERT_EQ(a->pixel_count[pixel], 2u);
  const uint64_t k = a->pixel_begin[pixel];
  const uint32_t* table = a->PixelTable(pixel);
  // Weights to half a step of 16 bits.
  const float step = CompositingWeights::kWeightStep;
  EXPECT_EQ(a->gaussians[table[a->pairs[k].slot]], 1u);  // Front first.
  EXPECT_NEAR(a->Weight(k), 0.6f, 0.5f * step + 1e-7f);
  EXPECT_EQ(a->gaussians[table[a->pairs[k + 1].slot]], 0u);
  EXPECT_NEAR(a->Weight(k + 1), 0.2f, 0.5f * step + 1e-7f);
  EXPECT_NEAR(a->alpha[pixel], 0.8f, 1e-6);
  // Composite: 0.6 red + 0.2 blue.
  std::vector<float> image(16 * 16 * 3);
  const std::vector<float> colours = LocalColours(scene, *a);
  Composite(*a, colours.data(), 3, image.data());
  EXPECT_NEAR(image[3 * pixel], 0.6f, step);
  EXPECT_NEAR(image[3 * pixel + 1], 0.f, 1e-9);
  EXPECT_NEAR(image[3 * pixel + 2], 0.2f, step);
  // A^T of a residual that is 1 at that pixel only: each Gaussian gets its
  // weight there.
  std::vector<float> residual(16 * 16 * 3, 0.f), out(9, 0.f);
  residual[3 * pixel] = 1.f;
  AccumulateTransposed(*a, residual.data(), 3, out.data());
  EXPECT_NEAR(out[0], 0.f, 1e-9);   // Gaussian 2 (elsewhere).
  EXPECT_NEAR(out[3], 0.6f, step);  // Gaussian 1 (in front).
  EXPECT_NEAR(out[6], 0.2f, step);  // Gaussian 0 (behind).
  EXPECT_NEAR(out[4], 0.f, 1e-9);
}

// A random scene of flat and round Gaussians of sub-pixel to tile size, a
// moving actor and fading Gaussians.
GaussianScene RandomScene(unsigned seed, size_t count) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  GaussianScene scene;
  scene.num_channels = 5;
  InstanceTrack car;
  car.id = "car";
  car.boxes.push_back({0, {0, 0, 8}, {4, 2, 1.5}, Quat{1, 0, 0, 0}});
  car.boxes.push_back(
      {1000000, {1.5, 0, 9}, {4, 2, 1.5}, Quat{std::cos(0.2), 0, 0, std::sin(0.2)}});
  scene.instances.push_back(car);
  for (size_t i = 0; i < count; ++i) {
    const double z = 3 + 12 * u(rng);
    const Vec3 mean{(u(rng) - 0.5) * z, (u(rng) - 0.5) * 0.75 * z, z};
    const double s = 0.005 + 0.15 * u(rng);
    const Vec3 scale{s, s * (0.2 + u(rng)), s * (u(rng) < 0.5 ? 0.05 : 1.0)};
    Quat q{u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5};
    const uint32_t owner = u(rng) < 0.2 ? 1 : 0;
    AddGaussian(&scene, owner ? Vec3{mean.x * 0.3, mean.y * 0.3, 8 + u(rng) - 0.5} : mean, scale, q,
                0.05 + 0.94 * u(rng), {u(rng), u(rng), u(rng)}, owner);
    scene.times[i] = static_cast<float>(u(rng));
    if (u(rng) < 0.2) scene.lifespans[i] = static_cast<float>(0.3 * u(rng));
  }
  return scene;
}

void ExpectMatchesRender(const GaussianScene& scene, const RenderCamera& camera,
                         int64_t timestamp_us) {
  RenderOptions options;
  options.features = false;
  absl::StatusOr<RenderBuffers> render = Render(scene, camera, timestamp_us, {}, options);
  ASSERT_TRUE(render.ok()) << render.status();
  absl::StatusOr<CompositingWeights> a = ComputeCompositingWeights(scene, camera, timestamp_us);
  ASSERT_TRUE(a.ok()) << a.status();
  ASSERT_EQ(a->alpha.size(), render->alpha.size());
  std::vector<float> image(render->rgb.size());
  const std::vector<float> colours = LocalColours(scene, *a);
  Composite(*a, colours.data(), 3, image.data());
  // The render's own weights, rounded to 16 bits: each entry's colour (in
  // [0, 1]) is off by half a step at most; alpha is the render's bits.
  double max_excess = 0, max_alpha_error = 0, covered = 0, max_error = 0;
  for (size_t p = 0; p < render->alpha.size(); ++p) {
    max_alpha_error = std::max(max_alpha_error, double(std::abs(a->alpha[p] - render->alpha[p])));
    covered += render->alpha[p] > 0.5f;
    const double bound = 0.5 * CompositingWeights::kWeightStep * a->pixel_count[p] + 1e-6;
    for (int c = 0; c < 3; ++c) {
      const double error = std::abs(image[3 * p + c] - render->rgb[3 * p + c]);
      max_error = std::max(max_error, error);
      max_excess = std::max(max_excess, error - bound);
    }
  }
  EXPECT_LE(max_excess, 0.0);
  EXPECT_LT(max_error, 1e-4);
  EXPECT_EQ(max_alpha_error, 0.0);
  EXPECT_GT(covered, 0.2 * render->alpha.size());  // The scene really covers the image.
  EXPECT_EQ(a->entries(), static_cast<size_t>(render->stats.pairs_contributing));
}

TEST(CompositingWeights, ReproducesRenderOnRandomScenes) {
  const GaussianScene scene = RandomScene(3, 3000);
  ExpectMatchesRender(scene, SimpleCamera(96, 64, 80), 0);
  ExpectMatchesRender(scene, SimpleCamera(96, 64, 80), 600000);  // Actor moved, fading.
  RenderCamera turned = SimpleCamera(80, 72, 70);
  turned.world_from_camera.rotation = ToMatrix(Quat{std::cos(0.1), 0, std::sin(0.1), 0});
  turned.world_from_camera.translation = {0.3, -0.2, 0.5};
  ExpectMatchesRender(scene, turned, 300000);
  // Through a rolling shutter: each Gaussian from its line's pose and with
  // the actors at that line's time, as the rasterizer does.
  RenderCamera rolling = turned;
  Rigid end = turned.world_from_camera;
  end.rotation = ToMatrix(Quat{std::cos(0.14), 0, std::sin(0.14), 0});
  end.translation = end.translation + Vec3{0.4, 0.1, -0.2};
  rolling.rolling_shutter = RollingShutter{RollingShutter::Readout::kLeftToRight, 200000, end};
  ExpectMatchesRender(scene, rolling, 300000);
  RenderCamera distorted = SimpleCamera(96, 64, 80);
  distorted.model.SetOpenCv(-0.2, 0.05, 0.001, -0.001, 0);
  ExpectMatchesRender(scene, distorted, 0);
  // Under the low-pass our reconstruction writes (the weights follow the
  // scene's, not a constant).
  GaussianScene sharp = scene;
  sharp.low_pass = 0.1f;
  ExpectMatchesRender(sharp, SimpleCamera(96, 64, 80), 0);
  // In the order a scene's order band gives.
  GaussianScene banded = scene;
  banded.order_band = 0.02f;
  ExpectMatchesRender(banded, SimpleCamera(96, 64, 80), 0);
}

// Checks <A x, r> = <x, A^T r> for random x ([x_size]) and r ([r_size]),
// `forward(x, out)` writing A x and `transpose(r, out)` adding A^T r.
template <typename Forward, typename Transpose>
void ExpectAdjoint(size_t x_size, size_t r_size, uint32_t seed, Forward forward,
                   Transpose transpose) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1, 1);
  std::vector<float> x(x_size), r(r_size);
  for (float& v : x) v = u(rng);
  for (float& v : r) v = u(rng);
  std::vector<float> ax(r.size()), atr(x.size(), 0.f);
  forward(x.data(), ax.data());
  transpose(r.data(), atr.data());
  double left = 0, right = 0, scale = 0;
  for (size_t i = 0; i < r.size(); ++i) left += double(ax[i]) * r[i];
  for (size_t i = 0; i < x.size(); ++i) right += double(x[i]) * atr[i];
  for (size_t i = 0; i < x.size(); ++i) scale += std::abs(double(x[i]) * atr[i]);
  ASSERT_GT(scale, 1.0);
  EXPECT_NEAR(left, right, 1e-5 * scale);
}

TEST(CompositingWeights, TransposeIsTheAdjoint) {
  // <A c, r> = <c, A^T r> for random c and r, two channels.
  const GaussianScene scene = RandomScene(5, 800);
  absl::StatusOr<CompositingWeights> a =
      ComputeCompositingWeights(scene, SimpleCamera(64, 48, 60), 0);
  ASSERT_TRUE(a.ok()) << a.status();
  ExpectAdjoint(
      a->gaussians.size() * 2, 64 * 48 * 2, 1,
      [&](const float* c, float* out) { Composite(*a, c, 2, out); },
      [&](const float* r, float* out) { AccumulateTransposed(*a, r, 2, out); });
}

// Random colour gradients in [-0.5, 0.5] on every Gaussian of `scene`.
GaussianScene WithRandomGradients(GaussianScene scene, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-0.5f, 0.5f);
  scene.colour_gradients.resize(6 * scene.size());
  for (float& g : scene.colour_gradients) g = u(rng);
  return scene;
}

// The colours and gradients of `scene` in the local order of `a`, [M, 3, 3].
std::vector<float> LocalTexturedColours(const GaussianScene& scene, const CompositingWeights& a) {
  std::vector<float> params;
  for (uint32_t i : a.gaussians) {
    for (int c = 0; c < 3; ++c) {
      params.push_back(scene.features[i * scene.num_channels + c]);
      params.push_back(scene.colour_gradients[6 * i + 2 * c]);
      params.push_back(scene.colour_gradients[6 * i + 2 * c + 1]);
    }
  }
  return params;
}

TEST(CompositingWeights, WithLocalCoordinatesReproducesRenderOfColourGradients) {
  const GaussianScene scene = WithRandomGradients(RandomScene(3, 3000), 4);
  RenderCamera distorted = SimpleCamera(96, 64, 80);
  distorted.model.SetOpenCv(-0.2, 0.05, 0.001, -0.001, 0);
  for (const RenderCamera& camera : {SimpleCamera(96, 64, 80), distorted}) {
    RenderOptions options;
    options.features = false;
    absl::StatusOr<RenderBuffers> render = Render(scene, camera, 300000, {}, options);
    ASSERT_TRUE(render.ok()) << render.status();
    WeightOptions weight_options;
    weight_options.local_coords = true;
    absl::StatusOr<CompositingWeights> a =
        ComputeCompositingWeights(scene, camera, 300000, weight_options);
    ASSERT_TRUE(a.ok()) << a.status();
    ASSERT_EQ(a->local_frames.size(), 6 * a->gaussians.size());
    std::vector<float> image(render->rgb.size());
    const std::vector<float> params = LocalTexturedColours(scene, *a);
    CompositeTextured(*a, params.data(), image.data());
    double max_error = 0;
    for (size_t i = 0; i < image.size(); ++i)
      max_error = std::max(max_error, double(std::abs(image[i] - render->rgb[i])));
    EXPECT_LT(max_error, 2e-4);
    // The gradients matter: flat colours give another image.
    std::vector<float> flat(render->rgb.size());
    const std::vector<float> colours = LocalColours(scene, *a);
    Composite(*a, colours.data(), 3, flat.data());
    double max_difference = 0;
    for (size_t i = 0; i < flat.size(); ++i)
      max_difference = std::max(max_difference, double(std::abs(flat[i] - render->rgb[i])));
    EXPECT_GT(max_difference, 0.05);
  }
}

TEST(CompositingWeights, TexturedTransposeIsTheAdjoint) {
  const GaussianScene scene = RandomScene(5, 800);
  WeightOptions options;
  options.local_coords = true;
  absl::StatusOr<CompositingWeights> a =
      ComputeCompositingWeights(scene, SimpleCamera(64, 48, 60), 0, options);
  ASSERT_TRUE(a.ok()) << a.status();
  ExpectAdjoint(
      a->gaussians.size() * 9, 64 * 48 * 3, 2,
      [&](const float* x, float* out) { CompositeTextured(*a, x, out); },
      [&](const float* r, float* out) { AccumulateTransposedTextured(*a, r, out); });
}

TEST(CompositingWeights, AccumulateNormalIsTheTransposeOfTheMaskedComposite) {
  // A^T M A x in one pass equals Composite, the pixels outside the mask
  // zeroed, then AccumulateTransposed: flat RGB and with gradients, on an
  // image of whole tiles and on one whose last tiles are cut.
  const GaussianScene scene = RandomScene(6, 800);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  for (const auto& [width, height] : {std::pair{64, 48}, std::pair{70, 45}}) {
    std::vector<uint8_t> mask(width * height);
    for (size_t p = 0; p < mask.size(); ++p) mask[p] = (p * 7919 % 5) != 0;  // 4 in 5 pixels.
    for (const bool textured : {false, true}) {
      SCOPED_TRACE(::testing::Message() << width << "x" << height << " textured " << textured);
      WeightOptions options;
      options.local_coords = textured;
      absl::StatusOr<CompositingWeights> a =
          ComputeCompositingWeights(scene, SimpleCamera(width, height, 60), 0, options);
      ASSERT_TRUE(a.ok()) << a.status();
      // Each contributing Gaussian is listed once.
      std::vector<uint32_t> listed = a->gaussians;
      std::sort(listed.begin(), listed.end());
      EXPECT_EQ(std::adjacent_find(listed.begin(), listed.end()), listed.end());
      const size_t per = textured ? 9 : 3;
      std::vector<float> x(per * a->gaussians.size());
      for (float& v : x) v = u(rng);
      std::vector<float> image(3 * mask.size());
      if (textured) {
        CompositeTextured(*a, x.data(), image.data());
      } else {
        Composite(*a, x.data(), 3, image.data());
      }
      for (size_t p = 0; p < mask.size(); ++p)
        if (!mask[p]) image[3 * p] = image[3 * p + 1] = image[3 * p + 2] = 0.f;
      std::vector<float> expected(x.size(), 0.f), got(x.size(), 0.f);
      if (textured) {
        AccumulateTransposedTextured(*a, image.data(), expected.data());
      } else {
        AccumulateTransposed(*a, image.data(), 3, expected.data());
      }
      AccumulateNormal(*a, mask, x.data(), got.data());
      double max_error = 0, max_value = 0;
      for (size_t k = 0; k < x.size(); ++k) {
        max_error = std::max(max_error, double(std::abs(got[k] - expected[k])));
        max_value = std::max(max_value, double(std::abs(expected[k])));
      }
      EXPECT_GT(max_value, 0.1);
      EXPECT_LT(max_error, 1e-5 * max_value);
      // The baseline build (the one under PF_RENDER_KERNEL=baseline) gives
      // the same bits as the AVX2 one this CPU may run.
      ASSERT_TRUE(raster::UseTileKernelForTesting("baseline"));
      std::vector<float> baseline(x.size(), 0.f);
      AccumulateNormal(*a, mask, x.data(), baseline.data());
      raster::UseTileKernelForTesting(nullptr);
      EXPECT_EQ(baseline, got);
    }
  }
}

TEST(CompositingWeights, APixelStrideRecordsTheLatticePixelsOnly) {
  // With pixel_stride k only the pixels OnPixelLattice(x, y, k) have
  // entries, and exactly the entries (Gaussians, weights, local
  // coordinates) a full recording gives them; alpha is every pixel's.
  const GaussianScene scene = WithRandomGradients(RandomScene(7, 2000), 5);
  const RenderCamera camera = SimpleCamera(96, 64, 80);
  WeightOptions options;
  options.local_coords = true;
  absl::StatusOr<CompositingWeights> full = ComputeCompositingWeights(scene, camera, 0, options);
  ASSERT_TRUE(full.ok()) << full.status();
  for (const int stride : {2, 3, 4}) {
    SCOPED_TRACE(stride);
    options.pixel_stride = stride;
    absl::StatusOr<CompositingWeights> a = ComputeCompositingWeights(scene, camera, 0, options);
    ASSERT_TRUE(a.ok()) << a.status();
    EXPECT_EQ(a->alpha, full->alpha);
    size_t lattice = 0, compared = 0;
    for (int y = 0; y < 64; ++y) {
      for (int x = 0; x < 96; ++x) {
        const size_t p = static_cast<size_t>(y) * 96 + x;
        ASSERT_EQ(a->Records(p), OnPixelLattice(x, y, stride));
        if (!a->Records(p)) {
          ASSERT_EQ(a->pixel_count[p], 0u);
          continue;
        }
        ++lattice;
        ASSERT_EQ(a->pixel_count[p], full->pixel_count[p]);
        for (uint32_t j = 0; j < a->pixel_count[p]; ++j) {
          const uint64_t e = a->pixel_begin[p] + j, f = full->pixel_begin[p] + j;
          const uint32_t local = a->PixelTable(p)[a->pairs[e].slot];
          const uint32_t full_local = full->PixelTable(p)[full->pairs[f].slot];
          ASSERT_EQ(a->gaussians[local], full->gaussians[full_local]);
          ASSERT_EQ(a->Weight(e), full->Weight(f));
          float u, v, fu, fv;
          a->LocalCoords(local, x + 0.5f, y + 0.5f, &u, &v);
          full->LocalCoords(full_local, x + 0.5f, y + 0.5f, &fu, &fv);
          ASSERT_EQ(u, fu);
          ASSERT_EQ(v, fv);
          ++compared;
        }
      }
    }
    // 1 pixel in k, spread: every row and every column holds about 1 in k.
    EXPECT_NEAR(double(lattice) / (96 * 64), 1.0 / stride, 0.01);
    EXPECT_GT(compared, 0u);
    EXPECT_LT(a->entries(), full->entries() / (stride - 0.5));
  }
  options.pixel_stride = 0;
  EXPECT_EQ(ComputeCompositingWeights(scene, camera, 0, options).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(CompositingWeights, OmittedColoursAddWhatTheEntriesLeftOutGiveTheRender) {
  // With min_weight the weights under it are not recorded; `omitted` holds
  // their colour, so A c + omitted is the render's rgb (to float rounding:
  // summed in another order, the weights to 16 bits) on every recorded pixel, where A c alone
  // falls short by far more.
  const GaussianScene scene = RandomScene(3, 3000);
  const RenderCamera camera = SimpleCamera(96, 64, 80);
  RenderOptions render_options;
  render_options.features = false;
  absl::StatusOr<RenderBuffers> render = Render(scene, camera, 0, {}, render_options);
  ASSERT_TRUE(render.ok()) << render.status();
  absl::StatusOr<CompositingWeights> all = ComputeCompositingWeights(scene, camera, 0);
  ASSERT_TRUE(all.ok()) << all.status();
  for (const int stride : {1, 2}) {
    SCOPED_TRACE(stride);
    WeightOptions options;
    options.min_weight = 0.05f;
    options.omitted_colours = true;
    options.pixel_stride = stride;
    absl::StatusOr<CompositingWeights> a = ComputeCompositingWeights(scene, camera, 0, options);
    ASSERT_TRUE(a.ok()) << a.status();
    ASSERT_EQ(a->omitted.size(), render->rgb.size());
    EXPECT_LT(a->entries(), 0.8 * all->entries() / stride);
    std::vector<float> image(render->rgb.size());
    const std::vector<float> colours = LocalColours(scene, *a);
    Composite(*a, colours.data(), 3, image.data());
    double max_error = 0, max_shortfall = 0;
    for (size_t p = 0; p < render->alpha.size(); ++p) {
      for (int c = 0; c < 3; ++c) {
        const size_t k = 3 * p + c;
        if (!a->Records(p)) {
          ASSERT_EQ(a->omitted[k], 0.f);
          continue;
        }
        max_shortfall = std::max(max_shortfall, double(render->rgb[k] - image[k]));
        // Summed in another order, and the entries' weights to 16 bits.
        const double bound = 0.5 * CompositingWeights::kWeightStep * a->pixel_count[p] + 1e-5;
        max_error = std::max(max_error,
                             double(std::abs(image[k] + a->omitted[k] - render->rgb[k])) - bound);
      }
    }
    EXPECT_LE(max_error, 0.0);
    EXPECT_GT(max_shortfall, 0.05);
  }
  // Nothing left out: nothing omitted.
  WeightOptions options;
  options.omitted_colours = true;
  absl::StatusOr<CompositingWeights> exact = ComputeCompositingWeights(scene, camera, 0, options);
  ASSERT_TRUE(exact.ok()) << exact.status();
  EXPECT_EQ(exact->omitted, std::vector<float>(render->rgb.size(), 0.f));
}

TEST(CompositingWeights, EveryKernelRecordsTheBaselinesWeights) {
  // The recording's tile loop at the width of each kernel this CPU runs
  // (AVX2: 8 lanes) gives the baseline's 4-lane record to the bit: every
  // entry, pixel range, alpha, omitted colour and screen frame, on an image
  // whose last tiles are cut, with entries left out and on a lattice.
  const GaussianScene scene = RandomScene(5, 3000);
  const RenderCamera camera = SimpleCamera(93, 70, 80);
  for (const int stride : {1, 3}) {
    SCOPED_TRACE(stride);
    WeightOptions options;
    options.min_weight = 0.02f;
    options.omitted_colours = true;
    options.local_coords = true;
    options.pixel_stride = stride;
    ASSERT_TRUE(raster::UseTileKernelForTesting("baseline"));
    absl::StatusOr<CompositingWeights> baseline =
        ComputeCompositingWeights(scene, camera, 0, options);
    ASSERT_TRUE(baseline.ok()) << baseline.status();
    EXPECT_GT(baseline->entries(), 20000u / stride);
    EXPECT_GT(*std::max_element(baseline->omitted.begin(), baseline->omitted.end()), 0.02f);
    int kernels = 0;
    for (const char* kernel : {"avx2", "avx512"}) {
      if (!raster::UseTileKernelForTesting(kernel)) continue;  // The CPU lacks it.
      SCOPED_TRACE(kernel);
      ++kernels;
      absl::StatusOr<CompositingWeights> a = ComputeCompositingWeights(scene, camera, 0, options);
      ASSERT_TRUE(a.ok()) << a.status();
      EXPECT_EQ(a->gaussians, baseline->gaussians);
      EXPECT_EQ(a->pixel_begin, baseline->pixel_begin);
      EXPECT_EQ(a->pixel_count, baseline->pixel_count);
      EXPECT_EQ(a->pixel_table, baseline->pixel_table);
      EXPECT_EQ(a->table_begin, baseline->table_begin);
      EXPECT_EQ(a->table, baseline->table);
      std::vector<uint32_t> local, baseline_local;
      std::vector<float> weights, baseline_weights;
      a->Unpack(&local, &weights);
      baseline->Unpack(&baseline_local, &baseline_weights);
      EXPECT_EQ(local, baseline_local);
      EXPECT_EQ(weights, baseline_weights);
      EXPECT_EQ(a->alpha, baseline->alpha);
      EXPECT_EQ(a->local_frames, baseline->local_frames);
      EXPECT_EQ(a->omitted, baseline->omitted);
    }
    raster::UseTileKernelForTesting(nullptr);
    if (kernels == 0) GTEST_SKIP() << "this CPU runs the baseline kernel only";
  }
}

TEST(CompositingWeights, ATileWithMoreGaussiansThanATableHoldsStartsAnother) {
  // 70,000 faint Gaussians (opacity 0.006, just over the 1/255 cut-off), each
  // on the centre of one pixel of a 16 x 16 image (one tile): about 273 per
  // pixel, all blended (the transmittance stays over 0.19), so the tile's
  // Gaussians pass the 65,536 slots of one table and its last pixels take a
  // second one. Every entry still names its Gaussian: the image is the
  // render's.
  const RenderCamera camera = SimpleCamera(16, 16, 16);
  GaussianScene scene;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0, 1);
  const Quat identity{1, 0, 0, 0};
  const int count = 70000;
  for (int i = 0; i < count; ++i) {
    const int pixel = i % 256;
    const double z = 2 + 10 * (double(i) / count);
    const Vec3 mean{(pixel % 16 + 0.5 - 8) / 16 * z, (pixel / 16 + 0.5 - 8) / 16 * z, z};
    AddGaussian(&scene, mean, {0.002 * z, 0.002 * z, 0.002 * z}, identity, 0.006,
                {u(rng), u(rng), u(rng)});
  }
  RenderOptions render_options;
  render_options.features = false;
  absl::StatusOr<RenderBuffers> render = Render(scene, camera, 0, {}, render_options);
  ASSERT_TRUE(render.ok()) << render.status();
  absl::StatusOr<CompositingWeights> a = ComputeCompositingWeights(scene, camera, 0);
  ASSERT_TRUE(a.ok()) << a.status();
  EXPECT_EQ(a->gaussians.size(), static_cast<size_t>(count));
  EXPECT_EQ(a->entries(), static_cast<size_t>(render->stats.pairs_contributing));
  EXPECT_EQ(a->table.size(), static_cast<size_t>(count));  // One slot each, in two tables.
  ASSERT_EQ(a->table_begin.size(), 3u);
  EXPECT_EQ(a->pixel_table.front(), 0u);
  EXPECT_EQ(a->pixel_table.back(), 1u);
  EXPECT_GT(a->TableSize(0), 60000u);
  EXPECT_LE(a->TableSize(0), 65536u);
  EXPECT_EQ(a->table_begin.back(), static_cast<uint32_t>(count));
  std::vector<float> image(render->rgb.size());
  const std::vector<float> colours = LocalColours(scene, *a);
  Composite(*a, colours.data(), 3, image.data());
  // Within half a 16-bit step per entry, as ExpectMatchesRender.
  double max_excess = 0;
  for (size_t k = 0; k < image.size(); ++k) {
    const double bound = 0.5 * CompositingWeights::kWeightStep * a->pixel_count[k / 3] + 1e-5;
    max_excess = std::max(max_excess, std::abs(image[k] - render->rgb[k]) - bound);
  }
  EXPECT_GT(*std::max_element(render->rgb.begin(), render->rgb.end()), 0.3f);
  EXPECT_LE(max_excess, 0.0);
  // The textured normal product, which gathers each table's Gaussians in
  // turn, takes the tile's two tables as it takes two tiles: A^T A x.
  WeightOptions textured;
  textured.local_coords = true;
  absl::StatusOr<CompositingWeights> t = ComputeCompositingWeights(scene, camera, 0, textured);
  ASSERT_TRUE(t.ok()) << t.status();
  ASSERT_EQ(t->table_begin.size(), 3u);
  std::vector<float> x(9 * t->gaussians.size()), ax(3 * 256);
  for (float& v : x) v = static_cast<float>(u(rng));
  CompositeTextured(*t, x.data(), ax.data());
  std::vector<float> expected(x.size(), 0.f), got(x.size(), 0.f);
  AccumulateTransposedTextured(*t, ax.data(), expected.data());
  AccumulateNormal(*t, std::vector<uint8_t>(256, 1), x.data(), got.data());
  double max_error = 0, max_value = 0;
  for (size_t k = 0; k < x.size(); ++k) {
    max_error = std::max(max_error, double(std::abs(got[k] - expected[k])));
    max_value = std::max(max_value, double(std::abs(expected[k])));
  }
  EXPECT_GT(max_value, 1e-3);
  EXPECT_LT(max_error, 1e-5 * max_value);
}

TEST(CompositingWeights, RejectsEmptyCameraAndBadScenes) {
  GaussianScene scene = RandomScene(7, 10);
  EXPECT_EQ(ComputeCompositingWeights(scene, SimpleCamera(0, 10, 10), 0).status().code(),
            absl::StatusCode::kInvalidArgument);
  scene.owners[3] = 9;
  EXPECT_EQ(ComputeCompositingWeights(scene, SimpleCamera(10, 10, 10), 0).status().code(),
            absl::StatusCode::kInvalidArgument);
  scene.owners[3] = 0;
  scene.means.pop_back();
  EXPECT_EQ(ComputeCompositingWeights(scene, SimpleCamera(10, 10, 10), 0).status().code(),
            absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace pf
