// Parsing reconstruction flags.
#include "worker/engine/recon/recon_flags.h"

#include "absl/strings/str_cat.h"
#include "common/status_macros.h"
#include "worker/engine/recon/tuning_limits.h"

namespace pf {

const std::set<std::string>& ReconValueFlags() {
  static const std::set<std::string> flags = {
      "model",       "ns",          "nd",       "fusion", "device",        "refine",
      "hidden-band", "splat-sigma", "low-pass", "colour", "working-space", "completion"};
  return flags;
}

const std::set<std::string>& ReconBoolFlags() {
  static const std::set<std::string> flags = {"lifespan", "no-lifespan", "no-ground-fill",
                                              "no-facades", "allow-outside-paths"};
  return flags;
}

absl::StatusOr<CommandLine> ParseReconCommandLine(const std::vector<std::string>& args) {
  std::set<std::string> value_flags = ReconValueFlags();
  value_flags.insert("out");
  return CommandLine::Parse(args, value_flags, ReconBoolFlags());
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

absl::StatusOr<ReconOptions> ReconOptionsFromFlags(const CommandLine& cl) {
  ReconOptions options;
  ASSIGN_OR_RETURN(options.model, ParseReconModel(cl.Get("model", "analytic")));
  ASSIGN_OR_RETURN(options.static_per_view, cl.GetInt("ns", 0));
  ASSIGN_OR_RETURN(options.dynamic_per_instance, cl.GetInt("nd", 0));
  if (cl.Has("ns") && options.static_per_view <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("--ns: must be a positive number of queries per view, got ", cl.Get("ns")));
  }
  if (cl.Has("nd") && options.dynamic_per_instance <= 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--nd: must be a positive number of queries per instance, got ", cl.Get("nd")));
  }
  const std::string fusion = cl.Get("fusion", "softmax");
  if (fusion == "softmax") {
    options.fusion.weights = FusionWeights::kDepthSoftmax;
  } else if (fusion == "average") {
    options.fusion.weights = FusionWeights::kPlainAverage;
  } else if (fusion == "no-depth") {
    options.fusion.weights = FusionWeights::kNoDepth;
  } else {
    return absl::InvalidArgumentError(absl::StrCat("--fusion: unknown weighting '", fusion,
                                                   "' (expected softmax, average or no-depth)"));
  }
  if (cl.Has("lifespan") && cl.Has("no-lifespan")) {
    return absl::InvalidArgumentError(
        "--lifespan: given with --no-lifespan; give one (lifespans are off by default)");
  }
  options.fusion.lifespan = cl.Has("lifespan");
  options.completion.ground_fill = !cl.Has("no-ground-fill");
  options.completion.facades = !cl.Has("no-facades");
  const std::string completion = cl.Get("completion", "nearest");
  if (completion == "nearest") {
    options.completion.method = CompletionOptions::Method::kNearest;
  } else if (completion == "ip-basic") {
    options.completion.method = CompletionOptions::Method::kIpBasic;
  } else {
    return absl::InvalidArgumentError(absl::StrCat("--completion: unknown method '", completion,
                                                   "' (expected nearest or ip-basic)"));
  }
  options.allow_outside_paths = cl.Has("allow-outside-paths");
  ASSIGN_OR_RETURN(options.decoder.tangent_sigma,
                   cl.GetDouble("splat-sigma", options.decoder.tangent_sigma));
  RETURN_IF_ERROR(CheckTuning(kSplatSigmaLimit, options.decoder.tangent_sigma));
  ASSIGN_OR_RETURN(const double low_pass, cl.GetDouble("low-pass", options.decoder.low_pass));
  RETURN_IF_ERROR(CheckTuning(kLowPassLimit, low_pass));
  options.decoder.low_pass = static_cast<float>(low_pass);
  ASSIGN_OR_RETURN(const int64_t refine, cl.GetInt("refine", options.refinement.iterations));
  RETURN_IF_ERROR(CheckTuning(kRefineLimit, double(refine)));
  options.refinement.iterations = static_cast<int>(refine);
  ASSIGN_OR_RETURN(const int64_t band, cl.GetInt("hidden-band", options.hidden_band_px));
  RETURN_IF_ERROR(CheckTuning(kHiddenBandLimit, double(band)));
  options.hidden_band_px = static_cast<int>(band);
  if (cl.Has("colour")) {
    ASSIGN_OR_RETURN(options.colour_gradients, ParseColourModel(cl.Get("colour"), "--colour"));
  }
  ASSIGN_OR_RETURN(options.colour_encoding,
                   ParseColourEncoding(cl.Get("working-space", "srgb"), "--working-space"));
  ASSIGN_OR_RETURN(options.device, ParseComputeDevice(cl.Get("device", "cpu"), "--device"));
  RETURN_IF_ERROR(CheckComputeDevice(options.device, "--device"));
  return options;
}

}  // namespace pf
