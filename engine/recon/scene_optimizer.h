// Per-scene optimisation: every parameter of the reconstructed Gaussians
// refined against the CONTEXT frames by gradient descent through the
// rasterizer's backward pass (engine/render/raster_backward.h).
//
// Each step renders one context view (in a shuffled order, every view once
// per epoch), applies the view's exposure (an affine colour, 3x3 plus an
// offset, starting at identity and pulled back to it by
// OptimizeOptions::exposure_prior), takes the loss of photometric_loss.h
// (L1 + 0.2 D-SSIM) over the pixels off the ego vehicle, and moves the
// parameters with Adam (log-scales, rotations, opacity logits, colours and
// colour gradients; positions when OptimizeOptions::lr_mean > 0). Gaussians marked fixed keep their
// geometry (the far layer stays behind everything); they may still change colour and opacity.
// Actors' Gaussians move in their canonical frames, through the box poses. The exposures are the
// context views' (OptimizeStats::exposures), not the scene's: renders at new views use none
// (SCENE_FORMAT.md).
//
// With OptimizeOptions::pose each view's camera pose is corrected too (its
// gradient from the Gaussians' mean and rotation gradients,
// CameraMotionGradient); the corrections are the context views'
// (OptimizeStats::poses), renders at new views use the recorded poses.
//
// Not done: densification and pruning.
#ifndef POINTFORWARD_ENGINE_RECON_SCENE_OPTIMIZER_H_
#define POINTFORWARD_ENGINE_RECON_SCENE_OPTIMIZER_H_

#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include "absl/status/statusor.h"
#include "engine/recon/context_views.h"
#include "engine/render/gaussian_scene.h"
#include "engine/render/raster_backward.h"

namespace pf {

struct OptimizeProgress {
  int step = 0;  // Steps done.
  int steps = 0;
  double seconds = 0;
  double loss = 0;  // Mean loss of the last epoch's steps (or of those so far).
  double psnr = 0;  // Mean PSNR of the context views rendered in those steps.
};

struct OptimizeOptions {
  int steps = 0;           // Views rendered and stepped; 0: off.
  double max_seconds = 0;  // Also stop after this long; 0: no bound.
  double ssim_weight = 0.2;
  // Adam's step sizes: 0.3 times 3DGS's (from scratch it takes 30 K steps;
  // here a few hundred refine a fitted scene). Positions: lr_mean times the
  // cameras' spread (1.1 times the largest distance of a camera centre from
  // their mean, at least 1 m), decayed exponentially to lr_mean_final over
  // the steps; 0 by default, as moving them costs more than it gains on
  // real clips (docs/QUALITY.md: a reconstructed scene's colours are fitted
  // to the exact depth order of its overlapping discs).
  double lr_mean = 0, lr_mean_final = 0;
  double lr_log_scale = 1.5e-3;
  double lr_rotation = 3e-4;
  double lr_opacity = 1.5e-2;
  double lr_colour = 7.5e-4;  // Colour features and colour gradients.
  bool exposure = true;       // Fit an affine colour per view.
  double lr_exposure = 1e-3;
  double exposure_prior = 1e-2;  // Weight of |M - I|^2 + |b|^2 in the loss.
  // Correct each view's camera pose: a CameraMotion per view
  // (raster_backward.h), from zero, its rotation and translation stepped at
  // their own rates (radians and metres a step, before Adam's scaling).
  bool pose = false;
  double lr_pose_rotation = 2e-5, lr_pose_translation = 5e-4;
  // Every rate rises linearly from 1 / warmup_steps of its value over the
  // first warmup_steps steps (0: one epoch, a step per view), so Adam's
  // first steps, each a full rate whatever the gradient's size, do not
  // shake a scene that the colour fit already fitted.
  int warmup_steps = 0;
  uint32_t seed = 1;  // View order.
  // Called after every step.
  std::function<void(const OptimizeProgress&)> progress;
};

struct OptimizeStats {
  int steps = 0;
  double seconds = 0;
  double render_seconds = 0, backward_seconds = 0, update_seconds = 0;
  std::vector<float> loss;  // Per step.
  std::vector<float> psnr;  // Per step: the stepped view's PSNR before its step (exposed).
  double spread = 0;        // The position scale (m).
  // Per context view: the affine colour, row-major 3x4 ([M | b]).
  std::vector<std::array<float, 12>> exposures;
  // Per context view: its pose correction (OptimizeOptions::pose; zero
  // without), the view's camera moved by it.
  std::vector<CameraMotion> poses;
};

// Optimises `scene` against `views` (the scene's context views) for
// options.steps steps or options.max_seconds, whichever ends first.
// `fixed` ([N] or empty) marks Gaussians whose geometry stays. The scene
// must be renderable with feature colours (no SH); INVALID_ARGUMENT
// otherwise, or when `fixed` has the wrong size, a view is empty or has a
// rolling shutter.
absl::StatusOr<OptimizeStats> OptimizeScene(const std::vector<ContextView>& views,
                                            const std::vector<uint8_t>& fixed,
                                            const OptimizeOptions& options, GaussianScene* scene);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_SCENE_OPTIMIZER_H_
