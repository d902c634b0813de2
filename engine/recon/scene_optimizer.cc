// Per-scene optimisation (scene_optimizer.h).
#include "engine/recon/scene_optimizer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <random>
#include <span>

#include "absl/strings/str_cat.h"
#include "common/thread_pool.h"
#include "engine/recon/image_metrics.h"
#include "engine/recon/photometric_loss.h"
#include "engine/render/raster_backward.h"
#include "engine/render/rasterizer.h"

namespace pf {
namespace {

double ElapsedSeconds(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// Adam (Kingma and Ba) over one parameter array, its step count its own.
class Adam {
 public:
  void Reset(size_t n) {
    m_.assign(n, 0.f);
    v_.assign(n, 0.f);
    t_ = 0;
  }
  // One step of size `lr` with gradient `g`; entries whose `keep` row (of
  // `width` values) is set are not moved.
  void Step(std::span<float> params, std::span<const float> g, double lr,
            const std::vector<uint8_t>* keep = nullptr, int width = 1) {
    constexpr double kBeta1 = 0.9, kBeta2 = 0.999, kEps = 1e-15;
    ++t_;
    const double c1 = 1 - std::pow(kBeta1, t_), c2 = 1 - std::pow(kBeta2, t_);
    const float step = static_cast<float>(lr * std::sqrt(c2) / c1);
    const float eps = static_cast<float>(kEps * std::sqrt(c2));
    float* p = params.data();
    float* m = m_.data();
    float* v = v_.data();
    const float* gr = g.data();
    const int64_t n = static_cast<int64_t>(params.size());
    DefaultThreadPool().ParallelFor(0, n, 1 << 16, [&](int64_t b, int64_t e) {
      for (int64_t k = b; k < e; ++k) {
        if (keep != nullptr && (*keep)[k / width]) continue;
        m[k] = static_cast<float>(kBeta1) * m[k] + static_cast<float>(1 - kBeta1) * gr[k];
        v[k] = static_cast<float>(kBeta2) * v[k] + static_cast<float>(1 - kBeta2) * gr[k] * gr[k];
        p[k] -= step * m[k] / (std::sqrt(v[k]) + eps);
      }
    });
  }

 private:
  std::vector<float> m_, v_;
  int t_ = 0;
};

// 1.1 times the largest distance of a camera centre from their mean, at
// least 1 m (3DGS's scene extent).
double CameraSpread(const std::vector<ContextView>& views) {
  Vec3 mean{0, 0, 0};
  for (const ContextView& v : views) mean = mean + v.world_from_camera.translation;
  mean = mean * (1.0 / static_cast<double>(views.size()));
  double radius = 0;
  for (const ContextView& v : views) {
    radius = std::max(radius, Norm(v.world_from_camera.translation - mean));
  }
  return std::max(1.0, 1.1 * radius);
}

}  // namespace

absl::StatusOr<OptimizeStats> OptimizeScene(const std::vector<ContextView>& views,
                                            const std::vector<uint8_t>& fixed,
                                            const OptimizeOptions& options, GaussianScene* scene) {
  OptimizeStats stats;
  if (options.steps <= 0) return stats;
  if (views.empty())
    return absl::InvalidArgumentError("views: no context view to optimise against");
  if (absl::Status s = CheckRenderable(*scene); !s.ok()) return s;
  for (const ContextView& view : views) {
    if (view.rolling_shutter.has_value()) {
      return absl::InvalidArgumentError(absl::StrCat(
          "frames[", view.frame_index,
          "].rollingShutter: the optimisation (--optimize-steps) has no rolling shutter yet; "
          "reconstruct this clip without it"));
    }
  }
  if (scene->sh_degree >= 0) {
    return absl::InvalidArgumentError(
        "scene.sh_degree: the optimisation needs feature colours (sh_degree -1)");
  }
  const size_t n = scene->size();
  if (!fixed.empty() && fixed.size() != n) {
    return absl::InvalidArgumentError(
        absl::StrCat("fixed: has ", fixed.size(), " entries for ", n, " Gaussians"));
  }
  for (size_t v = 0; v < views.size(); ++v) {
    if (views[v].rgb.width != views[v].width() || views[v].rgb.height != views[v].height() ||
        views[v].rgb.channels != 3) {
      return absl::InvalidArgumentError(
          absl::StrCat("views[", v, "].rgb: not a 3-channel image of the camera's size"));
    }
  }
  const auto start = std::chrono::steady_clock::now();
  stats.spread = CameraSpread(views);

  Adam means, rotations, log_scales, opacities, colours, gradients;
  means.Reset(scene->means.size());
  rotations.Reset(scene->rotations.size());
  log_scales.Reset(scene->log_scales.size());
  opacities.Reset(scene->opacity_logits.size());
  colours.Reset(scene->features.size());
  gradients.Reset(scene->colour_gradients.size());
  const std::vector<uint8_t>* keep = fixed.empty() ? nullptr : &fixed;

  // Exposures: [M | b] per view, and their own Adam each.
  constexpr std::array<float, 12> kIdentity = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
  stats.exposures.assign(views.size(), kIdentity);
  std::vector<Adam> exposure_adam(views.size());
  for (Adam& adam : exposure_adam) adam.Reset(12);
  // Pose corrections: (w, t) per view, an Adam for each half.
  std::vector<std::array<float, 6>> poses(views.size(), std::array<float, 6>{});
  std::vector<Adam> pose_adam(2 * views.size());
  for (Adam& adam : pose_adam) adam.Reset(3);
  auto motion_of = [&](size_t v) {
    CameraMotion m;
    for (int k = 0; k < 6; ++k) m[k] = poses[v][k];
    return m;
  };
  // The pixels each view's loss counts: those off the ego vehicle (all
  // when the camera has no mask).
  std::vector<std::vector<uint8_t>> counted(views.size());
  for (size_t v = 0; v < views.size(); ++v) {
    const std::vector<uint8_t>& ego = views[v].ego;
    counted[v].resize(ego.size());
    for (size_t p = 0; p < ego.size(); ++p) counted[v][p] = ego[p] == 0;
  }

  std::mt19937 rng(options.seed);
  std::vector<size_t> order(views.size());
  RenderOptions render_options;
  render_options.features = false;
  render_options.depth = false;
  render_options.instance = false;
  double epoch_loss = 0, epoch_psnr = 0;
  int epoch_count = 0;
  for (int step = 0; step < options.steps; ++step) {
    if (options.max_seconds > 0 && ElapsedSeconds(start) >= options.max_seconds) break;
    const size_t slot = static_cast<size_t>(step) % views.size();
    if (slot == 0) {
      std::iota(order.begin(), order.end(), 0);
      std::shuffle(order.begin(), order.end(), rng);
      epoch_loss = epoch_psnr = 0;
      epoch_count = 0;
    }
    const size_t vi = order[slot];
    const ContextView& view = views[vi];
    const RenderCamera camera = MovedCamera({view.camera, view.world_from_camera}, motion_of(vi));

    // Render and expose.
    auto t0 = std::chrono::steady_clock::now();
    absl::StatusOr<RenderBuffers> render =
        Render(*scene, camera, view.timestamp_us, {}, render_options);
    if (!render.ok()) return render.status();
    stats.render_seconds += ElapsedSeconds(t0);
    const size_t pixels = static_cast<size_t>(view.width()) * view.height();
    std::array<float, 12>& e = stats.exposures[vi];
    std::vector<float> exposed(3 * pixels);
    for (size_t p = 0; p < pixels; ++p) {
      const float* x = &render->rgb[3 * p];
      for (int c = 0; c < 3; ++c) {
        exposed[3 * p + c] =
            e[4 * c] * x[0] + e[4 * c + 1] * x[1] + e[4 * c + 2] * x[2] + e[4 * c + 3];
      }
    }
    std::vector<float> g_exposed;
    const PhotometricLoss loss = PhotometricLossAndGradient(exposed.data(), view.rgb, counted[vi],
                                                            options.ssim_weight, &g_exposed);
    stats.loss.push_back(static_cast<float>(loss.value));
    const double psnr = loss.mse > 0 ? -10 * std::log10(loss.mse) : kMaxPsnr;
    stats.psnr.push_back(static_cast<float>(psnr));
    epoch_loss += loss.value;
    epoch_psnr += psnr;
    ++epoch_count;

    // Back through the exposure.
    RenderOutputGradients grads;
    grads.rgb.assign(3 * pixels, 0.f);
    std::array<double, 12> g_e{};
    for (size_t p = 0; p < pixels; ++p) {
      const float* g = &g_exposed[3 * p];
      const float* x = &render->rgb[3 * p];
      for (int c = 0; c < 3; ++c) {
        for (int k = 0; k < 3; ++k) {
          grads.rgb[3 * p + k] += e[4 * c + k] * g[c];
          g_e[4 * c + k] += double{g[c]} * x[k];
        }
        g_e[4 * c + 3] += g[c];
      }
    }
    t0 = std::chrono::steady_clock::now();
    absl::StatusOr<SceneGradients> g =
        RenderBackward(*scene, camera, view.timestamp_us, {}, grads, render_options);
    if (!g.ok()) return g.status();
    CameraMotion g_pose{};
    if (options.pose) {
      // From the scene as rendered, before its own step.
      absl::StatusOr<CameraMotion> motion =
          CameraMotionGradient(*scene, camera, view.timestamp_us, {}, *g, render_options);
      if (!motion.ok()) return motion.status();
      g_pose = *motion;
    }
    stats.backward_seconds += ElapsedSeconds(t0);

    // Adam.
    t0 = std::chrono::steady_clock::now();
    const double progress = options.steps > 1 ? double(step) / (options.steps - 1) : 0.0;
    const int warmup =
        options.warmup_steps > 0 ? options.warmup_steps : static_cast<int>(views.size());
    const double ramp = std::min(1.0, double(step + 1) / warmup);
    const double lr_mean = options.lr_mean > 0
                               ? stats.spread * options.lr_mean *
                                     std::pow(options.lr_mean_final / options.lr_mean, progress)
                               : 0.0;
    means.Step(scene->means, g->means, ramp * lr_mean, keep, 3);
    rotations.Step(scene->rotations, g->rotations, ramp * options.lr_rotation, keep, 4);
    log_scales.Step(scene->log_scales, g->log_scales, ramp * options.lr_log_scale, keep, 3);
    opacities.Step(scene->opacity_logits, g->opacity_logits, ramp * options.lr_opacity);
    colours.Step(scene->features, g->features, ramp * options.lr_colour);
    if (scene->has_colour_gradients()) {
      gradients.Step(scene->colour_gradients, g->colour_gradients, ramp * options.lr_colour);
    }
    if (options.exposure) {
      // The prior pulls [M | b] towards [I | 0].
      std::array<float, 12> grad;
      for (int k = 0; k < 12; ++k) {
        grad[k] = static_cast<float>(g_e[k] + 2 * options.exposure_prior * (e[k] - kIdentity[k]));
      }
      exposure_adam[vi].Step(e, grad, options.lr_exposure);
    }
    if (options.pose) {
      std::array<float, 6> grad;
      for (int k = 0; k < 6; ++k) grad[k] = static_cast<float>(g_pose[k]);
      const std::span<float> pose(poses[vi]);
      const std::span<const float> g_span(grad);
      pose_adam[2 * vi].Step(pose.first(3), g_span.first(3), ramp * options.lr_pose_rotation);
      pose_adam[2 * vi + 1].Step(pose.last(3), g_span.last(3), ramp * options.lr_pose_translation);
    }
    stats.update_seconds += ElapsedSeconds(t0);
    stats.steps = step + 1;
    if (options.progress) {
      OptimizeProgress p;
      p.step = step + 1;
      p.steps = options.steps;
      p.seconds = ElapsedSeconds(start);
      p.loss = epoch_loss / epoch_count;
      p.psnr = epoch_psnr / epoch_count;
      options.progress(p);
    }
  }
  for (size_t v = 0; v < views.size(); ++v) stats.poses.push_back(motion_of(v));
  stats.seconds = ElapsedSeconds(start);
  return stats;
}

}  // namespace pf
