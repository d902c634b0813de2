// The command-line flags of `pf reconstruct` and `pf eval` that shape a
// reconstruction, parsed into ReconOptions in one place:
//
//   --model analytic|pixel-aligned   (default analytic)
//   --ns N  --nd N                   N_s per view, N_d per instance
//                                    (default 100K / 10K scaled to the image size)
//   --fusion softmax|average|no-depth  fusion weights (ablations; default softmax)
//   --lifespan                       static Gaussians that a view at another time
//                                    sees past fade with time (off by default;
//                                    --no-lifespan, the default, is accepted)
//   --no-ground-fill                 LiDAR depth without the ground plane (view_depth.h;
//                                    ablation)
//   --no-facades                     LiDAR depth without facades above the top beam
//                                    (facade_depth.h; ablation)
//   --refine N                       colour refinement iterations (default 12; 0 off)
//   --splat-sigma S                  Gaussian std-dev per query spacing (default 0.65)
//   --low-pass PX2                   the scene's screen-space low-pass, pixels^2
//                                    (default 0.1; 0.3 is the 3DGS one)
//   --hidden-band PX                 hidden queries behind depth edges within PX
//                                    pixels (sparse_sampling.h; default 256, 0: none)
//   --colour gradients|flat          a colour gradient across each Gaussian or one
//                                    colour (colour_refinement.h; default gradients
//                                    for analytic, flat for pixel-aligned)
//   --working-space srgb|linear      the colour encoding the context images are
//                                    decoded to and the scene's colours are fitted
//                                    in (default srgb; docs/SCENE_FORMAT.md, "Colour")
//   --device cpu|cuda[:N]              where fusion's tensor work runs (compute_device.h)
//   --allow-outside-paths            accept manifest paths that are absolute or leave
//                                    the clip's directory (as pf validate does)
#ifndef POINTFORWARD_WORKER_ENGINE_RECON_RECON_FLAGS_H_
#define POINTFORWARD_WORKER_ENGINE_RECON_RECON_FLAGS_H_

#include <set>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "common/command_line.h"
#include "worker/engine/recon/reconstruction.h"

namespace pf {

// Flags that take a value / no value, to pass to CommandLine::Parse.
const std::set<std::string>& ReconValueFlags();
const std::set<std::string>& ReconBoolFlags();

// Parses the words of `pf reconstruct` / `pf eval`: the reconstruction flags
// above plus `--out`. INVALID_ARGUMENT naming an unknown flag.
absl::StatusOr<CommandLine> ParseReconCommandLine(const std::vector<std::string>& args);

// Returns the options the flags of `cl` ask for. INVALID_ARGUMENT naming the
// flag for an unknown model or fusion, a budget that is not a positive
// integer or an unknown --device; FAILED_PRECONDITION for a device this
// process cannot use (a GPU without CUDA LibTorch, or no LibTorch at all).
absl::StatusOr<ReconOptions> ReconOptionsFromFlags(const CommandLine& cl);

// Returns the name of a fusion weighting as --fusion spells it.
const char* FusionWeightsName(FusionWeights weights);

}  // namespace pf

#endif  // POINTFORWARD_WORKER_ENGINE_RECON_RECON_FLAGS_H_
