// Per-scene optimisation (scene_optimizer.h).
#include "engine/recon/scene_optimizer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <random>
#include <span>

#include "absl/strings/str_cat.h"
#include "common/elapsed.h"
#include "common/geometry.h"
#include "common/thread_pool.h"
#include "engine/recon/image_metrics.h"
#include "engine/recon/photometric_loss.h"
#include "engine/render/raster_backward.h"
#include "engine/render/rasterizer.h"

namespace pf {
namespace {

// Adam (Kingma and Ba) over one parameter array, its step count its own.
class Adam {
 public:
  void Reset(size_t n) {
    m_.assign(n, 0.f);
    v_.assign(n, 0.f);
    t_ = 0;
  }
  // New entries start with zero moments.
  void Resize(size_t n) {
    m_.resize(n, 0.f);
    v_.resize(n, 0.f);
  }
  // Forgets the moments of entries [begin, begin + count).
  void Forget(size_t begin, size_t count) {
    std::fill_n(m_.begin() + static_cast<std::ptrdiff_t>(begin), count, 0.f);
    std::fill_n(v_.begin() + static_cast<std::ptrdiff_t>(begin), count, 0.f);
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

// Copies Gaussian `from` over Gaussian `to`.
void CopyGaussian(size_t from, size_t to, GaussianScene* scene) {
  auto copy = [&](auto& array, size_t width) {
    std::copy_n(array.begin() + static_cast<std::ptrdiff_t>(from * width), width,
                array.begin() + static_cast<std::ptrdiff_t>(to * width));
  };
  copy(scene->means, 3);
  copy(scene->rotations, 4);
  copy(scene->log_scales, 3);
  copy(scene->opacity_logits, 1);
  copy(scene->features, static_cast<size_t>(scene->num_channels));
  if (!scene->sh.empty()) copy(scene->sh, 3 * static_cast<size_t>(scene->sh_coeffs()));
  copy(scene->times, 1);
  copy(scene->lifespans, 1);
  copy(scene->owners, 1);
  if (scene->has_colour_gradients()) copy(scene->colour_gradients, 6);
}

// The Adam states of a scene's parameter arrays.
struct SceneAdam {
  Adam means, rotations, log_scales, opacities, colours, gradients;

  // Sized as the scene's arrays: from zero, or keeping what they hold.
  void Reset(const GaussianScene& scene) {
    Each(scene, [](Adam& adam, size_t n) { adam.Reset(n); });
  }
  void Resize(const GaussianScene& scene) {
    Each(scene, [](Adam& adam, size_t n) { adam.Resize(n); });
  }
  // A new Gaussian in slot i: its moments from zero.
  void Forget(size_t i, const GaussianScene& scene) {
    means.Forget(3 * i, 3);
    rotations.Forget(4 * i, 4);
    log_scales.Forget(3 * i, 3);
    opacities.Forget(i, 1);
    const size_t nc = static_cast<size_t>(scene.num_channels);
    colours.Forget(nc * i, nc);
    if (scene.has_colour_gradients()) gradients.Forget(6 * i, 6);
  }

 private:
  // f(adam, size of its scene array) for each array.
  template <typename F>
  void Each(const GaussianScene& scene, F f) {
    f(means, scene.means.size());
    f(rotations, scene.rotations.size());
    f(log_scales, scene.log_scales.size());
    f(opacities, scene.opacity_logits.size());
    f(colours, scene.features.size());
    f(gradients, scene.colour_gradients.size());
  }
};

// Adaptive density control (scene_optimizer.h): the gradients gathered
// since the last round, and the pruned entries.
class Densifier {
 public:
  Densifier(const OptimizeOptions& options, double spread, const std::vector<uint8_t>& fixed,
            size_t n)
      : options_(options),
        spread_(spread),
        fixed_(fixed.empty() ? std::vector<uint8_t>(n, 0) : fixed),
        frozen_(fixed_),
        pruned_(n, 0),
        gradient_sum_(n, 0.0),
        seen_(n, 0) {
    budget_ = options.max_gaussians > 0 ? options.max_gaussians : n + n / 2;
  }

  // Adds one view's screen-space centre gradients.
  void Gather(const ScreenGradients& screen, int width, int height) {
    const double hx = 0.5 * width, hy = 0.5 * height;
    for (size_t i = 0; i < screen.visible.size(); ++i) {
      if (!screen.visible[i]) continue;
      gradient_sum_[i] += std::hypot(hx * screen.centre[2 * i], hy * screen.centre[2 * i + 1]);
      ++seen_[i];
    }
  }

  // One round: prunes, then splits or clones; resizes `adam` with the scene.
  void Round(GaussianScene* scene, SceneAdam* adam, OptimizeStats* stats) {
    const size_t n = scene->size();
    const float prune_logit = LogitOfOpacity(options_.prune_opacity);
    std::vector<size_t> free_slots;
    size_t live = 0;
    for (size_t i = 0; i < n; ++i) {
      if (!pruned_[i] && scene->opacity_logits[i] < prune_logit) {
        pruned_[i] = frozen_[i] = 1;
        scene->opacity_logits[i] = kPrunedOpacityLogit;
        ++stats->pruned;
      }
      if (pruned_[i]) {
        // A fixed Gaussian's slot stays its own: the caller's mask names it.
        if (!fixed_[i]) free_slots.push_back(i);
      } else {
        ++live;
      }
    }
    // Candidates, the largest mean gradient first (ties by index).
    const double small = options_.percent_dense * spread_;
    const bool clone = options_.lr_mean > 0;
    std::vector<std::pair<double, size_t>> candidates;
    for (size_t i = 0; i < n; ++i) {
      if (frozen_[i] || seen_[i] == 0) continue;
      const double mean = gradient_sum_[i] / seen_[i];
      if (!(mean > options_.densify_gradient)) continue;
      if (!clone && LargestScale(*scene, i) <= small) continue;
      candidates.push_back({-mean, i});
    }
    std::sort(candidates.begin(), candidates.end());
    const size_t room = budget_ > live ? budget_ - live : 0;
    candidates.resize(std::min(candidates.size(), room));
    // Slots: pruned ones (lowest first), then new ones at the end.
    const size_t appended =
        candidates.size() > free_slots.size() ? candidates.size() - free_slots.size() : 0;
    if (appended > 0) {
      scene->Resize(n + appended);
      adam->Resize(*scene);
      for (std::vector<uint8_t>* v : {&fixed_, &frozen_, &pruned_}) v->resize(n + appended, 0);
      for (size_t j = n; j < n + appended; ++j) free_slots.push_back(j);
    }
    for (size_t c = 0; c < candidates.size(); ++c) {
      const size_t i = candidates[c].second, j = free_slots[c];
      CopyGaussian(i, j, scene);
      pruned_[j] = frozen_[j] = 0;
      adam->Forget(j, *scene);
      if (LargestScale(*scene, i) > small) {
        SplitGaussian(i, j, scene);
        adam->Forget(i, *scene);
        ++stats->split;
      } else {
        // Two at one place: each 1 - sqrt(1 - o), the pair's alpha at the
        // centre the parent's.
        const double half =
            std::max(1e-6, 1 - std::sqrt(1 - OpacityOfLogit(scene->opacity_logits[i])));
        scene->opacity_logits[i] = scene->opacity_logits[j] = LogitOfOpacity(half);
        adam->Forget(i, *scene);
        ++stats->cloned;
      }
    }
    const size_t size = scene->size();
    gradient_sum_.assign(size, 0.0);
    seen_.assign(size, 0);
  }

  // Geometry stays on fixed and pruned Gaussians; nothing moves on pruned ones.
  const std::vector<uint8_t>& frozen() const { return frozen_; }
  const std::vector<uint8_t>& pruned() const { return pruned_; }

  // Drops pruned entries at the end of the arrays (the others keep their
  // indices).
  void TrimEnd(GaussianScene* scene) {
    size_t n = scene->size();
    while (n > 0 && pruned_[n - 1]) --n;
    scene->Resize(n);
    pruned_.resize(n);
  }

 private:
  static double LargestScale(const GaussianScene& scene, size_t i) {
    const float* s = &scene.log_scales[3 * i];
    return std::exp(std::max({s[0], s[1], s[2]}));
  }

  const OptimizeOptions& options_;
  double spread_;
  std::vector<uint8_t> fixed_, frozen_, pruned_;
  std::vector<double> gradient_sum_;
  std::vector<int> seen_;
  size_t budget_ = 0;
};

}  // namespace

void SplitGaussian(size_t i, size_t j, GaussianScene* scene) {
  // Offset and width along the axis (of the std-dev) and the opacity rule,
  // fitted to the parent's alpha under compositing: the largest difference
  // is 5-7 % of its opacity up to 0.7, 14 % at 0.95 (before the 1/255
  // cut-off, which takes more of a faint pair).
  constexpr double kSplitOffset = 0.5, kNarrow = 0.75, kOpacityPower = 0.6;
  float* s = &scene->log_scales[3 * i];
  const int axis = static_cast<int>(std::max_element(s, s + 3) - s);
  const double sigma = std::exp(double{s[axis]});
  const float* r = &scene->rotations[4 * i];
  const Mat3 rotation = ToMatrix(Quat{r[0], r[1], r[2], r[3]});
  Vec3 e{0, 0, 0};
  (axis == 0 ? e.x : axis == 1 ? e.y : e.z) = kSplitOffset * sigma;
  const Vec3 d = rotation * e;
  const double offset[3] = {d.x, d.y, d.z};
  const double o = OpacityOfLogit(scene->opacity_logits[i]);
  const float logit = LogitOfOpacity(std::clamp(1 - std::pow(1 - o, kOpacityPower), 1e-6, 0.99));
  for (const auto& [k, sign] : {std::pair{i, 1.0}, std::pair{j, -1.0}}) {
    for (int a = 0; a < 3; ++a) scene->means[3 * k + a] += static_cast<float>(sign * offset[a]);
    scene->log_scales[3 * k + axis] += static_cast<float>(std::log(kNarrow));
    scene->opacity_logits[k] = logit;
    if (scene->has_colour_gradients() && axis < 2) {
      // Channel c is features[c] + g_cu u + g_cv v, (u, v) in std-devs along
      // the first two axes.
      for (int c = 0; c < 3; ++c) {
        float& g = scene->colour_gradients[6 * k + 2 * c + axis];
        scene->features[k * scene->num_channels + c] += static_cast<float>(sign * kSplitOffset) * g;
        g *= static_cast<float>(kNarrow);
      }
    }
  }
}

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

  SceneAdam adam;
  adam.Reset(*scene);
  const bool densify = options.densify;
  const int densify_interval =
      options.densify_interval > 0 ? options.densify_interval : 2 * static_cast<int>(views.size());
  // Sized only when on (it copies `fixed`).
  Densifier densifier(options, stats.spread, densify ? fixed : std::vector<uint8_t>{},
                      densify ? n : 0);
  // Whose geometry stays, and what does not move at all.
  const std::vector<uint8_t>* keep = fixed.empty() ? nullptr : &fixed;
  const std::vector<uint8_t>* still = nullptr;

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
    if (options.max_seconds > 0 && SecondsSince(start) >= options.max_seconds) break;
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
    stats.render_seconds += SecondsSince(t0);
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
    // Densification's rounds run up to densify_until of the steps or of the
    // seconds, whichever comes first.
    const double done =
        std::max(double(step) / options.steps,
                 options.max_seconds > 0 ? SecondsSince(start) / options.max_seconds : 0.0);
    const bool gather = densify && done < options.densify_until;
    t0 = std::chrono::steady_clock::now();
    ScreenGradients screen;
    absl::StatusOr<SceneGradients> g =
        RenderBackward(*scene, camera, view.timestamp_us, {}, grads, render_options, nullptr,
                       gather ? &screen : nullptr);
    if (!g.ok()) return g.status();
    if (gather) densifier.Gather(screen, view.width(), view.height());
    CameraMotion g_pose{};
    if (options.pose) {
      // From the scene as rendered, before its own step.
      absl::StatusOr<CameraMotion> motion =
          CameraMotionGradient(*scene, camera, view.timestamp_us, {}, *g, render_options);
      if (!motion.ok()) return motion.status();
      g_pose = *motion;
    }
    stats.backward_seconds += SecondsSince(t0);

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
    adam.means.Step(scene->means, g->means, ramp * lr_mean, keep, 3);
    adam.rotations.Step(scene->rotations, g->rotations, ramp * options.lr_rotation, keep, 4);
    adam.log_scales.Step(scene->log_scales, g->log_scales, ramp * options.lr_log_scale, keep, 3);
    adam.opacities.Step(scene->opacity_logits, g->opacity_logits, ramp * options.lr_opacity, still);
    adam.colours.Step(scene->features, g->features, ramp * options.lr_colour, still,
                      scene->num_channels);
    if (scene->has_colour_gradients()) {
      adam.gradients.Step(scene->colour_gradients, g->colour_gradients, ramp * options.lr_colour,
                          still, 6);
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
    if (gather && (step + 1) % densify_interval == 0) {
      densifier.Round(scene, &adam, &stats);
      keep = &densifier.frozen();
      still = &densifier.pruned();
    }
    stats.update_seconds += SecondsSince(t0);
    stats.steps = step + 1;
    if (options.progress) {
      OptimizeProgress p;
      p.step = step + 1;
      p.steps = options.steps;
      p.seconds = SecondsSince(start);
      p.loss = epoch_loss / epoch_count;
      p.psnr = epoch_psnr / epoch_count;
      options.progress(p);
    }
  }
  for (size_t v = 0; v < views.size(); ++v) stats.poses.push_back(motion_of(v));
  if (densify) {
    densifier.TrimEnd(scene);
    stats.pruned_entries = densifier.pruned();
  }
  stats.seconds = SecondsSince(start);
  return stats;
}

}  // namespace pf
