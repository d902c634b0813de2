// Reconstruction: a clip's CONTEXT frames to a GaussianScene, by the model
// the options name (recon_model.h: the analytic and pixel-aligned models,
// each a folder under models/) from the stages of pipeline.h (depth,
// lifting, scene graph, sparse sampling, fusion, decoding, the colour fit),
// with the time of each stage.
//
//   ASSIGN_OR_RETURN(LoadedClip loaded, LoadClip(path));
//   ASSIGN_OR_RETURN(ReconResult result, Reconstruct(loaded, {}));
#ifndef POINTFORWARD_ENGINE_RECON_RECONSTRUCTION_H_
#define POINTFORWARD_ENGINE_RECON_RECONSTRUCTION_H_

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "engine/clip/clip_io.h"
#include "engine/recon/colour_refinement.h"
#include "engine/recon/compute_device.h"
#include "engine/recon/context_views.h"
#include "engine/recon/fusion.h"
#include "engine/recon/gaussian_decoder.h"
#include "engine/recon/recon_stages.h"
#include "engine/recon/scene_optimizer.h"
#include "engine/recon/sparse_sampling.h"
#include "engine/recon/view_depth.h"
#include "engine/render/gaussian_scene.h"

namespace pf {

// The render blur of a reconstructed scene when none is given (pixels):
// kMeasuredDepthRenderBlur where the rig moves and depth is measured (LiDAR,
// sparse maps or none), else none. A scene from measured depth draws detail a
// little off where a new pose sees it: the real clips of moving rigs are
// closer to their TARGET frames blurred by 0.5 px. Exact depth is not, nor a
// rig that stands still (every view StillCameraViews), whose renders are
// wanted at the poses it was seen from (docs/QUALITY.md, "Render blur").
inline constexpr float kMeasuredDepthRenderBlur = 0.5f;
inline float DefaultRenderBlur(bool all_views_dense_depth, bool rig_stands_still) {
  return all_views_dense_depth || rig_stands_still ? 0.f : kMeasuredDepthRenderBlur;
}
// The growth of the render blur away from the CONTEXT cameras when none is
// given (GaussianScene::render_blur_growth, mrad/m): kMeasuredDepthRenderBlurGrowth
// where DefaultRenderBlur is over 0, else none. The further a pose is from
// the poses the scene was seen from, the more of its detail is off: 2 mrad/m
// is 2.7 px for DGP scene_02's frames 1.27 m past their CONTEXT poses, and
// leaves PandaSet's frames between CONTEXT frames (0.1-0.24 m) at 0.5 px
// (docs/QUALITY.md, "Render blur").
inline constexpr float kMeasuredDepthRenderBlurGrowth = 2.f;
inline float DefaultRenderBlurGrowth(bool all_views_dense_depth, bool rig_stands_still) {
  return all_views_dense_depth || rig_stands_still ? 0.f : kMeasuredDepthRenderBlurGrowth;
}

struct ReconOptions {
  std::string model = "analytic";  // A name of recon_model.h's registry.
  // N_s and N_d; <= 0 means the paper's 100K / 10K scaled to the first
  // context image's size relative to 768 x 576 (N_s by ScaledStaticBudget,
  // N_d by ScaledBudget; sparse_sampling.h).
  int64_t static_per_view = 0;
  int64_t dynamic_per_instance = 0;
  // N_s of the views of a camera that stands still (StillCameraViews,
  // sparse_sampling.h) is static_per_view times this, in [1, 16]; 1: the same.
  double still_rig_density = 8.0;
  FusionOptions fusion;
  DecoderOptions decoder;
  // iterations = 0: no refinement. The fit's memory bound is its max_pairs
  // raised to half of what the machine has free when the fit starts
  // (RefinementOptions::available_memory_share).
  RefinementOptions refinement = [] {
    RefinementOptions defaults;
    defaults.available_memory_share = 0.5;
    return defaults;
  }();
  // Whether the colour fit gives each Gaussian a colour gradient
  // (GaussianScene::colour_gradients); unset: the model's default, on for
  // analytic, off for pixel-aligned (one Gaussian per pixel has no room
  // for a gradient inside its pixel).
  // refinement.colour_gradients is overwritten with the result.
  std::optional<bool> colour_gradients;
  CompletionOptions completion;
  int far_stride = 3;
  bool skip_covered = true;
  bool fill_static_budget = true;  // SamplingOptions::fill_static_budget.
  int hidden_band_px = 256;        // SamplingOptions::behind_band_px (0: none).
  // Find each camera's ego body after the depth stage, lift none of it, and
  // keep it as the scene's ego layer (ego_body.h).
  bool ego_layer = true;
  // The scene's render blur (GaussianScene::render_blur), pixels in
  // [0, kMaxRenderBlur]; 0: none; unset: DefaultRenderBlur().
  std::optional<float> render_blur;
  // The growth of the render blur away from the CONTEXT views
  // (GaussianScene::render_blur_growth), mrad/m in [0, kMaxRenderBlurGrowth];
  // unset: DefaultRenderBlurGrowth() without render_blur, 0 with it.
  std::optional<float> render_blur_growth;
  bool allow_outside_paths = false;
  // The working colour encoding: the context images are decoded to it, and
  // the scene's colours are in it (GaussianScene::colour_encoding). Renders
  // convert to linear for EXR and to sRGB for PNG either way.
  ColourEncoding colour_encoding = ColourEncoding::kSrgb;
  // Where fusion's tensor work runs (compute_device.h); without LibTorch in
  // the build only the CPU, with the C++ kernel. A cuda device also takes
  // the colour fit's solve where the build has CUDA (cuda_colour_fit.h).
  ComputeDevice device;
  // Per-scene optimisation after the colour fit (scene_optimizer.h; steps 0:
  // none, the default). Its progress callback is set by the pipeline.
  OptimizeOptions optimize;
  // Called after each stage and with notes (recon_stages.h); may be null.
  ReconProgressFn progress;
};

struct ReconStats {
  int views = 0;
  int instances = 0;
  int64_t static_per_view = 0;       // N_s used.
  int64_t dynamic_per_instance = 0;  // N_d used.
  int64_t static_gaussians = 0;      // Owner 0, far layer included.
  int64_t far_gaussians = 0;
  int64_t dynamic_gaussians = 0;
  // Views whose camera stands still, sampled at still_rig_density x N_s.
  int still_rig_views = 0;
  int lidar_views = 0;          // Views whose depth came from LiDAR.
  int sparse_map_views = 0;     // Views whose sparse depth map was completed (view_depth.h).
  int64_t ground_pixels = 0;    // Completed views' pixels set by the ground fill (view_depth.h).
  int64_t facade_pixels = 0;    // Completed views' pixels set by facades (facade_depth.h).
  int64_t stereo_pixels = 0;    // Completed views' pixels set by the plane sweep (stereo_depth.h).
  int64_t upward_pixels = 0;    // Set by the depth below continued up (facade_depth.h).
  int64_t enclosed_pixels = 0;  // Set by the gaps enclosed by known depth (depth_stage.h).
  int views_without_depth = 0;  // No depth map, no LiDAR point: all far layer.
  // Of `instances`, those whose boxes do not move (scene_graph.h IsStillTrack):
  // reconstructed as static, their Gaussians theirs after decoding.
  int still_instances = 0;
  int rolling_shutter_views = 0;  // Frames with a rolling shutter, lifted line by line.
  float low_pass = 0;     // The scene's screen-space low-pass, pixels^2 (DecoderOptions::low_pass).
  float render_blur = 0;  // The scene's render blur, pixels (ReconOptions::render_blur).
  float render_blur_growth = 0;  // Its growth, mrad/m (ReconOptions::render_blur_growth).
  // Each ego layer's camera and the share of its pixels on the body.
  std::vector<std::pair<std::string, double>> ego_body;
  // The scene's colours carry gradients (the fit ran with them; a fit over
  // the memory bound with them falls back to flat colours).
  bool colour_gradients = false;
  // The colour fit's pixels: 1 in colour_fit_pixel_stride of each view (1:
  // every pixel; 0: no fit ran).
  int colour_fit_pixel_stride = 0;
  // The memory bound the colour fit's weights ran under, bytes
  // (RefinementStats::max_pairs; 0: no fit ran).
  int64_t colour_fit_bound_bytes = 0;
  // Where the colour fit's solve ran ("cpu" or "cuda:N"; empty: no fit), and
  // its seconds recording the weights and solving (RefinementStats).
  std::string colour_fit_device;
  double colour_fit_record_seconds = 0;
  double colour_fit_solve_seconds = 0;
  double colour_fit_upload_seconds = 0;  // Of the solve: the weights to the GPU.
  // The optimisation (scene_optimizer.h): steps taken (0: none ran), its
  // loss per step, and the context views' PSNR per step.
  int optimize_steps = 0;
  std::vector<float> optimize_loss;
  std::vector<float> optimize_psnr;
  // With OptimizeOptions::pose: each context view's pose correction.
  struct PoseCorrection {
    int frame_index = -1;  // Into clip.frames.
    std::string camera_id;
    std::array<double, 6> motion{};  // CameraMotion (raster_backward.h): radians, then metres.
  };
  std::vector<PoseCorrection> optimize_poses;
  // With OptimizeOptions::densify: Gaussians split, cloned and pruned (the
  // counts above are then the optimised scene's, pruned entries left out).
  bool optimize_densify = false;
  int64_t optimize_split = 0, optimize_cloned = 0, optimize_pruned = 0;
  std::vector<std::pair<std::string, double>> stage_seconds;  // In order.
  double total_seconds = 0;
};

struct ReconResult {
  GaussianScene scene;
  ReconStats stats;
};

// Everything a reconstruction reads, decoded.
struct ReconInputs {
  std::vector<ContextView> views;
  std::vector<LidarSweepData> sweeps;
  std::vector<InstanceTrack> tracks;  // Only tracks with boxes.
  int64_t time_origin_us = 0;
  ColourEncoding colour_encoding = ColourEncoding::kSrgb;  // Of the views' rgb.
};

// Sets inputs->tracks to the tracks of `clip` that have boxes and
// inputs->time_origin_us to its time origin (TracksFromClip,
// ClipTimeOrigin): what a reconstruction takes of a clip beside its frames.
absl::Status SetTracksFromClip(const pointforward::v1::Clip& clip, ReconInputs* inputs);

// Loads the CONTEXT frames (in options.colour_encoding), LiDAR sweeps and
// tracks of `loaded` (options.allow_outside_paths says which paths may be
// read). INVALID_ARGUMENT when the clip has no CONTEXT frame; errors of the
// loaders otherwise.
absl::StatusOr<ReconInputs> LoadReconInputs(const LoadedClip& loaded, const ReconOptions& options);

// Reconstructs decoded inputs with the model options.model names.
// INVALID_ARGUMENT for no views or an unknown model; FAILED_PRECONDITION for
// a device this process cannot use.
absl::StatusOr<ReconResult> ReconstructInputs(ReconInputs inputs, const ReconOptions& options);

// Returns whether the colour fit of `options` gives the Gaussians colour
// gradients (ReconOptions::colour_gradients, else the model's default).
bool ColourGradientsFor(const ReconOptions& options);

// LoadReconInputs then ReconstructInputs; the load is the first stage.
absl::StatusOr<ReconResult> Reconstruct(const LoadedClip& loaded, const ReconOptions& options);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_RECONSTRUCTION_H_
