// The reconstruction pipeline, stage by stage.
#include "worker/engine/recon/reconstruction.h"

// The generated protobuf header first (see image_io.h).
#include <algorithm>
#include <chrono>

#include "absl/strings/str_cat.h"
#include "common/status_macros.h"
#include "pointforward/v1/clip.pb.h"
#include "worker/engine/recon/depth_stage.h"
#include "worker/engine/recon/query_lifting.h"
#include "worker/engine/recon/scene_graph.h"
#if PF_HAVE_TORCH
#include "worker/engine/recon/tensor_fusion.h"
#endif

namespace pf {
namespace {

// Times stages and reports progress.
class StageClock {
 public:
  StageClock(ReconStats* stats, const std::function<void(const std::string&)>& progress)
      : stats_(stats), progress_(progress), start_(Now()), last_(start_) {}

  // Closes the running stage as `name`.
  void Done(const std::string& name, const std::string& detail = "") {
    const double now = Now();
    stats_->stage_seconds.emplace_back(name, now - last_);
    if (progress_) progress_(absl::StrCat(name, " done in ", now - last_, " s", detail));
    last_ = now;
  }
  void Progress(const std::string& line) const {
    if (progress_) progress_(line);
  }
  double Total() const { return Now() - start_; }

 private:
  static double Now() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
  }
  ReconStats* stats_;
  const std::function<void(const std::string&)>& progress_;
  double start_, last_;
};

}  // namespace

absl::StatusOr<ReconModel> ParseReconModel(const std::string& name) {
  if (name == "analytic") return ReconModel::kAnalytic;
  if (name == "pixel-aligned") return ReconModel::kPixelAligned;
  return absl::InvalidArgumentError(
      absl::StrCat("--model: unknown model '", name, "' (expected analytic or pixel-aligned)"));
}

const char* ReconModelName(ReconModel model) {
  return model == ReconModel::kAnalytic ? "analytic" : "pixel-aligned";
}

absl::Status SetTracksFromClip(const pointforward::v1::Clip& clip, ReconInputs* inputs) {
  ASSIGN_OR_RETURN(std::vector<InstanceTrack> tracks, TracksFromClip(clip));
  inputs->tracks.clear();
  for (InstanceTrack& track : tracks)
    if (!track.boxes.empty()) inputs->tracks.push_back(std::move(track));
  inputs->time_origin_us = ClipTimeOrigin(clip);
  return absl::OkStatus();
}

absl::StatusOr<ReconInputs> LoadReconInputs(const LoadedClip& loaded, const ReconOptions& options) {
  ReconInputs inputs;
  LoadViewsOptions view_options;
  view_options.allow_outside_paths = options.allow_outside_paths;
  view_options.colour_encoding = options.colour_encoding;
  inputs.colour_encoding = options.colour_encoding;
  ASSIGN_OR_RETURN(inputs.views, LoadContextViews(loaded, view_options));
  if (inputs.views.empty()) {
    return absl::InvalidArgumentError("frames: the clip has no CONTEXT frame to reconstruct from");
  }
  RETURN_IF_ERROR(SetTracksFromClip(loaded.clip, &inputs));
  // LiDAR only matters for views without a depth map.
  const bool need_lidar = std::any_of(inputs.views.begin(), inputs.views.end(),
                                      [](const ContextView& v) { return v.depth.width == 0; });
  if (need_lidar) {
    ASSIGN_OR_RETURN(inputs.sweeps, LoadLidarSweeps(loaded, options.allow_outside_paths));
  }
  return inputs;
}

absl::StatusOr<ReconResult> ReconstructInputs(const ReconInputs& inputs,
                                              const ReconOptions& options) {
  if (inputs.views.empty()) return absl::InvalidArgumentError("no context views");
  RETURN_IF_ERROR(CheckComputeDevice(options.device, "device"));
  ReconResult result;
  ReconStats& stats = result.stats;
  StageClock clock(&stats, options.progress);
  const std::vector<ContextView>& views = inputs.views;
  const std::vector<InstanceTrack>& tracks = inputs.tracks;
  const size_t num_views = views.size();
  stats.views = static_cast<int>(num_views);
  stats.instances = static_cast<int>(tracks.size());
  stats.static_per_view =
      options.static_per_view > 0
          ? options.static_per_view
          : ScaledBudget(kDefaultStaticPerView, views[0].width(), views[0].height());
  stats.dynamic_per_instance =
      options.dynamic_per_instance > 0
          ? options.dynamic_per_instance
          : ScaledBudget(kDefaultDynamicPerInstance, views[0].width(), views[0].height());

  // 1. Depth: measured (map or LiDAR, completed), facades, then the far layer.
  DepthStage stage = MeasureViewDepths(views, inputs.sweeps, tracks, options.completion);
  stats.lidar_views = stage.lidar_views;
  stats.sparse_map_views = stage.sparse_map_views;
  stats.ground_pixels = stage.ground_pixels;
  stats.facade_pixels = stage.facade_pixels;
  const std::vector<ViewDepth> depths = AddFarLayer(views, &stage);
  stats.views_without_depth = stage.views_without_depth;
  const std::string sparse_maps =
      stage.sparse_map_views > 0
          ? absl::StrCat(", ", stage.sparse_map_views, " from sparse depth maps, completed")
          : "";
  clock.Done("depth", absl::StrCat(" (", stats.lidar_views, " of ", num_views, " views from LiDAR",
                                   sparse_maps, ", ", stats.ground_pixels,
                                   " pixels from the ground plane, ", stats.facade_pixels,
                                   " from facades, far layer radius ", stage.far.radius, " m)"));
  if (stats.views_without_depth > 0) {
    clock.Progress(absl::StrCat("warning: ", stats.views_without_depth, " of ", num_views,
                                " views have no depth map and no LiDAR point; all their pixels "
                                "are on the far layer"));
  }

  // 2. Lifting.
  std::vector<LiftedView> lifted(num_views);
  for (size_t v = 0; v < num_views; ++v) lifted[v] = LiftView(views[v], depths[v]);
  clock.Done("lift");

  // 3. Scene graph: box membership of lifted points and dynamic masks.
  std::vector<std::vector<uint32_t>> owners(num_views);
  std::vector<std::vector<uint8_t>> masks(num_views);
  for (size_t v = 0; v < num_views; ++v) {
    owners[v] = PixelOwners(lifted[v], depths[v], tracks, views[v].timestamp_us);
    masks[v] = DynamicMask(views[v].camera, views[v].world_from_camera, tracks,
                           views[v].timestamp_us, kMembershipMargin.grow);
  }
  clock.Done("scene_graph");

  // 4. Sampling.
  SamplingOptions sampling;
  sampling.static_per_view = stats.static_per_view;
  sampling.dynamic_per_instance = stats.dynamic_per_instance;
  sampling.far_stride = options.far_stride;
  sampling.skip_covered = options.skip_covered;
  sampling.fill_static_budget = options.fill_static_budget;
  sampling.behind_band_px = options.hidden_band_px;
  sampling.dense = options.model == ReconModel::kPixelAligned;
  std::vector<SamplingView> sampling_views(num_views);
  for (size_t v = 0; v < num_views; ++v)
    sampling_views[v] = {&views[v], &depths[v], &lifted[v], &owners[v]};
  const QuerySet queries = SampleQueries(sampling_views, tracks, sampling);
  lifted.clear();
  clock.Done("sample", absl::StrCat(" (", queries.size(), " queries)"));

  // 5. Fusion.
  FusedQueries fused;
  if (options.model == ReconModel::kAnalytic) {
    std::vector<FusionView> fusion_views(num_views);
    for (size_t v = 0; v < num_views; ++v) fusion_views[v] = {&views[v], &depths[v], &masks[v]};
#if PF_HAVE_TORCH
    ASSIGN_OR_RETURN(
        fused, FuseQueriesOnDevice(queries, fusion_views, tracks, options.fusion, options.device));
    clock.Done("fuse", absl::StrCat(" (LibTorch on ", options.device.ToString(), ")"));
#else
    fused = FuseQueries(queries, fusion_views, tracks, options.fusion);
    clock.Done("fuse", " (C++ on cpu)");
#endif
  } else {
    fused = UnfusedQueries(queries);
    clock.Done("fuse", " (none: one Gaussian per pixel)");
  }

  // 6. Decoding.
  std::vector<int64_t> times(num_views);
  for (size_t v = 0; v < num_views; ++v) times[v] = views[v].timestamp_us;
  result.scene =
      DecodeGaussians(queries, fused, times, inputs.time_origin_us, tracks, options.decoder);
  result.scene.colour_encoding = inputs.colour_encoding;
  for (size_t i = 0; i < queries.size(); ++i) {
    if (queries.owners[i] == 0) {
      ++stats.static_gaussians;
      stats.far_gaussians += queries.far[i];
    } else {
      ++stats.dynamic_gaussians;
    }
  }
  clock.Done("decode");

  // 7. Colour refinement against the context images.
  if (options.refinement.iterations > 0) {
    RefinementOptions refinement = options.refinement;
    refinement.colour_gradients = ColourGradientsFor(options);
    ASSIGN_OR_RETURN(const RefinementStats refined,
                     RefineColours(views, refinement, &result.scene));
    const int max_stride = options.refinement.max_pixel_stride;
    std::string detail =
        refined.flat_fallback
            ? absl::StrCat(
                  "; flat colours: with gradients the weights pass the memory bound "
                  "even on 1 pixel in ",
                  max_stride)
            : "";
    if (refined.pixel_stride > 1) {
      absl::StrAppend(&detail, "; fitted on 1 pixel in ", refined.pixel_stride,
                      " of each view to stay within the memory bound");
    }
    if (!refined.skipped_over_budget && refined.pixels > 0) {
      stats.colour_fit_pixel_stride = refined.pixel_stride;
    }
    if (refined.skipped_over_budget) {
      clock.Done("refine",
                 absl::StrCat(" (skipped: the context views' weights pass the fit's memory bound, ",
                              absl::SixDigits(1e-9 * double(kWeightUnitBytes) *
                                              double(options.refinement.max_pairs)),
                              " GB, even on 1 pixel in ", max_stride,
                              " of each view; colours kept as decoded)"));
    } else {
      clock.Done("refine", absl::StrCat(" (", refined.pairs, " pixel-Gaussian pairs, ",
                                        absl::SixDigits(double(refined.weight_bytes) / 1e9),
                                        " GB of weights, context RMSE ", refined.rmse_before,
                                        " -> ", refined.rmse_after, detail, ")"));
    }
  }
  stats.colour_gradients = result.scene.has_colour_gradients();
  stats.total_seconds = clock.Total();
  return result;
}

bool ColourGradientsFor(const ReconOptions& options) {
  return options.colour_gradients.value_or(options.model == ReconModel::kAnalytic);
}

absl::StatusOr<ReconResult> Reconstruct(const LoadedClip& loaded, const ReconOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  if (options.progress) options.progress("loading context frames");
  ASSIGN_OR_RETURN(ReconInputs inputs, LoadReconInputs(loaded, options));
  const double load_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSIGN_OR_RETURN(ReconResult result, ReconstructInputs(inputs, options));
  result.stats.stage_seconds.insert(result.stats.stage_seconds.begin(), {"load", load_seconds});
  result.stats.total_seconds += load_seconds;
  return result;
}

}  // namespace pf
