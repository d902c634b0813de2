// Tests of the rasterizer's backward pass: its forward half against the
// reference renderer, its gradients against central differences in double
// for every parameter kind and camera model, the camera motion's gradient
// likewise, the float pass against the double one, and bad input.
#include "engine/render/raster_backward.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "engine/render/random_scene_testing.h"
#include "engine/render/raster_frame.h"
#include "engine/render/reference_renderer.h"

namespace pf {
namespace {

using testing_scenes::MovedCameraOfModel;
using testing_scenes::RandomScene;
using testing_scenes::RandomSceneSpec;

constexpr int64_t kTime = 1'600'000;  // 0.6 s after RandomScene's time origin.

// Random output gradients (rgb, alpha, depth, features) for `camera`.
OutputGradients<double> RandomOutputGradients(const RenderCamera& camera, int channels,
                                              uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  const size_t pixels = static_cast<size_t>(camera.model.width()) * camera.model.height();
  OutputGradients<double> g;
  g.rgb.resize(3 * pixels);
  g.alpha.resize(pixels);
  g.depth.resize(pixels);
  g.features.resize(pixels * channels);
  for (auto* v : {&g.rgb, &g.alpha, &g.depth, &g.features}) {
    for (double& x : *v) x = u(rng);
  }
  for (double& x : g.depth) x *= 0.1;  // Depth is in metres, colours in [0, 1].
  return g;
}

// The same output gradients in float, as RenderBackward() takes them.
RenderOutputGradients InFloat(const OutputGradients<double>& g) {
  RenderOutputGradients f;
  f.rgb.assign(g.rgb.begin(), g.rgb.end());
  f.alpha.assign(g.alpha.begin(), g.alpha.end());
  f.depth.assign(g.depth.begin(), g.depth.end());
  f.features.assign(g.features.begin(), g.features.end());
  return f;
}

// sum of grads . outputs of a double render.
double Loss(const testing::DoubleRender& r, const OutputGradients<double>& g) {
  double sum = 0;
  for (size_t k = 0; k < g.rgb.size(); ++k) sum += g.rgb[k] * r.rgb[k];
  for (size_t k = 0; k < g.alpha.size(); ++k) sum += g.alpha[k] * r.alpha[k];
  for (size_t k = 0; k < g.depth.size(); ++k) sum += g.depth[k] * r.depth[k];
  for (size_t k = 0; k < g.features.size(); ++k) sum += g.features[k] * r.features[k];
  return sum;
}

// A small scene of overlapping Gaussians, some nearly transparent, a few
// pixels to a few tiles across, some moving with an actor.
GaussianScene SmallScene(const RenderCamera& camera, uint32_t seed, bool gradients) {
  RandomSceneSpec spec;
  spec.seed = seed;
  spec.count = 40;
  spec.channels = 4;
  spec.instances = true;  // A quarter of them in two actors' canonical frames.
  spec.colour_gradients = gradients;
  GaussianScene scene = RandomScene(spec, camera);
  std::mt19937 rng(seed + 100);
  std::uniform_real_distribution<double> u(0, 1);
  for (size_t i = 0; i < scene.size(); ++i) {
    // Opacities from nearly transparent (0.02) to 0.95, none at the 0.99
    // clamp; larger splats, so that most overlap.
    scene.opacity_logits[i] = static_cast<float>(u(rng) < 0.3 ? -3.9 + u(rng) : 2.9 * u(rng) - 1);
    for (int c = 0; c < 3; ++c) scene.log_scales[3 * i + c] += 1.2f;
    scene.lifespans[i] = std::numeric_limits<float>::infinity();
  }
  return scene;
}

struct KindError {
  double max_error = 0;  // Largest |analytic - numeric|.
  double scale = 0;      // Largest |numeric|.
  int checked = 0;
  int skipped = 0;  // Where a threshold was crossed: not smooth.
};

// Compares the analytic gradients of up to 24 parameters of each kind
// (spread over the scene) with central differences. Two steps tell where a
// pixel crosses the 1/255 cut-off within the step (the loss steps there):
// such a parameter is counted as skipped.
std::vector<std::pair<std::string, KindError>> CompareWithDifferences(
    const GaussianScene& scene, const RenderCamera& camera, const OutputGradients<double>& g) {
  const GaussianParams<double> base = testing::ParamsInDouble(scene);
  absl::StatusOr<testing::DoubleRender> at =
      testing::RenderBackwardInDouble(scene, base, camera, kTime, g);
  EXPECT_TRUE(at.ok()) << at.status();
  if (!at.ok()) return {};
  using Member = std::vector<double> GaussianParams<double>::*;
  const std::vector<std::pair<std::string, Member>> kinds = {
      {"means", &GaussianParams<double>::means},
      {"rotations", &GaussianParams<double>::rotations},
      {"log_scales", &GaussianParams<double>::log_scales},
      {"opacity_logits", &GaussianParams<double>::opacity_logits},
      {"features", &GaussianParams<double>::features},
      {"colour_gradients", &GaussianParams<double>::colour_gradients}};
  auto difference = [&](Member member, size_t k, double h) {
    GaussianParams<double> p = base;
    (p.*member)[k] += h;
    const double up = Loss(*testing::RenderBackwardInDouble(scene, p, camera, kTime, {}), g);
    (p.*member)[k] -= 2 * h;
    const double down = Loss(*testing::RenderBackwardInDouble(scene, p, camera, kTime, {}), g);
    return (up - down) / (2 * h);
  };
  std::vector<std::pair<std::string, KindError>> errors;
  for (const auto& [name, member] : kinds) {
    KindError e;
    const std::vector<double>& analytic = at->grads.*member;
    const size_t size = (base.*member).size();
    constexpr size_t kPerKind = 16;
    for (size_t j = 0; j < std::min(size, kPerKind); ++j) {
      const size_t k = j * size / std::min(size, kPerKind) + (j % 3);
      if (k >= size) continue;
      const double numeric = difference(member, k, 1e-5);
      if (std::abs(numeric - difference(member, k, 2e-6)) > 1e-3 * (std::abs(numeric) + 1e-2)) {
        ++e.skipped;
        continue;
      }
      e.max_error = std::max(e.max_error, std::abs(analytic[k] - numeric));
      e.scale = std::max(e.scale, std::abs(numeric));
      ++e.checked;
    }
    errors.push_back({name, e});
  }
  return errors;
}

TEST(RasterBackward, ForwardHalfMatchesTheReferenceRenderer) {
  for (int model = 0; model < testing_scenes::kCameraModels; ++model) {
    for (bool gradients : {false, true}) {
      SCOPED_TRACE(::testing::Message() << "camera model " << model << " gradients " << gradients);
      const RenderCamera camera = MovedCameraOfModel(model);
      RandomSceneSpec spec;
      spec.seed = 7 + model;
      spec.colour_gradients = gradients;
      GaussianScene scene = RandomScene(spec, camera);
      scene.order_band = gradients ? 0.02f : 0.f;  // The band's order where it is set.
      absl::StatusOr<testing::DoubleRender> ours =
          testing::RenderBackwardInDouble(scene, testing::ParamsInDouble(scene), camera, kTime, {});
      ASSERT_TRUE(ours.ok()) << ours.status();
      std::vector<uint8_t> ambiguous;
      const RenderBuffers ref = testing::ReferenceRender(scene, camera, kTime, {}, {}, &ambiguous);
      double worst = 0, alpha_sum = 0;
      for (size_t p = 0; p < ref.alpha.size(); ++p) {
        if (ambiguous[p]) continue;
        alpha_sum += ref.alpha[p];
        worst = std::max(worst, std::abs(ours->alpha[p] - ref.alpha[p]));
        for (int c = 0; c < 3; ++c) {
          worst = std::max(worst, std::abs(ours->rgb[3 * p + c] - ref.rgb[3 * p + c]));
        }
        for (int c = 0; c < scene.num_channels; ++c) {
          const size_t k = p * scene.num_channels + c;
          worst = std::max(worst, std::abs(ours->features[k] - ref.features[k]));
        }
        worst = std::max(worst, 0.01 * std::abs(ours->depth[p] - ref.depth[p]));
      }
      EXPECT_GT(alpha_sum, 0.3 * ref.alpha.size());  // The scene covers the image.
      EXPECT_LT(worst, 2e-4);
    }
  }
}

// Every parameter kind and camera model, flat and textured colours.
TEST(RasterBackward, GradientsMatchCentralDifferences) {
  for (int model = 0; model < testing_scenes::kCameraModels; ++model) {
    for (bool gradients : {false, true}) {
      SCOPED_TRACE(::testing::Message() << "camera model " << model << " gradients " << gradients);
      RenderCamera camera = MovedCameraOfModel(model);
      const GaussianScene scene = SmallScene(camera, 3 + model, gradients);
      const OutputGradients<double> g = RandomOutputGradients(camera, scene.num_channels, model);
      for (const auto& [name, e] : CompareWithDifferences(scene, camera, g)) {
        if (name == "colour_gradients" && !gradients) {
          EXPECT_EQ(e.checked, 0);
          continue;
        }
        EXPECT_LE(e.skipped, 1) << name;
        std::printf("model %d gradients %d %-16s relative error %.2e (%d checked)\n", model,
                    gradients, name.c_str(), e.max_error / e.scale, e.checked);
        EXPECT_GT(e.scale, 1e-3) << name;  // The loss does depend on the parameter.
        // The distortion Jacobian's own derivative is a central difference
        // (raster_backward.h): a little less exact than the pinhole's.
        const double tolerance = model == 0 ? 1e-6 : 1e-4;
        EXPECT_LT(e.max_error, tolerance * e.scale + 1e-7)
            << name << ": " << e.checked << " parameters, largest gradient " << e.scale;
      }
    }
  }
}

TEST(RasterBackward, FloatPassMatchesTheDoublePass) {
  for (int model = 0; model < testing_scenes::kCameraModels; ++model) {
    SCOPED_TRACE(::testing::Message() << "camera model " << model);
    const RenderCamera camera = MovedCameraOfModel(model);
    RandomSceneSpec spec;
    spec.seed = 11 + model;
    spec.colour_gradients = model % 2 == 1;
    const GaussianScene scene = RandomScene(spec, camera);
    const OutputGradients<double> g = RandomOutputGradients(camera, scene.num_channels, 5);
    absl::StatusOr<testing::DoubleRender> exact =
        testing::RenderBackwardInDouble(scene, testing::ParamsInDouble(scene), camera, kTime, g);
    ASSERT_TRUE(exact.ok()) << exact.status();
    const RenderOutputGradients gf = InFloat(g);
    BackwardStats stats;
    absl::StatusOr<SceneGradients> fast = RenderBackward(scene, camera, kTime, {}, gf, {}, &stats);
    ASSERT_TRUE(fast.ok()) << fast.status();
    // The same pairs as Render() blends (its exp is a polynomial: a pair at
    // the 1/255 cut-off may rarely go the other way).
    absl::StatusOr<RenderBuffers> render = Render(scene, camera, kTime, {});
    ASSERT_TRUE(render.ok());
    EXPECT_GT(stats.pairs_contributing, 1000);
    EXPECT_NEAR(stats.pairs_contributing, render->stats.pairs_contributing,
                1e-4 * render->stats.pairs_contributing + 2);
    auto compare = [](const std::vector<float>& f, const std::vector<double>& d, const char* name) {
      ASSERT_EQ(f.size(), d.size()) << name;
      double diff = 0, norm = 0;
      for (size_t k = 0; k < f.size(); ++k) {
        diff += (f[k] - d[k]) * (f[k] - d[k]);
        norm += d[k] * d[k];
      }
      EXPECT_GT(norm, 0) << name;
      EXPECT_LT(std::sqrt(diff), 2e-3 * std::sqrt(norm)) << name;
    };
    compare(fast->means, exact->grads.means, "means");
    compare(fast->rotations, exact->grads.rotations, "rotations");
    compare(fast->log_scales, exact->grads.log_scales, "log_scales");
    compare(fast->opacity_logits, exact->grads.opacity_logits, "opacity_logits");
    compare(fast->features, exact->grads.features, "features");
    if (spec.colour_gradients) {
      compare(fast->colour_gradients, exact->grads.colour_gradients, "colour_gradients");
    }
    // Repeated, the same bits.
    absl::StatusOr<SceneGradients> again = RenderBackward(scene, camera, kTime, {}, gf);
    ASSERT_TRUE(again.ok());
    EXPECT_EQ(again->means, fast->means);
    EXPECT_EQ(again->features, fast->features);
  }
}

// A gradient step on colours, opacities and geometry towards a target render
// lowers the squared error: the gradient points the right way on a scene
// where every term acts at once.
TEST(RasterBackward, AStepAgainstTheGradientLowersTheError) {
  const RenderCamera camera = MovedCameraOfModel(1);
  const GaussianScene target_scene = SmallScene(camera, 21, false);
  absl::StatusOr<RenderBuffers> target = Render(target_scene, camera, kTime, {});
  ASSERT_TRUE(target.ok());
  GaussianScene scene = target_scene;
  std::mt19937 rng(4);
  std::normal_distribution<float> noise(0, 0.05f);
  for (float& m : scene.means) m += noise(rng);
  for (float& f : scene.features) f += 4 * noise(rng);
  auto error = [&](const GaussianScene& s, RenderOutputGradients* g) {
    absl::StatusOr<RenderBuffers> r = Render(s, camera, kTime, {});
    double sum = 0;
    if (g != nullptr) g->rgb.resize(r->rgb.size());
    for (size_t k = 0; k < r->rgb.size(); ++k) {
      const double d = r->rgb[k] - target->rgb[k];
      sum += 0.5 * d * d;
      if (g != nullptr) g->rgb[k] = static_cast<float>(d);
    }
    return sum;
  };
  RenderOutputGradients g;
  const double before = error(scene, &g);
  RenderOptions options;
  options.features = false;
  absl::StatusOr<SceneGradients> grad = RenderBackward(scene, camera, kTime, {}, g, options);
  ASSERT_TRUE(grad.ok()) << grad.status();
  // A step of eps against the gradient lowers the error by about
  // eps |gradient|^2 (first order).
  double norm2 = 0, largest = 0;
  for (const std::vector<float>* v : {&grad->means, &grad->features, &grad->log_scales,
                                      &grad->rotations, &grad->opacity_logits}) {
    for (float x : *v) {
      norm2 += double{x} * x;
      largest = std::max(largest, std::abs(double{x}));
    }
  }
  const double eps = 2e-4 / largest;
  auto step = [eps](std::vector<float>* p, const std::vector<float>& d) {
    for (size_t k = 0; k < p->size(); ++k) (*p)[k] -= static_cast<float>(eps * d[k]);
  };
  step(&scene.means, grad->means);
  step(&scene.features, grad->features);
  step(&scene.log_scales, grad->log_scales);
  step(&scene.rotations, grad->rotations);
  step(&scene.opacity_logits, grad->opacity_logits);
  const double after = error(scene, nullptr);
  const double predicted = eps * norm2;
  EXPECT_NEAR(before - after, predicted, 0.2 * predicted) << before << " -> " << after;
}

// The parameters of `scene` moved as the camera moved by `motion` would see
// them from the unmoved camera: per owner, x' = C^-1 M^-1 C x (C camera
// from owner at kTime, M the motion), rotations turned likewise.
GaussianParams<double> MovedAgainst(const GaussianScene& scene,
                                    const GaussianParams<double>& params,
                                    const RenderCamera& camera, const CameraMotion& motion) {
  raster::RenderFrame frame;
  EXPECT_TRUE(raster::SetUpRenderFrame(scene.instances, scene.time_origin_us, scene.fade_span,
                                       camera, kTime, {}, RenderOptions{}.near_plane, &frame)
                  .ok());
  const Rigid step{RotationFromVector({motion[0], motion[1], motion[2]}),
                   {motion[3], motion[4], motion[5]}};
  GaussianParams<double> out = params;
  for (size_t i = 0; i < scene.size(); ++i) {
    const raster::Transform& t = frame.camera_from_owner[scene.owners[i]];
    Rigid c;
    for (int r = 0; r < 3; ++r) {
      for (int k = 0; k < 3; ++k) c.rotation.m[r][k] = t.r[3 * r + k];
      c.translation[r] = t.t[r];
    }
    const Rigid m = c.Inverse() * step.Inverse() * c;
    const Vec3 x = m * Vec3{params.means[3 * i], params.means[3 * i + 1], params.means[3 * i + 2]};
    for (int k = 0; k < 3; ++k) out.means[3 * i + k] = x[k];
    const double* q = &params.rotations[4 * i];
    const Quat turned = FromMatrix(m.rotation) * Quat{q[0], q[1], q[2], q[3]};
    out.rotations[4 * i] = turned.w;
    out.rotations[4 * i + 1] = turned.x;
    out.rotations[4 * i + 2] = turned.y;
    out.rotations[4 * i + 3] = turned.z;
  }
  return out;
}

// Moving the camera renders what moving the Gaussians the other way does
// (the identity CameraMotionGradient rests on), and MovedCamera moves it in
// its own frame.
TEST(RasterBackward, MovingTheCameraIsMovingTheGaussiansBack) {
  for (int model = 0; model < testing_scenes::kCameraModels; ++model) {
    SCOPED_TRACE(::testing::Message() << "camera model " << model);
    const RenderCamera camera = MovedCameraOfModel(model);
    const GaussianScene scene = SmallScene(camera, 30 + model, true);
    const GaussianParams<double> base = testing::ParamsInDouble(scene);
    const CameraMotion motion = {0.01, -0.02, 0.015, 0.05, -0.03, 0.02};
    const RenderCamera moved = MovedCamera(camera, motion);
    const Vec3 shift = moved.world_from_camera.translation - camera.world_from_camera.translation;
    const Vec3 local = camera.world_from_camera.rotation * Vec3{0.05, -0.03, 0.02};
    EXPECT_LT(Norm(shift - local), 1e-12);
    absl::StatusOr<testing::DoubleRender> by_camera =
        testing::RenderBackwardInDouble(scene, base, moved, kTime, {});
    absl::StatusOr<testing::DoubleRender> by_gaussians = testing::RenderBackwardInDouble(
        scene, MovedAgainst(scene, base, camera, motion), camera, kTime, {});
    absl::StatusOr<testing::DoubleRender> unmoved =
        testing::RenderBackwardInDouble(scene, base, camera, kTime, {});
    ASSERT_TRUE(by_camera.ok() && by_gaussians.ok() && unmoved.ok());
    double differ = 0, moved_by = 0;
    for (size_t k = 0; k < by_camera->rgb.size(); ++k) {
      differ += std::abs(by_camera->rgb[k] - by_gaussians->rgb[k]);
      moved_by += std::abs(by_camera->rgb[k] - unmoved->rgb[k]);
    }
    differ /= by_camera->rgb.size();
    moved_by /= by_camera->rgb.size();
    EXPECT_GT(moved_by, 1e-2);
    EXPECT_LT(differ, 1e-5) << "the motion moves the render by " << moved_by;
  }
}

// The camera motion's gradient against central differences of the loss with
// the Gaussians moved back (in double: steps far under the float camera's
// resolution), every camera model, with actors.
TEST(RasterBackward, CameraMotionGradientMatchesCentralDifferences) {
  for (int model = 0; model < testing_scenes::kCameraModels; ++model) {
    SCOPED_TRACE(::testing::Message() << "camera model " << model);
    const RenderCamera camera = MovedCameraOfModel(model);
    const GaussianScene scene = SmallScene(camera, 70 + model, model % 2 == 1);
    const OutputGradients<double> g = RandomOutputGradients(camera, scene.num_channels, 50 + model);
    const GaussianParams<double> base = testing::ParamsInDouble(scene);
    absl::StatusOr<testing::DoubleRender> at =
        testing::RenderBackwardInDouble(scene, base, camera, kTime, g);
    ASSERT_TRUE(at.ok()) << at.status();
    absl::StatusOr<CameraMotion> analytic =
        testing::CameraMotionGradientInDouble(scene, base, camera, kTime, at->grads);
    ASSERT_TRUE(analytic.ok()) << analytic.status();
    auto difference = [&](int k, double h) {
      CameraMotion motion{};
      motion[k] = h;
      const double up =
          Loss(*testing::RenderBackwardInDouble(scene, MovedAgainst(scene, base, camera, motion),
                                                camera, kTime, {}),
               g);
      motion[k] = -h;
      const double down =
          Loss(*testing::RenderBackwardInDouble(scene, MovedAgainst(scene, base, camera, motion),
                                                camera, kTime, {}),
               g);
      return (up - down) / (2 * h);
    };
    double scale = 0, worst = 0;
    int checked = 0;
    constexpr double kSteps[] = {1e-5, 3e-6, 1e-6, 3e-7, 1e-7};
    for (int k = 0; k < 6; ++k) {
      // The first of two steps in turn that agree: a larger step may take
      // a pixel across a cut-off, a smaller one meets the lens's rounding.
      double numeric = std::nan("");
      double previous = difference(k, kSteps[0]);
      for (size_t step = 1; step < std::size(kSteps) && std::isnan(numeric); ++step) {
        const double d = difference(k, kSteps[step]);
        if (std::abs(d - previous) <= 1e-4 * (std::abs(d) + 10)) numeric = d;
        previous = d;
      }
      if (std::isnan(numeric)) continue;
      ++checked;
      scale = std::max(scale, std::abs(numeric));
      worst = std::max(worst, std::abs((*analytic)[k] - numeric));
    }
    std::printf("model %d camera motion relative error %.2e (%d of 6 checked)\n", model,
                worst / scale, checked);
    EXPECT_EQ(checked, 6);
    EXPECT_GT(scale, 1);
    // The distortion's Jacobian is itself a central difference (as in
    // GradientsMatchCentralDifferences).
    EXPECT_LT(worst, (model == 0 ? 2e-5 : 1e-4) * scale);
  }
}

// Moving a pinhole camera's principal point by h pixels moves every
// Gaussian's projected centre by h pixels and nothing else, so the loss's
// derivative along it is the sum of the screen-space centre gradients
// (none for a Gaussian the camera does not see), their colour gradients'
// share included. The Gaussians are wide enough that no pixel of the image
// is near their 1/255 cut-off, whose steps a finite difference would count.
TEST(RasterBackward, ScreenCentreGradientsSumToThePrincipalPointsGradient) {
  RenderCamera camera;
  camera.model = CameraModel(96, 72, 76.8, 76.8, 48, 36);
  GaussianScene scene;
  scene.num_channels = 3;
  std::mt19937 rng(21);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  scene.Resize(6);
  for (size_t i = 0; i < scene.size(); ++i) {
    scene.means[3 * i] = 1.2f * u(rng) - 0.6f;
    scene.means[3 * i + 1] = 0.9f * u(rng) - 0.45f;
    scene.means[3 * i + 2] = 5.f + 3.f * u(rng);
    for (int k = 0; k < 4; ++k) scene.rotations[4 * i + k] = u(rng) - 0.5f;
    for (int k = 0; k < 3; ++k) {
      scene.log_scales[3 * i + k] = std::log(3.f + 1.5f * u(rng));
      scene.features[3 * i + k] = u(rng);
    }
    scene.opacity_logits[i] = -1.f + u(rng);  // Opacity 0.27-0.5.
  }
  scene.colour_gradients.resize(6 * scene.size());
  for (float& g : scene.colour_gradients) g = 0.2f * (u(rng) - 0.5f);
  scene.Resize(7);  // And one behind the camera.
  scene.means[3 * 6 + 2] = -3.f;
  scene.log_scales[3 * 6] = scene.log_scales[3 * 6 + 1] = scene.log_scales[3 * 6 + 2] = 0.f;
  const OutputGradients<double> g = RandomOutputGradients(camera, scene.num_channels, 9);
  const RenderOutputGradients gf = InFloat(g);
  RenderOptions options;
  ScreenGradients screen;
  absl::StatusOr<SceneGradients> grads =
      RenderBackward(scene, camera, kTime, {}, gf, options, nullptr, &screen);
  ASSERT_TRUE(grads.ok()) << grads.status();
  ASSERT_EQ(screen.visible.size(), scene.size());
  ASSERT_EQ(screen.centre.size(), 2 * scene.size());
  double sum[2] = {0, 0};
  int visible = 0;
  for (size_t i = 0; i < scene.size(); ++i) {
    visible += screen.visible[i];
    if (!screen.visible[i]) {
      EXPECT_EQ(screen.centre[2 * i], 0.f);
      EXPECT_EQ(screen.centre[2 * i + 1], 0.f);
    }
    sum[0] += screen.centre[2 * i];
    sum[1] += screen.centre[2 * i + 1];
  }
  EXPECT_EQ(visible, 6);
  EXPECT_EQ(screen.visible[6], 0);
  const CameraModel& m = camera.model;
  auto loss_at = [&](double dx, double dy) {
    RenderCamera moved = camera;
    moved.model = CameraModel(m.width(), m.height(), m.fx(), m.fy(), m.cx() + dx, m.cy() + dy);
    return Loss(
        *testing::RenderBackwardInDouble(scene, testing::ParamsInDouble(scene), moved, kTime, {}),
        g);
  };
  // The lens keeps the principal point in float: a step of 1/100 pixel.
  constexpr double kH = 1e-2;
  const double numeric[2] = {(loss_at(kH, 0) - loss_at(-kH, 0)) / (2 * kH),
                             (loss_at(0, kH) - loss_at(0, -kH)) / (2 * kH)};
  const double scale = std::abs(numeric[0]) + std::abs(numeric[1]);
  EXPECT_GT(scale, 0.1);  // The loss does move with the centres.
  for (int a = 0; a < 2; ++a) EXPECT_NEAR(sum[a], numeric[a], 1e-3 * scale) << a;
}

TEST(RasterBackward, RejectsWhatItCannotDifferentiate) {
  const RenderCamera camera = MovedCameraOfModel(0);
  RandomSceneSpec spec;
  spec.sh_degree = 1;
  GaussianScene sh = RandomScene(spec, camera);
  absl::StatusOr<SceneGradients> r = RenderBackward(sh, camera, kTime, {}, {});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("scene.sh_degree"), std::string::npos) << r.status();

  spec.sh_degree = -1;
  const GaussianScene scene = RandomScene(spec, camera);
  RenderOutputGradients g;
  g.rgb.resize(10);
  r = RenderBackward(scene, camera, kTime, {}, g);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("grads.rgb: has 10 values"), std::string::npos) << r.status();

  g = {};
  g.features.resize(static_cast<size_t>(96 * 72) * scene.num_channels);
  RenderOptions no_features;
  no_features.features = false;
  r = RenderBackward(scene, camera, kTime, {}, g, no_features);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("grads.features"), std::string::npos) << r.status();

  RenderCamera rolling = camera;
  rolling.rolling_shutter = RollingShutter{{}, 0, camera.world_from_camera};
  r = RenderBackward(scene, rolling, kTime, {}, {});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("no rolling shutter"), std::string::npos) << r.status();

  absl::StatusOr<SceneGradients> grads = RenderBackward(scene, camera, kTime, {}, {});
  ASSERT_TRUE(grads.ok());
  EXPECT_TRUE(CameraMotionGradient(scene, camera, kTime, {}, *grads).ok());
  absl::StatusOr<CameraMotion> motion = CameraMotionGradient(scene, rolling, kTime, {}, *grads);
  ASSERT_FALSE(motion.ok());
  EXPECT_NE(motion.status().message().find("no rolling shutter"), std::string::npos)
      << motion.status();
  grads->means.pop_back();
  motion = CameraMotionGradient(scene, camera, kTime, {}, *grads);
  ASSERT_FALSE(motion.ok());
  EXPECT_NE(motion.status().message().find("grads:"), std::string::npos) << motion.status();
}

}  // namespace
}  // namespace pf
