// The engine's ReconOptions from the one table of reconstruction options
// (recon_option_table.h): from a ReconstructionOptions message (the worker,
// and the command line after its flags are read into one), and the metadata
// a scene file records of them. The flags (`pf reconstruct`, `pf eval`,
// `pf depth-eval`; `pf help` lists them):
//
//   --model analytic|pixel-aligned   (default analytic; recon_model.h)
//   --ns N  --nd N                   N_s per view, N_d per instance
//                                    (default 100K / 10K scaled to the image size;
//                                    sparse_sampling.h ScaledStaticBudget)
//   --still-rig-density F            N_s of the views of a camera that stands still
//                                    over the CONTEXT frames is F x N_s (default 8;
//                                    1: no more; sparse_sampling.h StillCameraViews)
//   --fusion softmax|average|no-depth  fusion weights (ablations; default softmax)
//   --lifespan                       static Gaussians that a view at another time
//                                    sees past fade with time (off by default;
//                                    --no-lifespan, the default, is accepted)
//   --no-ground-fill                 LiDAR depth without the ground plane (view_depth.h;
//                                    ablation)
//   --no-facades                     LiDAR depth without facades above the top beam
//                                    (facade_depth.h; ablation)
//   --no-ego-layer                   find no ego body: lift every pixel, no ego layer
//                                    in the scene (ego_body.h)
//   --render-blur PX                 every render of the scene blurred by a Gaussian
//                                    of std-dev PX pixels (render_blur.h; default 0.5
//                                    where the rig moves and depth is measured, else
//                                    0; docs/QUALITY.md, "Render blur"), alone: that
//                                    blur whatever the pose
//   --render-blur-growth G           and more away from the CONTEXT cameras: G mrad
//                                    per metre, up to 3 px (default 2 where the
//                                    default blur is over 0, else 0)
//   --completion nearest|ip-basic    how LiDAR depth is completed (default nearest)
//   --refine N                       colour-fit iterations (default 20; 0 off)
//   --splat-sigma S                  Gaussian std-dev per query spacing (default 0.65)
//   --fade-frames F                  static Gaussians fade with time away from their
//                                    view's over about F CONTEXT frames (default 5;
//                                    0: never; gaussian_decoder.h)
//   --low-pass PX2                   the scene's screen-space low-pass, pixels^2
//                                    (default 0.1 with dense depth maps, else 0.2;
//                                    0.3 is the 3DGS one)
//   --hidden-band PX                 hidden queries behind depth edges within PX
//                                    pixels (sparse_sampling.h; default 256, 0: none)
//   --colour gradients|flat          a colour gradient across each Gaussian or one
//                                    colour (colour_refinement.h; default: the model's)
//   --working-space srgb|linear      the colour encoding the context images are
//                                    decoded to and the scene's colours are fitted
//                                    in (default srgb; docs/SCENE_FORMAT.md, "Colour")
//   --optimize-steps N               per-scene optimisation: N context views rendered
//                                    and stepped after the colour fit (scene_optimizer.h;
//                                    default 0: none)
//   --optimize-seconds S             stop the optimisation after S seconds
//   --optimize-poses                 the optimisation also corrects each context
//                                    view's camera pose (scene_optimizer.h)
//   --optimize-densify               the optimisation also splits Gaussians where
//                                    the views disagree with the scene and prunes
//                                    the faintest (scene_optimizer.h)
//   --device cpu|cuda[:N]            where fusion and the colour fit's solve run (compute_device.h)
//   --allow-outside-paths            accept manifest paths that are absolute or leave
//                                    the clip's directory (as pf validate does)
#ifndef POINTFORWARD_ENGINE_RECON_RECON_OPTIONS_H_
#define POINTFORWARD_ENGINE_RECON_RECON_OPTIONS_H_

#include <map>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "common/command_line.h"
#include "engine/recon/reconstruction.h"
#include "pointforward/v1/resources.pb.h"

namespace pf {

// The engine options `proto` asks for, every field checked against the
// table and the registered models (INVALID_ARGUMENT naming "options.<field>").
// options.device is parsed, not checked against this process.
absl::StatusOr<ReconOptions> ReconOptionsFromProto(
    const pointforward::v1::ReconstructionOptions& proto);

// Parses the words of `pf reconstruct` / `pf eval`: the table's flags,
// --allow-outside-paths and --out. INVALID_ARGUMENT naming an unknown flag.
absl::StatusOr<CommandLine> ParseReconCommandLine(const std::vector<std::string>& args);

// The options the flags of `cl` ask for: INVALID_ARGUMENT naming the flag for
// a value out of its range or choices; FAILED_PRECONDITION for a device this
// process cannot use (a GPU without CUDA LibTorch, or no LibTorch at all).
absl::StatusOr<ReconOptions> ReconOptionsFromFlags(const CommandLine& cl);

// The name of a fusion weighting as --fusion spells it.
const char* FusionWeightsName(FusionWeights weights);

// What a scene file records of its reconstruction (`pf scene` prints it):
// model, source_clip, the N_s and N_d used, fusion, lifespan, ground_fill,
// facades.
std::map<std::string, std::string> SceneMetadata(const ReconOptions& options,
                                                 const ReconStats& stats,
                                                 const std::string& source_clip);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_RECON_OPTIONS_H_
