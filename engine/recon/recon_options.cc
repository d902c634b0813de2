// ReconOptions from the option table: see recon_options.h.
#include "engine/recon/recon_options.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "common/colour_space.h"
#include "common/status_macros.h"
#include "engine/recon/recon_model.h"
#include "engine/recon/recon_option_table.h"

namespace pf {

namespace v1 = pointforward::v1;

absl::StatusOr<ReconOptions> ReconOptionsFromProto(const v1::ReconstructionOptions& proto) {
  ASSIGN_OR_RETURN(const v1::ReconstructionOptions p,
                   NormalizeReconProto(proto, ReconModelNames()));
  ReconOptions options;
  options.model = p.model();
  options.static_per_view = p.ns();
  options.dynamic_per_instance = p.nd();
  if (p.has_still_rig_density()) options.still_rig_density = p.still_rig_density();
  if (p.fusion() == "average") {
    options.fusion.weights = FusionWeights::kPlainAverage;
  } else if (p.fusion() == "no-depth") {
    options.fusion.weights = FusionWeights::kNoDepth;
  } else {
    options.fusion.weights = FusionWeights::kDepthSoftmax;
  }
  options.fusion.lifespan = p.lifespan();
  options.completion.ground_fill = !p.no_ground_fill();
  options.completion.facades = !p.no_facades();
  options.completion.stereo = !p.no_stereo();
  options.ego_layer = !p.no_ego_layer();
  if (p.has_render_blur()) options.render_blur = static_cast<float>(p.render_blur());
  if (p.has_render_blur_growth()) {
    options.render_blur_growth = static_cast<float>(p.render_blur_growth());
  }
  options.completion.method = p.completion() == "ip-basic" ? CompletionOptions::Method::kIpBasic
                                                           : CompletionOptions::Method::kNearest;
  if (p.has_refine()) options.refinement.iterations = p.refine();
  if (p.has_colour_fit_memory()) {
    options.refinement.max_pairs = std::max<int64_t>(
        1, static_cast<int64_t>(p.colour_fit_memory() * 1e9 / double(kWeightUnitBytes)));
    options.refinement.available_memory_share = 0;
  }
  if (p.has_splat_sigma()) options.decoder.tangent_sigma = p.splat_sigma();
  if (p.has_low_pass()) options.decoder.low_pass = static_cast<float>(p.low_pass());
  if (p.has_order_band()) options.decoder.order_band = static_cast<float>(p.order_band());
  if (p.has_fade_frames()) options.decoder.fade_frames = p.fade_frames();
  if (p.has_hidden_band()) options.hidden_band_px = p.hidden_band();
  if (p.has_optimize_steps()) options.optimize.steps = p.optimize_steps();
  if (p.has_optimize_seconds()) options.optimize.max_seconds = p.optimize_seconds();
  options.optimize.pose = p.optimize_poses();
  options.optimize.densify = p.optimize_densify();
  if (!p.colour().empty()) options.colour_gradients = p.colour() == "gradients";
  if (!p.working_space().empty()) {
    ASSIGN_OR_RETURN(options.colour_encoding,
                     ParseColourEncoding(p.working_space(), "options.working_space"));
  }
  ASSIGN_OR_RETURN(options.device, ParseComputeDevice(p.device(), "options.device"));
  return options;
}

absl::StatusOr<CommandLine> ParseReconCommandLine(const std::vector<std::string>& args) {
  std::set<std::string> value_flags = ReconValueFlags();
  value_flags.insert("out");
  std::set<std::string> switches = ReconSwitchFlags();
  switches.insert("allow-outside-paths");
  return CommandLine::Parse(args, value_flags, switches);
}

absl::StatusOr<ReconOptions> ReconOptionsFromFlags(const CommandLine& cl) {
  ASSIGN_OR_RETURN(const v1::ReconstructionOptions proto,
                   ReconProtoFromFlags(cl, ReconModelNames()));
  ASSIGN_OR_RETURN(ReconOptions options, ReconOptionsFromProto(proto));
  options.allow_outside_paths = cl.Has("allow-outside-paths");
  RETURN_IF_ERROR(CheckComputeDevice(options.device, "--device"));
  return options;
}

const char* FusionWeightsName(FusionWeights weights) {
  switch (weights) {
    case FusionWeights::kDepthSoftmax:
      return "softmax";
    case FusionWeights::kPlainAverage:
      return "average";
    case FusionWeights::kNoDepth:
      return "no-depth";
  }
  return "?";
}

std::map<std::string, std::string> SceneMetadata(const ReconOptions& options,
                                                 const ReconStats& stats,
                                                 const std::string& source_clip) {
  return {{"model", options.model},
          {"source_clip", source_clip},
          {"ns", absl::StrCat(stats.static_per_view)},
          {"nd", absl::StrCat(stats.dynamic_per_instance)},
          {"fusion", FusionWeightsName(options.fusion.weights)},
          {"lifespan", options.fusion.lifespan ? "true" : "false"},
          {"ground_fill", options.completion.ground_fill ? "true" : "false"},
          {"facades", options.completion.facades ? "true" : "false"},
          {"stereo", options.completion.stereo ? "true" : "false"}};
}

}  // namespace pf
