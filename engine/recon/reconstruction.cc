// Loading a reconstruction's inputs and running the model the options name.
#include "engine/recon/reconstruction.h"

#include <chrono>

#include "absl/strings/str_cat.h"
#include "common/elapsed.h"
#include "common/status_macros.h"
#include "engine/recon/recon_model.h"

namespace pf {

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
  // LiDAR gives the depth of views without a depth map, and the intensity.
  ASSIGN_OR_RETURN(inputs.sweeps, LoadLidarSweeps(loaded, options.allow_outside_paths));
  return inputs;
}

absl::StatusOr<ReconResult> ReconstructInputs(ReconInputs inputs, const ReconOptions& options) {
  if (inputs.views.empty()) return absl::InvalidArgumentError("no context views");
  const ReconModel* model = FindReconModel(options.model);
  if (model == nullptr) return CheckReconModel(options.model, "model");
  RETURN_IF_ERROR(CheckComputeDevice(options.device, "device"));
  return model->Reconstruct(std::move(inputs), options);
}

bool ColourGradientsFor(const ReconOptions& options) {
  const ReconModel* model = FindReconModel(options.model);
  return options.colour_gradients.value_or(model == nullptr || model->DefaultColourGradients());
}

absl::StatusOr<ReconResult> Reconstruct(const LoadedClip& loaded, const ReconOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  ReportNote(options.progress, ReconStage::kLoad, "loading context frames");
  ASSIGN_OR_RETURN(ReconInputs inputs, LoadReconInputs(loaded, options));
  const double load_seconds = SecondsSince(start);
  ASSIGN_OR_RETURN(ReconResult result, ReconstructInputs(std::move(inputs), options));
  result.stats.stage_seconds.insert(result.stats.stage_seconds.begin(),
                                    {ReconStageName(ReconStage::kLoad), load_seconds});
  result.stats.total_seconds += load_seconds;
  return result;
}

}  // namespace pf
