// Tests of the per-scene optimisation: on views rendered from a known scene,
// a perturbed copy is pulled back towards the views, fixed Gaussians keep
// their geometry, per-view exposures follow the views' gains, pose
// corrections bring a view recorded at the wrong pose back to its image, and
// densification adds Gaussians where a coarse scene lacks detail.
#include "engine/recon/scene_optimizer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "engine/render/rasterizer.h"

namespace pf {
namespace {

// A wall of overlapping Gaussians 6 m in front of a row of cameras.
GaussianScene WallScene() {
  GaussianScene scene;
  scene.num_channels = 3;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  for (int i = 0; i < 400; ++i) {
    const size_t g = scene.size();
    scene.Resize(g + 1);
    scene.means[3 * g] = -3.f + 6.f * u(rng);
    scene.means[3 * g + 1] = -2.f + 4.f * u(rng);
    scene.means[3 * g + 2] = 6.f + 0.3f * u(rng);
    for (int c = 0; c < 3; ++c) {
      scene.log_scales[3 * g + c] = std::log(0.15f + 0.2f * u(rng));
      scene.features[3 * g + c] = u(rng);
    }
    scene.opacity_logits[g] = 1.f;
  }
  return scene;
}

std::vector<ContextView> ViewsOf(const GaussianScene& scene, const std::vector<float>& gains) {
  std::vector<ContextView> views;
  for (size_t v = 0; v < gains.size(); ++v) {
    ContextView view;
    view.frame_index = static_cast<int>(v);
    view.camera = CameraModel(64, 48, 50, 50, 32, 24);
    view.world_from_camera.translation = {-0.6 + 0.3 * static_cast<double>(v), 0.1, 0};
    const absl::StatusOr<RenderBuffers> r =
        Render(scene, {view.camera, view.world_from_camera}, 0, {});
    view.rgb = ImageF(64, 48, 3);
    for (size_t k = 0; k < r->rgb.size(); ++k) view.rgb.pixels[k] = gains[v] * r->rgb[k];
    views.push_back(std::move(view));
  }
  return views;
}

TEST(SceneOptimizer, PullsAPerturbedSceneBackTowardsItsViews) {
  const GaussianScene truth = WallScene();
  const std::vector<ContextView> views = ViewsOf(truth, {1, 1, 1, 1, 1});
  GaussianScene scene = truth;
  std::mt19937 rng(5);
  std::normal_distribution<float> noise(0.f, 1.f);
  for (float& m : scene.means) m += 0.05f * noise(rng);
  for (float& f : scene.features) f = std::clamp(f + 0.15f * noise(rng), 0.f, 1.f);
  std::vector<uint8_t> fixed(scene.size(), 0);
  for (size_t i = 0; i < scene.size(); i += 10) fixed[i] = 1;
  const GaussianScene before = scene;

  OptimizeOptions options;
  options.steps = 60;
  options.exposure = false;
  // Positions on, at 3DGS's rate; colours faster than the default.
  options.lr_mean = 1.6e-4;
  options.lr_mean_final = 1.6e-6;
  options.lr_colour = 1e-2;
  int calls = 0;
  options.progress = [&](const OptimizeProgress& p) {
    ++calls;
    EXPECT_EQ(p.step, calls);
  };
  absl::StatusOr<OptimizeStats> stats = OptimizeScene(views, fixed, options, &scene);
  ASSERT_TRUE(stats.ok()) << stats.status();
  EXPECT_EQ(stats->steps, 60);
  EXPECT_EQ(calls, 60);
  ASSERT_EQ(stats->psnr.size(), 60u);
  // The first epoch's views against the last epoch's.
  double first = 0, last = 0;
  for (int k = 0; k < 5; ++k) {
    first += stats->psnr[k] / 5;
    last += stats->psnr[55 + k] / 5;
  }
  EXPECT_GT(last, first + 3) << first << " dB -> " << last << " dB";
  // Fixed Gaussians kept their geometry; the others moved.
  double moved = 0;
  for (size_t i = 0; i < scene.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      if (fixed[i]) {
        EXPECT_EQ(scene.means[3 * i + c], before.means[3 * i + c]);
        EXPECT_EQ(scene.log_scales[3 * i + c], before.log_scales[3 * i + c]);
      } else {
        moved += std::abs(scene.means[3 * i + c] - before.means[3 * i + c]);
      }
    }
  }
  EXPECT_GT(moved, 0);
}

TEST(SceneOptimizer, ExposuresFollowTheViewsGains) {
  const GaussianScene truth = WallScene();
  const std::vector<float> gains = {0.8f, 1.2f, 0.8f, 1.2f};
  const std::vector<ContextView> views = ViewsOf(truth, gains);
  GaussianScene scene = truth;
  OptimizeOptions options;
  options.steps = 40;
  options.lr_exposure = 5e-3;
  absl::StatusOr<OptimizeStats> stats = OptimizeScene(views, {}, options, &scene);
  ASSERT_TRUE(stats.ok()) << stats.status();
  ASSERT_EQ(stats->exposures.size(), 4u);
  for (size_t v = 0; v < 4; ++v) {
    const double diagonal =
        (stats->exposures[v][0] + stats->exposures[v][5] + stats->exposures[v][10]) / 3;
    if (gains[v] > 1) {
      EXPECT_GT(diagonal, 1.03) << "view " << v;
    } else {
      EXPECT_LT(diagonal, 0.97) << "view " << v;
    }
  }
}

// A view recorded at the wrong pose: with pose corrections, and nothing else
// moving, its camera is moved back to where its image was taken.
TEST(SceneOptimizer, PoseCorrectionsMoveAViewBackToItsImage) {
  const GaussianScene truth = WallScene();
  std::vector<ContextView> views = ViewsOf(truth, {1, 1, 1, 1});
  // View 2's image was taken from its recorded pose moved by `error`.
  const CameraMotion error = {0, 0, 0.04, 0.12, -0.09, 0};
  const Rigid step{RotationFromVector({error[0], error[1], error[2]}),
                   {error[3], error[4], error[5]}};
  views[2].world_from_camera = views[2].world_from_camera * step.Inverse();
  GaussianScene scene = truth;
  OptimizeOptions options;
  options.steps = 160;
  options.exposure = false;
  options.lr_log_scale = options.lr_rotation = options.lr_opacity = options.lr_colour = 0;
  options.pose = true;
  options.lr_pose_rotation = 2e-3;
  options.lr_pose_translation = 6e-3;
  absl::StatusOr<OptimizeStats> stats = OptimizeScene(views, {}, options, &scene);
  ASSERT_TRUE(stats.ok()) << stats.status();
  ASSERT_EQ(stats->poses.size(), 4u);
  const CameraMotion& found = stats->poses[2];
  std::printf("found %.4f %.4f %.4f  %.4f %.4f %.4f\n", found[0], found[1], found[2], found[3],
              found[4], found[5]);
  EXPECT_NEAR(found[2], error[2], 0.008);  // The roll.
  // The wall, 6 m away, moves in the image with t_x + 6 w_y and t_y - 6 w_x.
  EXPECT_NEAR(found[3] + 6 * found[1], error[3], 0.03);
  EXPECT_NEAR(found[4] - 6 * found[0], error[4], 0.03);
  // View 2 is rendered as well as the others in the last epoch; the others
  // were not moved far.
  double worst = 1e9;
  for (int k = 156; k < 160; ++k) worst = std::min(worst, double{stats->psnr[k]});
  std::printf("last epoch's lowest PSNR %.2f dB\n", worst);
  EXPECT_GT(worst, 30);
  for (size_t v : {0, 1, 3}) {
    for (int k = 0; k < 6; ++k) EXPECT_LT(std::abs(stats->poses[v][k]), 0.005) << v << " " << k;
  }
  // Without the corrections view 2 stays apart.
  options.pose = false;
  scene = truth;
  stats = OptimizeScene(views, {}, options, &scene);
  ASSERT_TRUE(stats.ok());
  double off = 1e9;
  for (int k = 156; k < 160; ++k) off = std::min(off, double{stats->psnr[k]});
  std::printf("without the corrections %.2f dB\n", off);
  EXPECT_LT(off, 25);
  EXPECT_EQ(stats->poses[2], CameraMotion{});
}

// A split Gaussian renders close to what it was, faint or nearly opaque,
// along each axis.
TEST(SceneOptimizer, ASplitKeepsTheRenderClose) {
  const RenderCamera camera{CameraModel(96, 72, 80, 80, 48, 36), Rigid{}};
  for (float opacity : {0.1f, 0.7f}) {
    for (int axis = 0; axis < 3; ++axis) {
      GaussianScene scene;
      scene.num_channels = 3;
      scene.Resize(1);
      scene.means = {0.1f, -0.05f, 5.f};
      scene.rotations = {0.9f, 0.2f, -0.3f, 0.1f};
      scene.log_scales = {std::log(0.3f), std::log(0.3f), std::log(0.3f)};
      scene.log_scales[axis] = std::log(0.8f);
      scene.opacity_logits = {std::log(opacity / (1 - opacity))};
      scene.features = {0.8f, 0.5f, 0.2f};
      scene.colour_gradients = {0.3f, -0.2f, 0.f, 0.3f, -0.3f, 0.1f};
      const absl::StatusOr<RenderBuffers> before = Render(scene, camera, 0, {});
      scene.Resize(2);
      scene.colour_gradients.resize(12);
      std::copy_n(scene.means.begin(), 3, scene.means.begin() + 3);
      std::copy_n(scene.rotations.begin(), 4, scene.rotations.begin() + 4);
      std::copy_n(scene.log_scales.begin(), 3, scene.log_scales.begin() + 3);
      scene.opacity_logits[1] = scene.opacity_logits[0];
      std::copy_n(scene.features.begin(), 3, scene.features.begin() + 3);
      std::copy_n(scene.colour_gradients.begin(), 6, scene.colour_gradients.begin() + 6);
      SplitGaussian(0, 1, &scene);
      const absl::StatusOr<RenderBuffers> after = Render(scene, camera, 0, {});
      double worst = 0, peak = 0;
      for (size_t k = 0; k < before->rgb.size(); ++k) {
        worst = std::max(worst, double{std::abs(after->rgb[k] - before->rgb[k])});
        peak = std::max(peak, double{before->rgb[k]});
      }
      std::printf("opacity %.1f axis %d: largest change %.4f of %.4f\n", opacity, axis, worst,
                  peak);
      // The faint pair also loses more to the 1/255 cut-off, relative to its
      // peak. (With the colours moved the wrong way: 0.22 and 0.25.)
      EXPECT_LT(worst, (opacity < 0.5f ? 0.19 : 0.1) * peak);
    }
  }
}

// A coarse copy of the wall (a quarter of its Gaussians, twice as wide)
// and a few nearly transparent Gaussians: densification splits where the
// views show detail the copy lacks, within the budget, prunes the faint
// ones in place, leaves fixed Gaussians whole, and fits the views better
// than the same steps without it.
TEST(SceneOptimizer, DensificationSplitsWhereTheViewsShowDetailAndPrunesTheFaint) {
  const GaussianScene truth = WallScene();
  const std::vector<ContextView> views = ViewsOf(truth, {1, 1, 1, 1, 1});
  GaussianScene coarse;
  coarse.num_channels = 3;
  for (size_t i = 0; i < truth.size(); i += 4) {
    const size_t g = coarse.size();
    coarse.Resize(g + 1);
    for (int c = 0; c < 3; ++c) {
      coarse.means[3 * g + c] = truth.means[3 * i + c];
      coarse.log_scales[3 * g + c] = truth.log_scales[3 * i + c] + std::log(2.f);
      coarse.features[3 * g + c] = truth.features[3 * i + c];
    }
    coarse.opacity_logits[g] = truth.opacity_logits[i];
  }
  const size_t faint_begin = coarse.size();
  for (int k = 0; k < 20; ++k) {
    const size_t g = coarse.size();
    coarse.Resize(g + 1);
    coarse.means[3 * g] = -2.f + 0.2f * static_cast<float>(k);
    coarse.means[3 * g + 2] = 5.5f;
    coarse.opacity_logits[g] = -6.5f;  // Opacity 0.0015.
    coarse.features[3 * g] = 1.f;
  }
  std::vector<uint8_t> fixed(coarse.size(), 0);
  for (size_t i = 0; i < faint_begin; i += 10) fixed[i] = 1;
  coarse.opacity_logits[0] = -6.5f;  // A faint fixed one: pruned, its slot kept.

  OptimizeOptions options;
  options.steps = 60;
  options.exposure = false;
  options.lr_colour = 1e-2;
  options.lr_log_scale = 5e-3;
  auto last_epoch = [](const OptimizeStats& stats) {
    double psnr = 0;
    for (size_t k = stats.psnr.size() - 5; k < stats.psnr.size(); ++k) psnr += stats.psnr[k] / 5;
    return psnr;
  };
  GaussianScene plain = coarse;
  absl::StatusOr<OptimizeStats> without = OptimizeScene(views, fixed, options, &plain);
  ASSERT_TRUE(without.ok()) << without.status();
  EXPECT_EQ(plain.size(), coarse.size());
  EXPECT_TRUE(without->pruned_entries.empty());

  options.densify = true;
  options.max_gaussians = 180;
  GaussianScene scene = coarse;
  absl::StatusOr<OptimizeStats> with = OptimizeScene(views, fixed, options, &scene);
  ASSERT_TRUE(with.ok()) << with.status();
  std::printf(
      "split %lld, cloned %lld, pruned %lld; %zu entries; last epoch %.2f dB, %.2f dB "
      "without\n",
      static_cast<long long>(with->split), static_cast<long long>(with->cloned),
      static_cast<long long>(with->pruned), scene.size(), last_epoch(*with), last_epoch(*without));
  EXPECT_GT(with->split, 20);
  EXPECT_EQ(with->cloned, 0);  // Positions stay: nothing to gain from a clone.
  EXPECT_GE(with->pruned, 21);
  ASSERT_EQ(with->pruned_entries.size(), scene.size());
  size_t live = 0;
  for (size_t i = 0; i < scene.size(); ++i) {
    if (with->pruned_entries[i]) {
      EXPECT_EQ(scene.opacity_logits[i], kPrunedOpacityLogit) << i;
    } else {
      ++live;
    }
  }
  EXPECT_LE(live, options.max_gaussians);
  // The 20 pruned slots that were not fixed were taken first, then new ones.
  EXPECT_EQ(scene.size(), coarse.size() + static_cast<size_t>(with->split) - 20);
  EXPECT_TRUE(with->pruned_entries[0]);
  EXPECT_EQ(scene.opacity_logits[0], kPrunedOpacityLogit);
  // The faint ones were pruned where they were, unless a split child took
  // the slot; fixed Gaussians kept their place and shape.
  for (size_t i = faint_begin; i < coarse.size(); ++i) {
    if (with->pruned_entries[i]) continue;
    EXPECT_GT(scene.opacity_logits[i], -5.f) << "slot " << i << " holds a split child";
  }
  for (size_t i = 1; i < faint_begin; ++i) {
    if (!fixed[i]) continue;
    for (int c = 0; c < 3; ++c) {
      EXPECT_EQ(scene.means[3 * i + c], coarse.means[3 * i + c]);
      EXPECT_EQ(scene.log_scales[3 * i + c], coarse.log_scales[3 * i + c]);
    }
  }
  EXPECT_GT(last_epoch(*with), last_epoch(*without) + 0.3);
  // The same run again: the same scene.
  GaussianScene again = coarse;
  ASSERT_TRUE(OptimizeScene(views, fixed, options, &again).ok());
  EXPECT_EQ(again.means, scene.means);
  EXPECT_EQ(again.features, scene.features);
}

// When positions move, Gaussians under percent_dense of the spread are
// cloned rather than split: a copy at the same place, each of the pair at
// opacity 1 - sqrt(1 - o) (their alpha at the centre the parent's).
TEST(SceneOptimizer, SmallGaussiansAreClonedWhenPositionsMove) {
  const GaussianScene truth = WallScene();
  const std::vector<ContextView> views = ViewsOf(truth, {1, 1, 1, 1, 1});
  GaussianScene scene = truth;
  for (float& f : scene.features) f = 0.5f;  // Something to fit.
  OptimizeOptions options;
  options.steps = 20;
  options.exposure = false;
  options.lr_log_scale = options.lr_rotation = options.lr_opacity = options.lr_colour = 0;
  options.lr_mean = options.lr_mean_final = 1e-12;  // Positions "move": clones allowed.
  options.densify = true;
  options.percent_dense = 10;  // Every Gaussian is small.
  absl::StatusOr<OptimizeStats> stats = OptimizeScene(views, {}, options, &scene);
  ASSERT_TRUE(stats.ok()) << stats.status();
  EXPECT_EQ(stats->split, 0);
  EXPECT_EQ(stats->cloned, 200);  // The budget: 1.5 times the 400.
  ASSERT_EQ(scene.size(), truth.size() + 200);
  // Opacity logit 1 everywhere (WallScene): parents and clones now at
  // 1 - sqrt(1 - sigmoid(1)); the clones sit on their parents' means.
  const double o = 1 / (1 + std::exp(-1.0));
  const double half = 1 - std::sqrt(1 - o);
  const float logit = static_cast<float>(std::log(half / (1 - half)));
  size_t halved = 0;
  for (size_t i = 0; i < truth.size(); ++i)
    halved += std::abs(scene.opacity_logits[i] - logit) < 1e-5f;
  EXPECT_EQ(halved, 200u);
  for (size_t j = truth.size(); j < scene.size(); ++j) {
    EXPECT_NEAR(scene.opacity_logits[j], logit, 1e-5f) << j;
    bool on_a_parent = false;
    for (size_t i = 0; i < truth.size() && !on_a_parent; ++i) {
      on_a_parent = std::abs(scene.means[3 * j] - truth.means[3 * i]) < 1e-5f &&
                    std::abs(scene.means[3 * j + 1] - truth.means[3 * i + 1]) < 1e-5f &&
                    std::abs(scene.means[3 * j + 2] - truth.means[3 * i + 2]) < 1e-5f &&
                    std::abs(scene.opacity_logits[i] - logit) < 1e-5f;
    }
    EXPECT_TRUE(on_a_parent) << j;
  }
}

TEST(SceneOptimizer, RejectsWhatItCannotOptimise) {
  GaussianScene scene = WallScene();
  const std::vector<ContextView> views = ViewsOf(scene, {1});
  OptimizeOptions options;
  options.steps = 1;
  absl::StatusOr<OptimizeStats> r =
      OptimizeScene(views, std::vector<uint8_t>(3, 0), options, &scene);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("fixed: has 3 entries"), std::string::npos) << r.status();
  r = OptimizeScene({}, {}, options, &scene);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("views"), std::string::npos) << r.status();
  options.steps = 0;
  r = OptimizeScene({}, {}, options, &scene);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->steps, 0);
}

}  // namespace
}  // namespace pf
