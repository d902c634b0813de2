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
// With OptimizeOptions::densify the scene grows where the
// views disagree with it and sheds what they no longer see, as 3DGS's
// adaptive density control: every densify_interval steps, each Gaussian
// whose screen-space centre gradient, averaged over the views that saw it
// since the last time, passes densify_gradient is split in two (or, when
// small and positions move, cloned), the largest gradients first, up to
// max_gaussians; Gaussians fainter than prune_opacity are pruned. A pruned
// Gaussian stays in the arrays as an invisible entry (opacity logit
// kPrunedOpacityLogit, never stepped) unless it is at their end, so that
// every other Gaussian keeps its index and with it its place in the depth
// order band (GaussianScene::order_band); new Gaussians take pruned slots
// first, then the end of the arrays.
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
  // Densification and pruning (above), every densify_interval steps (0:
  // two epochs, two steps per view).
  // densify_gradient is in 3DGS's units (per normalised device coordinate:
  // a pixel's gradient times half the view's width or height). It stops after
  // densify_until of the run (of its steps, or of max_seconds when that comes
  // first). A Gaussian is split when its largest scale passes percent_dense
  // times the cameras' spread, else cloned, and only cloned when positions
  // move (lr_mean > 0): a clone at the same place adds nothing. A split
  // keeps the render close (not 3DGS's random draw, whose change a few
  // hundred steps do not undo; SplitGaussian). max_gaussians 0: 1.5 times the
  // scene's Gaussians at the start.
  bool densify = false;
  int densify_interval = 0;
  double densify_until = 0.6;
  double densify_gradient = 2e-4;
  double percent_dense = 0.01;
  double prune_opacity = 0.005;
  size_t max_gaussians = 0;
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
  // Densification: Gaussians split, cloned and pruned over the run; the
  // scene's arrays at the end, and [N] 1 on the pruned entries among them.
  int64_t split = 0, cloned = 0, pruned = 0;
  std::vector<uint8_t> pruned_entries;
};

// Splits Gaussian i of `scene` into itself and j, which must hold a copy of
// it: the two move half its std-dev either way along its longest axis,
// narrow there to 0.75 of it, take the colour its colour gradients give at
// their new centres, and the opacity 1 - (1 - o)^0.6, so that the pair
// composites to about its alpha.
void SplitGaussian(size_t i, size_t j, GaussianScene* scene);

// The opacity logit of a pruned Gaussian (far below the 1/255 cut-off).
inline constexpr float kPrunedOpacityLogit = -40.f;

// Optimises `scene` against `views` (the scene's context views) for
// options.steps steps or options.max_seconds, whichever ends first.
// `fixed` ([N] or empty) marks Gaussians whose geometry stays (they are
// never split or cloned; they may be pruned, and their slots then stay
// theirs, so `fixed` still names the first N entries). The scene must be renderable with feature
// colours (no SH); INVALID_ARGUMENT otherwise, or when `fixed` has the wrong size, a view is empty
// or has a rolling shutter.
absl::StatusOr<OptimizeStats> OptimizeScene(const std::vector<ContextView>& views,
                                            const std::vector<uint8_t>& fixed,
                                            const OptimizeOptions& options, GaussianScene* scene);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_SCENE_OPTIMIZER_H_
