// pf eval CLIP.json --out DIR [--model analytic|pixel-aligned] [--ns N --nd N]
//         [--fusion softmax|average|no-depth] [--no-lifespan] [--refine N]
//         [--splat-sigma S] [--device cpu]
// Reconstructs from the clip's CONTEXT frames, renders every TARGET frame
// and writes DIR/report.json and a contact sheet per target
// (worker/engine/recon/evaluation.h). Progress to stderr; the mean figures
// to stdout.
#include <cstdio>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/commands.h"
#include "common/command_line.h"
#include "common/status_macros.h"
#include "worker/engine/clip/clip_io.h"
#include "worker/engine/recon/evaluation.h"
#include "worker/engine/recon/recon_flags.h"

namespace pf {
namespace {

constexpr char kUsage[] =
    "usage: pf eval CLIP.json --out DIR [--model analytic|pixel-aligned] [--ns N --nd N] "
    "[--fusion softmax|average|no-depth] [--no-lifespan] [--refine N] [--splat-sigma S] "
    "[--device cpu]";

std::string Figure(const std::optional<double>& value, const char* unit) {
  return value.has_value() ? absl::StrCat(absl::SixDigits(*value), unit) : "n/a";
}

absl::Status Run(const CommandLine& cl) {
  if (cl.positional().size() != 1 || !cl.Has("out")) return absl::InvalidArgumentError(kUsage);
  ASSIGN_OR_RETURN(ReconOptions options, ReconOptionsFromFlags(cl));
  options.progress = [](const std::string& line) {
    std::fprintf(stderr, "pf eval: %s\n", line.c_str());
  };
  ASSIGN_OR_RETURN(const LoadedClip loaded, LoadClip(cl.positional()[0]));
  const std::string out_dir = cl.Get("out");
  ASSIGN_OR_RETURN(const EvalReport report, EvaluateClip(loaded, options, out_dir));
  std::printf(
      "%s: %lld gaussians, reconstruct %.2f s, %zu target frames rendered in %.2f s\n"
      "  mean PSNR %s, SSIM %s, depth RMSE %s, dynamic PSNR %s\n"
      "  report: %s/report.json\n",
      ReconModelName(options.model), static_cast<long long>(report.gaussians),
      report.stats.total_seconds, report.frames.size(), report.render_seconds,
      Figure(report.mean.psnr, " dB").c_str(), Figure(report.mean.ssim, "").c_str(),
      Figure(report.mean.depth_rmse, " m").c_str(), Figure(report.mean.dynamic_psnr, " dB").c_str(),
      out_dir.c_str());
  return absl::OkStatus();
}

}  // namespace

int RunEval(const std::vector<std::string>& args) {
  absl::StatusOr<CommandLine> cl = ParseReconCommandLine(args);
  if (!cl.ok()) return ReportError("eval", cl.status());
  const absl::Status status = Run(*cl);
  return status.ok() ? kExitOk : ReportError("eval", status);
}

}  // namespace pf
