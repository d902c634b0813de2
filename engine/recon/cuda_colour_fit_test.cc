// Tests of the colour fit's solve on a GPU (cuda_colour_fit.h) against the
// CPU solve: the same scenes, views and options must give the same colours,
// gradients and residuals to float rounding. The tests that need a GPU skip
// with a message where there is none (or the build has no CUDA); the errors
// are checked everywhere.
#include "engine/recon/cuda_colour_fit.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "engine/recon/colour_refinement.h"
#include "engine/recon/gaussian_decoder.h"
#include "engine/render/cuda_rasterizer.h"
#include "engine/render/random_scene_testing.h"
#include "engine/render/rasterizer.h"

namespace pf {
namespace {

#define SKIP_WITHOUT_GPU()                                   \
  do {                                                       \
    if (absl::Status gpu = CheckCudaDevice(0); !gpu.ok()) {  \
      GTEST_SKIP() << "no GPU to fit on: " << gpu.message(); \
    }                                                        \
  } while (false)

// A random scene of kReconChannels with agreement 1 everywhere but every
// 7th Gaussian (hidden), and context views of it through every camera model
// from four places, their images rendered from colours off by up to 0.2
// and a little noise, so the fit has something to do. One view has an ego
// mask over its bottom rows.
struct Problem {
  GaussianScene scene;
  std::vector<ContextView> views;
};

Problem MakeProblem(uint32_t seed) {
  Problem problem;
  const RenderCamera first = testing_scenes::MovedCameraOfModel(0);
  testing_scenes::RandomSceneSpec spec;
  spec.seed = seed;
  spec.count = 3000;
  spec.channels = kReconChannels;
  problem.scene = testing_scenes::RandomScene(spec, first);
  GaussianScene& scene = problem.scene;
  for (size_t i = 0; i < scene.size(); ++i) {
    scene.features[i * kReconChannels + kAgreementChannel] = i % 7 == 3 ? 0.f : 1.f;
  }
  GaussianScene truth = scene;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> off(-0.2f, 0.2f);
  std::normal_distribution<float> noise(0.f, 0.01f);
  for (size_t i = 0; i < truth.size(); ++i)
    for (int c = 0; c < 3; ++c) truth.features[i * kReconChannels + c] += off(rng);
  for (int v = 0; v < 8; ++v) {
    RenderCamera camera = testing_scenes::MovedCameraOfModel(v % testing_scenes::kCameraModels);
    camera.world_from_camera.translation[0] += 0.05 * (v / 2);
    camera.world_from_camera.translation[1] -= 0.03 * (v % 3);
    RenderOptions render_options;
    render_options.features = false;
    absl::StatusOr<RenderBuffers> render = Render(truth, camera, 0, {}, render_options);
    EXPECT_TRUE(render.ok()) << render.status();
    if (!render.ok()) continue;
    ContextView view;
    view.camera_id = "cam" + std::to_string(v);
    view.camera = camera.model;
    view.world_from_camera = camera.world_from_camera;
    view.rgb = ImageF(camera.model.width(), camera.model.height(), 3);
    for (size_t k = 0; k < view.rgb.pixels.size(); ++k)
      view.rgb.pixels[k] = render->rgb[k] + noise(rng);
    if (v == 5) {
      view.ego.assign(view.rgb.pixels.size() / 3, 0);
      std::fill(view.ego.end() - 10 * view.width(), view.ego.end(), 1);
    }
    problem.views.push_back(std::move(view));
  }
  return problem;
}

// The largest difference between the fitted colours (and gradients) of two
// scenes, the share of values that differ by more than 1e-4, and the lowest
// PSNR between their renders through the views.
struct Agreement {
  double max_difference = 0;
  double share_over_1e4 = 0;
  double min_render_psnr = 0;
};

Agreement Compare(const GaussianScene& a, const GaussianScene& b,
                  const std::vector<ContextView>& views) {
  Agreement out;
  out.min_render_psnr = 200;
  RenderOptions render_options;
  render_options.features = false;
  for (const ContextView& view : views) {
    absl::StatusOr<RenderBuffers> ra =
        Render(a, {view.camera, view.world_from_camera}, 0, {}, render_options);
    absl::StatusOr<RenderBuffers> rb =
        Render(b, {view.camera, view.world_from_camera}, 0, {}, render_options);
    EXPECT_TRUE(ra.ok() && rb.ok());
    if (!ra.ok() || !rb.ok()) continue;
    double sum = 0;
    for (size_t k = 0; k < ra->rgb.size(); ++k) sum += std::pow(double(ra->rgb[k]) - rb->rgb[k], 2);
    const double mse = sum / double(std::max<size_t>(ra->rgb.size(), 1));
    out.min_render_psnr = std::min(out.min_render_psnr, mse > 0 ? -10 * std::log10(mse) : 200.0);
  }
  int64_t over = 0, total = 0;
  auto add = [&](float x, float y) {
    const double d = std::abs(double(x) - double(y));
    out.max_difference = std::max(out.max_difference, d);
    over += d > 1e-4;
    ++total;
  };
  for (size_t i = 0; i < a.size(); ++i)
    for (int c = 0; c < 3; ++c)
      add(a.features[i * kReconChannels + c], b.features[i * kReconChannels + c]);
  EXPECT_EQ(a.colour_gradients.size(), b.colour_gradients.size());
  for (size_t k = 0; k < std::min(a.colour_gradients.size(), b.colour_gradients.size()); ++k)
    add(a.colour_gradients[k], b.colour_gradients[k]);
  out.share_over_1e4 = double(over) / double(std::max<int64_t>(total, 1));
  return out;
}

TEST(CudaColourFit, MatchesTheCpuSolve) {
  SKIP_WITHOUT_GPU();
  const Problem problem = MakeProblem(5);
  for (const bool gradients : {true, false}) {
    for (const int64_t max_pairs : {int64_t{256'000'000}, int64_t{0}}) {
      SCOPED_TRACE(::testing::Message()
                   << "gradients " << gradients << ", max_pairs " << max_pairs);
      RefinementOptions options;
      options.colour_gradients = gradients;
      // 0: the CPU fit's pair count halved, so both fit 1 pixel in k.
      options.max_pairs = max_pairs;
      if (max_pairs == 0) {
        GaussianScene probe = problem.scene;
        RefinementOptions every_pixel = options;
        every_pixel.max_pairs = RefinementOptions().max_pairs;
        absl::StatusOr<RefinementStats> full = RefineColours(problem.views, every_pixel, &probe);
        ASSERT_TRUE(full.ok()) << full.status();
        options.max_pairs = (full->weight_bytes / kWeightUnitBytes) / 2;
      }
      GaussianScene cpu = problem.scene, gpu = problem.scene;
      absl::StatusOr<RefinementStats> on_cpu = RefineColours(problem.views, options, &cpu);
      options.device = {ComputeDevice::Kind::kCuda, 0};
      absl::StatusOr<RefinementStats> on_gpu = RefineColours(problem.views, options, &gpu);
      ASSERT_TRUE(on_cpu.ok()) << on_cpu.status();
      ASSERT_TRUE(on_gpu.ok()) << on_gpu.status();
      EXPECT_FALSE(on_cpu->on_gpu);
      EXPECT_TRUE(on_gpu->on_gpu);
      EXPECT_GT(on_gpu->gpu_bytes, 0);
      // The same recorded system.
      EXPECT_EQ(on_gpu->pixels, on_cpu->pixels);
      EXPECT_EQ(on_gpu->pairs, on_cpu->pairs);
      EXPECT_EQ(on_gpu->pixel_stride, on_cpu->pixel_stride);
      EXPECT_EQ(on_gpu->flat_fallback, on_cpu->flat_fallback);
      if (max_pairs == 0) EXPECT_GT(on_cpu->pixel_stride, 1);
      // The fit did something, and the same on both.
      EXPECT_LT(on_cpu->rmse_after, 0.7 * on_cpu->rmse_before);
      EXPECT_NEAR(on_gpu->rmse_before, on_cpu->rmse_before, 1e-6 * on_cpu->rmse_before);
      EXPECT_NEAR(on_gpu->rmse_after, on_cpu->rmse_after, 1e-3 * on_cpu->rmse_after);
      // Float sums in another order: the two fits part where the views barely
      // determine a colour (flat fits of this scene most: 0.017 at most, a
      // sixth of the colours over 1e-4, on an H200), not in what they render.
      const Agreement agreement = Compare(cpu, gpu, problem.views);
      std::printf(
          "gradients %d stride %d: max difference %.3g, share over 1e-4 %.3g, renders "
          "%.1f dB apart at least, rmse %.6f -> %.6f (cpu %.6f -> %.6f)\n",
          int(gradients), on_gpu->pixel_stride, agreement.max_difference, agreement.share_over_1e4,
          agreement.min_render_psnr, on_gpu->rmse_before, on_gpu->rmse_after, on_cpu->rmse_before,
          on_cpu->rmse_after);
      EXPECT_LT(agreement.max_difference, 0.05);
      EXPECT_GT(agreement.min_render_psnr, 60);
      if (gradients) EXPECT_LT(agreement.share_over_1e4, 0.02);
      // Hidden Gaussians keep their colour on the GPU too.
      for (size_t i = 3; i < gpu.size(); i += 7) {
        for (int c = 0; c < 3; ++c) {
          EXPECT_NEAR(gpu.features[i * kReconChannels + c],
                      problem.scene.features[i * kReconChannels + c], 1e-3);
        }
      }
    }
  }
}

TEST(CudaColourFit, SolveNeedsAStartAndVectorsOfTheRightSize) {
  SKIP_WITHOUT_GPU();
  const Problem problem = MakeProblem(6);
  WeightOptions weight_options;
  weight_options.local_coords = true;
  absl::StatusOr<CompositingWeights> a = ComputeCompositingWeights(
      problem.scene, {problem.views[0].camera, problem.views[0].world_from_camera}, 0,
      weight_options);
  ASSERT_TRUE(a.ok()) << a.status();
  const std::vector<uint8_t> fitted(a->alpha.size(), 1);
  const size_t n = problem.scene.size();
  absl::StatusOr<std::unique_ptr<CudaColourFit>> gpu = CudaColourFit::Upload(
      {{&*a, fitted.data(), problem.views[0].rgb.pixels.data()}}, n, /*textured=*/true, 0);
  ASSERT_TRUE(gpu.ok()) << gpu.status();
  std::vector<float> x(9 * n, 0.5f);
  const std::vector<float> prior(9 * n, 1.f), inverse(6 * n, 0.f);
  EXPECT_EQ((*gpu)->Solve(prior, inverse, 2, &x).code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ((*gpu)->Residual(std::vector<float>(3 * n), true).status().code(),
            absl::StatusCode::kInvalidArgument);
  // The residual of x = 0 is the image itself.
  absl::StatusOr<ChannelSums> zero = (*gpu)->Residual(std::vector<float>(9 * n, 0.f), false);
  ASSERT_TRUE(zero.ok()) << zero.status();
  double image_sum = 0;
  for (float v : problem.views[0].rgb.pixels) image_sum += double(v) * v;
  EXPECT_NEAR((*zero)[0] + (*zero)[1] + (*zero)[2], image_sum, 1e-4 * image_sum);
  ASSERT_TRUE((*gpu)->Residual(x, true).ok());
  EXPECT_EQ((*gpu)->Solve(prior, std::vector<float>(n), 2, &x).code(),
            absl::StatusCode::kInvalidArgument);
  // Flat weights for a textured fit.
  CompositingWeights flat = *a;
  flat.local_frames.clear();
  EXPECT_EQ(CudaColourFit::Upload({{&flat, fitted.data(), problem.views[0].rgb.pixels.data()}}, n,
                                  true, 0)
                .status()
                .code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(CudaColourFit, AnUnusableDeviceIsAnErrorNamingIt) {
  // Everywhere: no GPU (or no CUDA in the build) says so; a GPU that does
  // not exist is named.
  const Problem problem = MakeProblem(7);
  GaussianScene scene = problem.scene;
  RefinementOptions options;
  options.device = {ComputeDevice::Kind::kCuda, 7};
  absl::StatusOr<RefinementStats> stats = RefineColours(problem.views, options, &scene);
  ASSERT_FALSE(stats.ok());
  EXPECT_EQ(stats.status().code(), absl::StatusCode::kFailedPrecondition);
  if (HaveCudaColourFit() && CheckCudaDevice(0).ok()) {
    EXPECT_NE(stats.status().message().find("cuda:7"), std::string::npos) << stats.status();
  }
  // Nothing was changed.
  EXPECT_EQ(scene.features, problem.scene.features);
}

}  // namespace
}  // namespace pf
