// pf reconstruct CLIP.json --out SCENE [--model analytic|pixel-aligned]
//                [--ns N --nd N] [--fusion softmax|average|no-depth]
//                [--lifespan] [--refine N] [--splat-sigma S] [--low-pass PX2] [--order-band B]
//                [--fade-frames F]
//                [--hidden-band PX] [--colour-fit-memory GB] [--no-ground-fill] [--no-facades]
//                [--no-stereo] [--no-ego-layer]
//                [--device cpu|cuda[:N]] [--colour gradients|flat]
//                [--working-space srgb|linear]
//                [--optimize-steps N [--optimize-seconds S] [--optimize-poses]
//                 [--optimize-densify]]
//                [--allow-outside-paths]
// Checks the clip as pf validate does, then builds a Gaussian scene from the
// clip's CONTEXT frames (engine/recon/reconstruction.h) and writes it
// with SaveScene. Progress per stage goes to stderr, a summary to stdout.
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "client/commands.h"
#include "common/command_line.h"
#include "common/file_util.h"
#include "common/status_macros.h"
#include "engine/clip/clip_io.h"
#include "engine/clip/clip_validator.h"
#include "engine/recon/recon_options.h"
#include "engine/recon/reconstruction.h"
#include "engine/render/scene_file.h"

namespace pf {
namespace {

constexpr char kReconstructUsage[] =
    "usage: pf reconstruct CLIP.json --out SCENE [--model analytic|pixel-aligned] "
    "[--ns N --nd N] [--fusion softmax|average|no-depth] [--lifespan] [--refine N] "
    "[--splat-sigma S] [--low-pass PX2] [--order-band B] [--fade-frames F] [--hidden-band PX] "
    "[--colour-fit-memory GB] [--no-ground-fill] [--no-facades] [--no-stereo] [--no-ego-layer] "
    "[--render-blur PX] [--render-blur-growth G] [--still-rig-density F] "
    "[--device cpu|cuda[:N]] [--colour gradients|flat] [--working-space srgb|linear] "
    "[--completion nearest|ip-basic] "
    "[--optimize-steps N [--optimize-seconds S] [--optimize-poses] [--optimize-densify]] "
    "[--allow-outside-paths]";

absl::Status ReconstructCommand(const CommandLine& cl) {
  if (cl.positional().size() != 1) return absl::InvalidArgumentError(kReconstructUsage);
  RETURN_IF_ERROR(cl.Require({"out"}, kReconstructUsage));
  ASSIGN_OR_RETURN(ReconOptions options, ReconOptionsFromFlags(cl));
  options.progress = [](const ReconProgress& progress) {
    std::fprintf(stderr, "pf reconstruct: %s\n", ProgressLine(progress).c_str());
  };
  const std::string clip_path = cl.positional()[0];
  RETURN_IF_ERROR(CheckOutputFilePath("--out", cl.Get("out")));
  ValidateOptions validate;
  validate.allow_outside_paths = options.allow_outside_paths;
  ASSIGN_OR_RETURN(const LoadedClip loaded, LoadValidClip(clip_path, validate));
  ASSIGN_OR_RETURN(const ReconResult result, Reconstruct(loaded, options));
  const ReconStats& s = result.stats;
  const std::map<std::string, std::string> metadata = SceneMetadata(options, s, clip_path);
  RETURN_IF_ERROR(SaveScene(result.scene, cl.Get("out"), metadata));

  std::vector<std::string> stages;
  for (const auto& [name, seconds] : s.stage_seconds)
    stages.push_back(absl::StrCat(name, " ", absl::SixDigits(seconds), " s"));
  std::printf(
      "reconstructed %s (%s) -> %s\n"
      "  gaussians: %zu (static %lld incl. far layer %lld, dynamic %lld)\n"
      "  instances: %d, context views: %d (%d with depth from LiDAR, %d from sparse depth maps, "
      "%lld pixels of them from the ground plane, %lld from facades, %lld from stereo, %lld "
      "from the depth below continued up and %lld in gaps enclosed by known depth, %d "
      "without depth), "
      "N_s %lld, N_d %lld\n"
      "  time: %s; total %.2f s\n",
      clip_path.c_str(), options.model.c_str(), cl.Get("out").c_str(), result.scene.size(),
      static_cast<long long>(s.static_gaussians), static_cast<long long>(s.far_gaussians),
      static_cast<long long>(s.dynamic_gaussians), s.instances, s.views, s.lidar_views,
      s.sparse_map_views, static_cast<long long>(s.ground_pixels),
      static_cast<long long>(s.facade_pixels), static_cast<long long>(s.stereo_pixels),
      static_cast<long long>(s.upward_pixels), static_cast<long long>(s.enclosed_pixels),
      s.views_without_depth, static_cast<long long>(s.static_per_view),
      static_cast<long long>(s.dynamic_per_instance), absl::StrJoin(stages, ", ").c_str(),
      s.total_seconds);
  return absl::OkStatus();
}

}  // namespace

int RunReconstruct(const std::vector<std::string>& args) {
  absl::StatusOr<CommandLine> cl = ParseReconCommandLine(args);
  if (!cl.ok()) return ReportError("reconstruct", cl.status());
  const absl::Status status = ReconstructCommand(*cl);
  return status.ok() ? kExitOk : ReportError("reconstruct", status);
}

}  // namespace pf
