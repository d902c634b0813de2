// Tests of the CUDA rasterizer against the CPU one (Render()): the same
// scenes, cameras, times and edits must give the same images to float
// rounding. The tests that need a GPU skip with a message where there is none
// (or the build has no CUDA); the errors are checked everywhere.
#include "engine/render/cuda_rasterizer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "engine/render/bench_scene.h"
#include "engine/render/random_scene_testing.h"
#include "engine/render/rasterizer.h"

namespace pf {
namespace {

using testing_scenes::MovedCameraOfModel;
using testing_scenes::MoveSecondActor;
using testing_scenes::RandomScene;
using testing_scenes::RandomSceneSpec;

#define SKIP_WITHOUT_GPU()                                      \
  do {                                                          \
    if (absl::Status gpu = CheckCudaDevice(0); !gpu.ok()) {     \
      GTEST_SKIP() << "no GPU to render on: " << gpu.message(); \
    }                                                           \
  } while (false)

// PSNR of `a` against `b` over values in [0, 1].
double Psnr(const std::vector<float>& a, const std::vector<float>& b) {
  double sum = 0;
  for (size_t k = 0; k < a.size(); ++k) sum += (a[k] - b[k]) * (a[k] - b[k]);
  const double mse = sum / static_cast<double>(std::max<size_t>(a.size(), 1));
  return mse > 0 ? 10 * std::log10(1.0 / mse) : 200.0;
}

// Returns the fraction of values of `a` further than `tolerance` from `b`'s.
double FractionOff(const std::vector<float>& a, const std::vector<float>& b, double tolerance) {
  size_t off = 0;
  for (size_t k = 0; k < a.size(); ++k) off += std::abs(double{a[k]} - b[k]) > tolerance;
  return static_cast<double>(off) / static_cast<double>(std::max<size_t>(a.size(), 1));
}

// Expects the GPU render of every output to match the CPU's: colour and
// features at >= 50 dB, and 99.9 % of their values within 2e-3, of alpha
// within 1e-3, of depths (where alpha > 0.5) within 0.1 %, of instance ids
// the same; the visible count within 0.01 %. (Not every value: the GPU's
// fused multiply-adds round the projection differently, and two Gaussians
// at depths within that rounding may swap order.)
void ExpectSameRender(const GaussianScene& scene, const RenderCamera& camera, int64_t timestamp_us,
                      const std::vector<ActorEdit>& edits, const RenderOptions& options = {}) {
  absl::StatusOr<RenderBuffers> cpu = Render(scene, camera, timestamp_us, edits, options);
  ASSERT_TRUE(cpu.ok()) << cpu.status();
  absl::StatusOr<std::unique_ptr<CudaScene>> gpu_scene = CudaScene::Upload(scene, 0);
  ASSERT_TRUE(gpu_scene.ok()) << gpu_scene.status();
  absl::StatusOr<RenderBuffers> gpu = (*gpu_scene)->Render(camera, timestamp_us, edits, options);
  ASSERT_TRUE(gpu.ok()) << gpu.status();
  ASSERT_EQ(gpu->width, cpu->width);
  ASSERT_EQ(gpu->height, cpu->height);
  ASSERT_EQ(gpu->rgb.size(), cpu->rgb.size());
  ASSERT_EQ(gpu->features.size(), cpu->features.size());
  ASSERT_EQ(gpu->depth.size(), cpu->depth.size());
  ASSERT_EQ(gpu->instance.size(), cpu->instance.size());
  EXPECT_GE(Psnr(gpu->rgb, cpu->rgb), 50.0);
  EXPECT_LT(FractionOff(gpu->rgb, cpu->rgb, 2e-3), 1e-3);
  EXPECT_LT(FractionOff(gpu->alpha, cpu->alpha, 1e-3), 1e-3);
  if (options.features) {
    EXPECT_GE(Psnr(gpu->features, cpu->features), 50.0);
    EXPECT_LT(FractionOff(gpu->features, cpu->features, 2e-3), 1e-3);
  }
  int depth_checked = 0, depth_bad = 0;
  for (size_t p = 0; p < gpu->depth.size(); ++p) {
    if (cpu->alpha[p] < 0.5f) continue;
    ++depth_checked;
    if (std::abs(gpu->depth[p] - cpu->depth[p]) > 1e-3f * cpu->depth[p]) ++depth_bad;
  }
  EXPECT_LE(depth_bad, depth_checked / 1000) << "of " << depth_checked;
  if (options.depth) EXPECT_GT(depth_checked, 0);
  size_t same_owner = 0;
  for (size_t p = 0; p < gpu->instance.size(); ++p)
    same_owner += gpu->instance[p] == cpu->instance[p];
  if (!gpu->instance.empty()) {
    EXPECT_GE(static_cast<double>(same_owner), 0.999 * static_cast<double>(gpu->instance.size()));
  }
  EXPECT_NEAR(static_cast<double>(gpu->stats.gaussians_visible),
              static_cast<double>(cpu->stats.gaussians_visible),
              1e-4 * static_cast<double>(cpu->stats.gaussians_visible) + 2);
  EXPECT_NEAR(static_cast<double>(gpu->stats.pairs_contributing),
              static_cast<double>(cpu->stats.pairs_contributing),
              1e-3 * static_cast<double>(cpu->stats.pairs_contributing) + 2);
  // Something was drawn: a blank image would match a blank image.
  double coverage = 0;
  for (float a : cpu->alpha) coverage += a;
  EXPECT_GT(coverage / static_cast<double>(cpu->alpha.size()), 0.2);
}

TEST(CudaRasterizer, ErrorsNameTheCause) {
  GaussianScene broken;
  broken.Resize(2);
  broken.means.pop_back();
  absl::StatusOr<std::unique_ptr<CudaScene>> scene = CudaScene::Upload(broken, 0);
  EXPECT_EQ(scene.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(scene.status().message().find("scene.means"), std::string::npos);

  const absl::Status no_gpu = CheckCudaDevice(4096);
  EXPECT_EQ(no_gpu.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_FALSE(no_gpu.message().empty());
  if (!HaveCudaRasterizer()) {
    EXPECT_NE(no_gpu.message().find("no CUDA"), std::string::npos) << no_gpu.message();
  }
}

TEST(CudaRasterizer, BadCameraAndEditsAreErrorsAsOnTheCpu) {
  SKIP_WITHOUT_GPU();
  const RenderCamera camera = MovedCameraOfModel(0);
  const GaussianScene scene = RandomScene({}, camera);
  absl::StatusOr<std::unique_ptr<CudaScene>> gpu = CudaScene::Upload(scene, 0);
  ASSERT_TRUE(gpu.ok()) << gpu.status();
  ActorEdit unknown;
  unknown.instance_id = "nobody";
  absl::StatusOr<RenderBuffers> out = (*gpu)->Render(camera, 0, {unknown});
  EXPECT_EQ(out.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(out.status().message().find("nobody"), std::string::npos);
  RenderCamera empty = camera;
  empty.model = CameraModel(0, 10, 10, 10, 0, 5);
  EXPECT_EQ((*gpu)->Render(empty, 0, {}).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(CudaRasterizer, BenchSceneMatchesTheCpu) {
  SKIP_WITHOUT_GPU();
  const BenchScene bench = MakeBenchScene(100000, 320, 240, 3, 1);
  ExpectSameRender(bench.scene, bench.camera, bench.timestamp_us, {});
}

TEST(CudaRasterizer, EveryCameraModelWithEditsMatchesTheCpu) {
  SKIP_WITHOUT_GPU();
  for (int model = 0; model < testing_scenes::kCameraModels; ++model) {
    SCOPED_TRACE(model);
    const RenderCamera camera = MovedCameraOfModel(model);
    RandomSceneSpec spec;
    spec.seed = 21 + model;
    spec.count = 3000;
    const GaussianScene scene = RandomScene(spec, camera);
    ActorEdit remove;
    remove.instance_id = "actor0";
    ExpectSameRender(scene, camera, scene.time_origin_us + 700'000,
                     {remove, MoveSecondActor(scene)});
  }
}

TEST(CudaRasterizer, ShColourWideFeaturesAndColourGradientsMatchTheCpu) {
  SKIP_WITHOUT_GPU();
  const RenderCamera camera = MovedCameraOfModel(1);
  RandomSceneSpec spec;
  spec.count = 3000;
  for (int degree : {0, 3}) {
    SCOPED_TRACE(degree);
    spec.sh_degree = degree;
    spec.channels = 32;  // Four groups of eight channels.
    ExpectSameRender(RandomScene(spec, camera), camera, 1'300'000, {});
  }
  spec.sh_degree = -1;
  spec.channels = 11;  // Groups of eight and three.
  spec.colour_gradients = true;
  ExpectSameRender(RandomScene(spec, camera), camera, 1'300'000, {});
}

TEST(CudaRasterizer, OptionsLeaveOutBuffers) {
  SKIP_WITHOUT_GPU();
  const RenderCamera camera = MovedCameraOfModel(2);
  RandomSceneSpec spec;
  spec.count = 3000;
  spec.channels = 6;
  const GaussianScene scene = RandomScene(spec, camera);
  RenderOptions colour_only;
  colour_only.features = false;
  colour_only.depth = false;
  colour_only.instance = false;
  ExpectSameRender(scene, camera, 1'300'000, {}, colour_only);
}

TEST(CudaRasterizer, OneUploadRendersManyViewsAndEmptyScenes) {
  SKIP_WITHOUT_GPU();
  const BenchScene bench = MakeBenchScene(20000, 200, 150, 3, 2);
  absl::StatusOr<std::unique_ptr<CudaScene>> gpu = CudaScene::Upload(bench.scene, 0);
  ASSERT_TRUE(gpu.ok()) << gpu.status();
  EXPECT_EQ((*gpu)->size(), 20000u);
  for (int step = 0; step < 3; ++step) {
    RenderCamera camera = bench.camera;
    camera.world_from_camera.translation.x += 2.0 * step;
    camera.model = CameraModel(200 + 37 * step, 150 + 11 * step, 180, 180, 100, 75);
    absl::StatusOr<RenderBuffers> cpu = Render(bench.scene, camera, bench.timestamp_us, {});
    absl::StatusOr<RenderBuffers> out = (*gpu)->Render(camera, bench.timestamp_us, {});
    ASSERT_TRUE(cpu.ok() && out.ok());
    EXPECT_GE(Psnr(out->rgb, cpu->rgb), 50.0) << step;
  }
  EXPECT_GT((*gpu)->device_bytes(), 20000u * 64);

  GaussianScene empty;
  absl::StatusOr<std::unique_ptr<CudaScene>> none = CudaScene::Upload(empty, 0);
  ASSERT_TRUE(none.ok()) << none.status();
  absl::StatusOr<RenderBuffers> out = (*none)->Render(bench.camera, 0, {});
  ASSERT_TRUE(out.ok()) << out.status();
  EXPECT_EQ(*std::max_element(out->alpha.begin(), out->alpha.end()), 0.f);
  EXPECT_EQ(*std::max_element(out->rgb.begin(), out->rgb.end()), 0.f);
}

}  // namespace
}  // namespace pf
