// The reconstruction's stages: see pipeline.h.
#include "engine/recon/pipeline.h"

// The generated protobuf header first (see image_io.h).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "common/geometry.h"
#include "common/status_macros.h"
#include "engine/recon/cuda_colour_fit.h"
#include "engine/recon/lidar_intensity.h"
#include "engine/recon/scene_graph.h"
#include "engine/recon/sparse_sampling.h"
#include "engine/render/render_blur.h"
#include "pointforward/v1/clip.pb.h"
#if PF_HAVE_TORCH
#include "engine/recon/tensor_fusion.h"
#endif

namespace pf {
namespace {

double Now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// "; pose corrections ..." for the done line, when the poses were corrected.
std::string PoseSummary(const OptimizeStats& stats) {
  double turn = 0, shift = 0, turn_max = 0, shift_max = 0;
  for (const CameraMotion& m : stats.poses) {
    const double w = Norm(Vec3{m[0], m[1], m[2]}), t = Norm(Vec3{m[3], m[4], m[5]});
    turn += w;
    shift += t;
    turn_max = std::max(turn_max, w);
    shift_max = std::max(shift_max, t);
  }
  if (shift_max == 0 && turn_max == 0) return "";
  const double views = static_cast<double>(stats.poses.size());
  return absl::StrCat("; pose corrections: mean ",
                      absl::SixDigits(turn / views * kDegreesPerRadian), " deg and ",
                      absl::SixDigits(shift / views * 100), " cm, at most ",
                      absl::SixDigits(turn_max * kDegreesPerRadian), " deg and ",
                      absl::SixDigits(shift_max * 100), " cm");
}

// ReconStats' static, far and dynamic Gaussians of a scene with these
// owners; `far` covers a prefix of them (entries past it are not far),
// entries set in `left_out` ([N] or empty) are not counted.
void CountGaussians(const std::vector<uint32_t>& owners, const std::vector<uint8_t>& far,
                    const std::vector<uint8_t>& left_out, ReconStats* stats) {
  stats->static_gaussians = stats->far_gaussians = stats->dynamic_gaussians = 0;
  for (size_t i = 0; i < owners.size(); ++i) {
    if (!left_out.empty() && left_out[i]) continue;
    if (owners[i] == 0) {
      ++stats->static_gaussians;
      stats->far_gaussians += i < far.size() && far[i];
    } else {
      ++stats->dynamic_gaussians;
    }
  }
}

std::string DensifySummary(const OptimizeOptions& options, const OptimizeStats& stats,
                           const ReconStats& recon) {
  if (!options.densify) return "";
  return absl::StrCat("; densified: ", stats.split, " split, ", stats.cloned, " cloned, ",
                      stats.pruned, " pruned, ", recon.static_gaussians + recon.dynamic_gaussians,
                      " Gaussians");
}

// Each context view's camera id and time, as the time fade takes them.
struct ViewCamerasAndTimes {
  std::vector<std::string> cameras;
  std::vector<int64_t> times_us;
};
ViewCamerasAndTimes CamerasAndTimes(const std::vector<ContextView>& views) {
  ViewCamerasAndTimes out;
  for (const ContextView& view : views) {
    out.cameras.push_back(view.camera_id);
    out.times_us.push_back(view.timestamp_us);
  }
  return out;
}

}  // namespace

Pipeline::Pipeline(ReconInputs inputs, const ReconOptions& options)
    : inputs_(std::move(inputs)), options_(options) {
  start_ = last_ = Now();
  const std::vector<ContextView>& views = inputs_.views;
  ReconStats& stats = result_.stats;
  stats.views = static_cast<int>(views.size());
  stats.instances = static_cast<int>(inputs_.tracks.size());
  // Tracks that do not move are reconstructed as static points and get their
  // Gaussians back after decoding (scene_graph.h IsStillTrack).
  std::vector<InstanceTrack> moving;
  for (InstanceTrack& track : inputs_.tracks) {
    (IsStillTrack(track) ? still_tracks_ : moving).push_back(std::move(track));
  }
  inputs_.tracks = std::move(moving);
  stats.still_instances = static_cast<int>(still_tracks_.size());
  const int width = views.empty() ? 0 : views[0].width();
  const int height = views.empty() ? 0 : views[0].height();
  stats.static_per_view = options.static_per_view > 0
                              ? options.static_per_view
                              : ScaledStaticBudget(kDefaultStaticPerView, width, height);
  stats.dynamic_per_instance = options.dynamic_per_instance > 0
                                   ? options.dynamic_per_instance
                                   : ScaledBudget(kDefaultDynamicPerInstance, width, height);
}

void Pipeline::Done(ReconStage stage, std::string detail) {
  const double now = Now();
  result_.stats.stage_seconds.emplace_back(ReconStageName(stage), now - last_);
  if (options_.progress) {
    ReconProgress done;
    done.kind = ReconProgress::Kind::kStageDone;
    done.stage = stage;
    done.seconds = now - last_;
    done.detail = std::move(detail);
    options_.progress(done);
  }
  last_ = now;
}

absl::Status Pipeline::Depth() {
  const std::vector<ContextView>& views = inputs_.views;
  if (views.empty()) return absl::InvalidArgumentError("no context views");
  ReconStats& stats = result_.stats;
  const size_t num_views = views.size();
  depth_stage_ = MeasureViewDepths(views, inputs_.sweeps, inputs_.tracks, options_.completion);
  stats.lidar_views = depth_stage_.lidar_views;
  stats.sparse_map_views = depth_stage_.sparse_map_views;
  stats.ground_pixels = depth_stage_.ground_pixels;
  stats.facade_pixels = depth_stage_.facade_pixels;
  stats.stereo_pixels = depth_stage_.stereo_pixels;
  stats.upward_pixels = depth_stage_.upward_pixels;
  stats.enclosed_pixels = depth_stage_.enclosed_pixels;
  depths_ = AddFarLayer(views, &depth_stage_);
  stats.views_without_depth = depth_stage_.views_without_depth;
  stats.rolling_shutter_views =
      static_cast<int>(std::count_if(views.begin(), views.end(), [](const ContextView& view) {
        return view.rolling_shutter.has_value();
      }));
  std::string ego;
  if (options_.ego_layer) {
    ego_layers_ = DetectEgoBodies(views, depths_, inputs_.tracks);
    SetEgoMasks(ego_layers_, &inputs_.views);
    for (const EgoLayer& layer : ego_layers_) {
      stats.ego_body.emplace_back(layer.camera_id, layer.body_share());
      absl::StrAppend(&ego, ego.empty() ? "" : ", ", layer.camera_id, " ",
                      absl::SixDigits(100.0 * stats.ego_body.back().second), " %");
    }
    ego = ego.empty() ? ", no ego body found" : absl::StrCat(", ego body: ", ego);
  }
  const std::string sparse_maps =
      depth_stage_.sparse_map_views > 0
          ? absl::StrCat(", ", depth_stage_.sparse_map_views, " from sparse depth maps, completed")
          : "";
  Done(ReconStage::kDepth,
       absl::StrCat(" (", stats.lidar_views, " of ", num_views, " views from LiDAR", sparse_maps,
                    ", ", stats.ground_pixels, " pixels from the ground plane, ",
                    stats.facade_pixels, " from facades, ", stats.stereo_pixels, " from stereo, ",
                    stats.upward_pixels, " from the depth below continued up, ",
                    stats.enclosed_pixels, " in gaps enclosed by known depth, far layer radius ",
                    depth_stage_.far.radius, " m", ego,
                    stats.rolling_shutter_views > 0
                        ? absl::StrCat(", ", stats.rolling_shutter_views,
                                       " with a rolling shutter, lifted line by line")
                        : "",
                    ")"));
  if (stats.views_without_depth > 0) {
    ReportNote(options_.progress, ReconStage::kDepth,
               absl::StrCat("warning: ", stats.views_without_depth, " of ", num_views,
                            " views have no depth map and no LiDAR point; all their pixels "
                            "are on the far layer"));
  }
  return absl::OkStatus();
}

void Pipeline::Lift() {
  const size_t num_views = inputs_.views.size();
  lifted_.resize(num_views);
  for (size_t v = 0; v < num_views; ++v) lifted_[v] = LiftView(inputs_.views[v], depths_[v]);
  Done(ReconStage::kLift);
}

void Pipeline::SceneGraph() {
  const std::vector<ContextView>& views = inputs_.views;
  const size_t num_views = views.size();
  owners_.resize(num_views);
  masks_.resize(num_views);
  for (size_t v = 0; v < num_views; ++v) {
    owners_[v] = PixelOwners(lifted_[v], depths_[v], inputs_.tracks, views[v].timestamp_us,
                             views[v].rolling_shutter);
    masks_[v] = DynamicMask(views[v].camera, views[v].lines().MiddleWorldFromCamera(),
                            inputs_.tracks, views[v].middle_time_us(), kMembershipMargin.grow);
  }
  Done(ReconStage::kSceneGraph);
}

void Pipeline::Sample(bool dense) {
  const size_t num_views = inputs_.views.size();
  SamplingOptions sampling;
  sampling.static_per_view = result_.stats.static_per_view;
  sampling.dynamic_per_instance = result_.stats.dynamic_per_instance;
  sampling.far_stride = options_.far_stride;
  sampling.skip_covered = options_.skip_covered;
  sampling.fill_static_budget = options_.fill_static_budget;
  sampling.behind_band_px = options_.hidden_band_px;
  sampling.dense = dense;
  // A point is left to a finer view only while that view's discs are not
  // faded at its time: within the fade's width, sigma + 1 seconds.
  const ViewCamerasAndTimes views = CamerasAndTimes(inputs_.views);
  if (const std::optional<double> sigma =
          FadeSigma(views.cameras, views.times_us, options_.decoder.fade_frames)) {
    sampling.finer_view_seconds = *sigma + 1.0;
  }
  const std::vector<bool> still = StillCameraViews(inputs_.views);
  std::vector<SamplingView> sampling_views(num_views);
  int still_views = 0;
  for (size_t v = 0; v < num_views; ++v) {
    sampling_views[v] = {&inputs_.views[v], &depths_[v], &lifted_[v], &owners_[v]};
    if (still[v] && !dense && options_.still_rig_density != 1.0) {
      sampling_views[v].static_density = options_.still_rig_density;
      ++still_views;
    }
  }
  result_.stats.still_rig_views = still_views;
  queries_ = SampleQueries(sampling_views, inputs_.tracks, sampling);
  lifted_.clear();
  std::string still_note;
  if (still_views > 0) {
    still_note = absl::StrCat("; ", still_views, " views of cameras that stand still at ",
                              options_.still_rig_density, " x N_s");
  }
  Done(ReconStage::kSample, absl::StrCat(" (", queries_.size(), " queries", still_note, ")"));
}

absl::Status Pipeline::Fuse() {
  const size_t num_views = inputs_.views.size();
  std::vector<FusionView> fusion_views(num_views);
  for (size_t v = 0; v < num_views; ++v) {
    fusion_views[v] = {&inputs_.views[v], &depths_[v], &masks_[v]};
  }
#if PF_HAVE_TORCH
  ASSIGN_OR_RETURN(fused_, FuseQueriesOnDevice(queries_, fusion_views, inputs_.tracks,
                                               options_.fusion, options_.device));
  Done(ReconStage::kFuse, absl::StrCat(" (LibTorch on ", options_.device.ToString(), ")"));
#else
  fused_ = FuseQueries(queries_, fusion_views, inputs_.tracks, options_.fusion);
  Done(ReconStage::kFuse, " (C++ on cpu)");
#endif
  return absl::OkStatus();
}

void Pipeline::KeepQueriesUnfused() {
  fused_ = UnfusedQueries(queries_);
  Done(ReconStage::kFuse, " (none: one Gaussian per pixel)");
}

void Pipeline::Decode() {
  const ViewCamerasAndTimes views = CamerasAndTimes(inputs_.views);
  ReconStats& stats = result_.stats;
  DecoderOptions decoder = options_.decoder;
  const bool all_views_dense_depth =
      stats.lidar_views == 0 && stats.sparse_map_views == 0 && stats.views_without_depth == 0;
  if (!decoder.low_pass) decoder.low_pass = DefaultLowPass(all_views_dense_depth);
  stats.low_pass = *decoder.low_pass;
  const std::vector<bool> still_views = StillCameraViews(inputs_.views);
  const bool rig_stands_still =
      !still_views.empty() &&
      std::all_of(still_views.begin(), still_views.end(), [](bool s) { return s; });
  stats.render_blur =
      options_.render_blur.value_or(DefaultRenderBlur(all_views_dense_depth, rig_stands_still));
  // A blur given alone is the blur of every render.
  stats.render_blur_growth = options_.render_blur_growth.value_or(
      options_.render_blur ? 0.f
                           : DefaultRenderBlurGrowth(all_views_dense_depth, rig_stands_still));
  if (stats.render_blur_growth > 0.f) {
    for (const ContextView& view : inputs_.views) {
      blur_anchors_.push_back(BlurAnchorOf(view.world_from_camera));
    }
  }
  result_.scene = DecodeGaussians(queries_, fused_, views.times_us, inputs_.time_origin_us,
                                  inputs_.tracks, decoder);
  FadeStaticGaussians(views.cameras, views.times_us, queries_.owners, queries_.far,
                      decoder.fade_frames, &result_.scene);
  result_.scene.colour_encoding = inputs_.colour_encoding;
  CountGaussians(queries_.owners, queries_.far, {}, &stats);
  std::string still;
  if (!still_tracks_.empty()) {
    int64_t adopted = 0;
    for (const int64_t n : AdoptStillInstances(still_tracks_, queries_.far, &result_.scene)) {
      adopted += n;
    }
    still = absl::StrCat("; ", still_tracks_.size(), " instances that do not move decoded as ",
                         "static, then given their ", adopted, " Gaussians");
  }
  // The scene holds what the stages after this one need: the queries, their
  // fusion and the views' depths, owners and masks are freed, so the colour
  // fit's weights can take their memory.
  far_ = std::move(queries_.far);
  queries_ = QuerySet();
  fused_ = FusedQueries();
  std::vector<ViewDepth>().swap(depths_);
  std::vector<std::vector<uint32_t>>().swap(owners_);
  std::vector<std::vector<uint8_t>>().swap(masks_);
  // LiDAR intensity from the sweeps the depth stage would take (nearest each
  // CONTEXT view), so those of TARGET times stay out.
  std::vector<const LidarSweepData*> sweeps;
  std::vector<bool> taken(inputs_.sweeps.size(), false);
  for (const ContextView& view : inputs_.views) {
    const int s = NearestSweep(inputs_.sweeps, view.timestamp_us);
    if (s >= 0 && !taken[s]) {
      taken[s] = true;
      sweeps.push_back(&inputs_.sweeps[s]);
    }
  }
  std::string intensity = "no LiDAR: no intensity";
  if (!sweeps.empty()) {
    const LidarIntensityStats fused = FuseLidarIntensity(sweeps, kIntensityChannel, &result_.scene);
    result_.scene.lidar_intensity_channel = kIntensityChannel;
    intensity =
        absl::StrCat("LiDAR intensity from ", fused.points, " returns of ", sweeps.size(),
                     " sweeps: ", fused.assigned, " of ", result_.scene.size(), " Gaussians");
  }
  Done(ReconStage::kDecode, absl::StrCat(" (", intensity, still, ")"));
}

absl::Status Pipeline::FitColours() {
  if (options_.refinement.iterations <= 0) return absl::OkStatus();
  RefinementOptions refinement = options_.refinement;
  refinement.colour_gradients = ColourGradientsFor(options_);
  // The solve goes where fusion went when this build has the GPU colour fit;
  // a GPU that cannot take it (no room, too old, a failed kernel) leaves it to
  // the CPU: the scene is only written once the GPU's solve is done.
  std::string device_note;
  if (options_.device.kind == ComputeDevice::Kind::kCuda) {
    if (HaveCudaColourFit()) {
      refinement.device = options_.device;
    } else {
      device_note = "; solved on the cpu: this build has no CUDA kernels";
    }
  }
  absl::StatusOr<RefinementStats> fitted = RefineColours(inputs_.views, refinement, &result_.scene);
  if (!fitted.ok() && refinement.device.kind == ComputeDevice::Kind::kCuda) {
    device_note = absl::StrCat("; solved on the cpu: ", fitted.status().message());
    refinement.device = ComputeDevice{};
    fitted = RefineColours(inputs_.views, refinement, &result_.scene);
  }
  RETURN_IF_ERROR(fitted.status());
  const RefinementStats& refined = *fitted;
  if (refined.on_gpu) device_note = absl::StrCat("; solved on ", refinement.device.ToString());
  result_.stats.colour_fit_device = refined.on_gpu ? refinement.device.ToString() : "cpu";
  result_.stats.colour_fit_record_seconds = refined.record_seconds;
  result_.stats.colour_fit_solve_seconds = refined.solve_seconds;
  result_.stats.colour_fit_upload_seconds = refined.upload_seconds;
  const int max_stride = options_.refinement.max_pixel_stride;
  std::string detail = refined.flat_fallback
                           ? absl::StrCat(
                                 "; flat colours: with gradients the weights pass the memory bound "
                                 "even on 1 pixel in ",
                                 max_stride)
                           : "";
  absl::StrAppend(&detail, device_note);
  if (refined.pixel_stride > 1) {
    absl::StrAppend(&detail, "; fitted on 1 pixel in ", refined.pixel_stride,
                    " of each view to stay within the memory bound");
  }
  if (!refined.skipped_over_budget && refined.pixels > 0) {
    result_.stats.colour_fit_pixel_stride = refined.pixel_stride;
  }
  result_.stats.colour_fit_bound_bytes = kWeightUnitBytes * refined.max_pairs;
  const std::string bound = absl::StrCat(
      absl::SixDigits(1e-9 * double(kWeightUnitBytes) * double(refined.max_pairs)), " GB");
  if (refined.skipped_over_budget) {
    Done(ReconStage::kRefine,
         absl::StrCat(" (skipped: the context views' weights pass the fit's memory bound, ", bound,
                      ", even on 1 pixel in ", max_stride,
                      " of each view; colours kept as decoded)"));
  } else {
    Done(ReconStage::kRefine,
         absl::StrCat(" (", refined.pairs, " pixel-Gaussian pairs, ",
                      absl::SixDigits(double(refined.weight_bytes) / 1e9),
                      " GB of weights within a ", bound, " bound, context RMSE ",
                      refined.rmse_before, " -> ", refined.rmse_after, "; weights ",
                      absl::SixDigits(refined.record_seconds), " s, fit ",
                      absl::SixDigits(refined.solve_seconds), " s", detail, ")"));
  }
  return absl::OkStatus();
}

absl::Status Pipeline::Optimize() {
  if (options_.optimize.steps <= 0) return absl::OkStatus();
  OptimizeOptions optimize = options_.optimize;
  std::vector<uint8_t> fixed(result_.scene.size(), 0);
  for (size_t i = 0; i < fixed.size() && i < far_.size(); ++i) fixed[i] = far_[i];
  // A progress line about every 10 % of the steps, and at least every 30 s
  // (a run bounded by seconds may never reach 10 % of its steps).
  const int every = std::max(1, optimize.steps / 10);
  double reported = 0;
  optimize.progress = [&](const OptimizeProgress& p) {
    if (p.step % every != 0 && p.step != p.steps && p.seconds - reported < 30) return;
    reported = p.seconds;
    ReportNote(options_.progress, ReconStage::kOptimize,
               absl::StrCat("optimize: step ", p.step, "/", p.steps, ", ",
                            absl::SixDigits(p.seconds), " s, loss ", absl::SixDigits(p.loss),
                            ", context PSNR ", absl::SixDigits(p.psnr), " dB (this epoch)"));
  };
  ASSIGN_OR_RETURN(const OptimizeStats stats,
                   OptimizeScene(inputs_.views, fixed, optimize, &result_.scene));
  result_.stats.optimize_steps = stats.steps;
  result_.stats.optimize_loss = stats.loss;
  result_.stats.optimize_psnr = stats.psnr;
  if (optimize.densify) {
    // The counts of the scene as optimised: split children added, pruned
    // entries left out (they stay in the arrays, invisible).
    ReconStats& s = result_.stats;
    s.optimize_densify = true;
    s.optimize_split = stats.split;
    s.optimize_cloned = stats.cloned;
    s.optimize_pruned = stats.pruned;
    CountGaussians(result_.scene.owners, far_, stats.pruned_entries, &s);
  }
  if (optimize.pose) {
    for (size_t v = 0; v < stats.poses.size(); ++v) {
      result_.stats.optimize_poses.push_back(
          {inputs_.views[v].frame_index, inputs_.views[v].camera_id, stats.poses[v]});
    }
  }
  const size_t views = inputs_.views.size();
  auto mean_psnr = [&](size_t begin, size_t end) {
    double sum = 0;
    for (size_t k = begin; k < end; ++k) sum += stats.psnr[k];
    return end > begin ? sum / double(end - begin) : 0.0;
  };
  const size_t first = std::min(views, stats.psnr.size());
  const size_t last_begin = stats.psnr.size() > views ? stats.psnr.size() - views : 0;
  Done(ReconStage::kOptimize,
       absl::StrCat(" (", stats.steps, " steps; context PSNR ",
                    absl::SixDigits(mean_psnr(0, first)), " dB in the first epoch, ",
                    absl::SixDigits(mean_psnr(last_begin, stats.psnr.size())),
                    " dB in the last; render ", absl::SixDigits(stats.render_seconds),
                    " s, backward ", absl::SixDigits(stats.backward_seconds), " s, update ",
                    absl::SixDigits(stats.update_seconds), " s", PoseSummary(stats),
                    DensifySummary(optimize, stats, result_.stats), ")"));
  return absl::OkStatus();
}

ReconResult Pipeline::Finish() {
  result_.scene.ego_layers = std::move(ego_layers_);
  result_.scene.render_blur = result_.stats.render_blur;
  result_.scene.render_blur_growth = result_.stats.render_blur_growth;
  result_.scene.blur_anchors = std::move(blur_anchors_);
  result_.stats.colour_gradients = result_.scene.has_colour_gradients();
  result_.stats.total_seconds = Now() - start_;
  return std::move(result_);
}

}  // namespace pf
