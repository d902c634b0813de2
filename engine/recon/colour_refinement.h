// Colour refinement against the context views: the last step of the
// analytic decoder, a least-squares fit of the Gaussians' colours.
//
// Splatting blurs (each Gaussian's footprint, the scene's screen-space
// low-pass, front-to-back compositing of overlapping discs), so fused
// colours rendered back into their own views come out softer than the
// images they came from. With geometry, opacity and time fixed, each
// context view's render is linear in the colours, rgb_v = A_v c
// (render/compositing_weights.h records A_v), so the colours that best
// explain the context images solve
//   min_c  sum_v sum_{p: alpha_vp >= min_alpha} |(A_v c)_p - I_vp|^2
//          + sum_i lambda_i |c_i - c0_i|^2,
// with c_0 the decoded (fused) colours and lambda_i = prior_weight x
// (sqrt(d_i u_i) + 0.001), d_i = sum_v,p M w_ip^2 being Gaussian i's own
// data weight (the diagonal of A^T M A) and u_i the same with nothing in
// front of it (w_ip / T_ip, T the transmittance; prior_from_unoccluded):
// the prior is relative, so one prior_weight damps a pixel-sized disc and
// a large fused one alike, keeps Gaussians that the context views barely
// see at their fused colour, and holds those they see only through others
// (1 / T times harder) from taking colours out of range. It is
// solved per channel by conjugate gradients on the normal equations
// (A^T M A + Lambda) c = A^T M I + Lambda c_0, preconditioned by their
// blocks per Gaussian (a colour and its two gradients share every pixel,
// so with colour gradients a 3x3 block, not the diagonal), each iteration
// one pass over every view's weights, starting from c_0; the result is
// clamped to
// [min_colour, max_colour]. Only CONTEXT images are used; geometry,
// opacity, time and the other feature channels are not touched. Pixels the
// render barely covers (alpha < min_alpha: holes, their rims) are left out,
// so Gaussians at the rim of a hole are not brightened to fill it; nor are
// pixels on the ego vehicle's body (ContextView::ego). Hidden
// Gaussians (agreement 0: the background continued behind an occluding
// edge, sparse_sampling.h) keep their colour.
#ifndef POINTFORWARD_ENGINE_RECON_COLOUR_REFINEMENT_H_
#define POINTFORWARD_ENGINE_RECON_COLOUR_REFINEMENT_H_

#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "common/compute_device.h"
#include "engine/recon/context_views.h"
#include "engine/render/gaussian_scene.h"
#include "engine/render/hole_fill.h"

namespace pf {

// The unit of RefinementOptions::max_pairs: the bytes of one recorded
// pixel-Gaussian pair (a 16-bit weight and a 16-bit slot in its tile's
// table, CompositingWeights::Pair), and of one table slot.
constexpr int64_t kWeightUnitBytes = 4;
// What the fit holds besides the weights: per Gaussian, its vectors with
// colour gradients (four of 9 floats, the preconditioner's 9 and the sums'
// 7), and per pixel of every view, its entry range, table, mask and target.
constexpr int64_t kFitBytesPerGaussian = 4 * (4 * 9 + 9 + 7);
constexpr int64_t kFitBytesPerPixel = 4 + 2 + 4 + 1 + 12;

struct RefinementOptions {
  int iterations = 20;         // Conjugate-gradient iterations; 0: no refinement.
  double prior_weight = 0.05;  // Pull towards the decoded colours, relative to the data.
  // Take each colour's prior relative to sqrt(d_i u_i) instead of d_i, u_i
  // being the data weight Gaussian i would have with nothing in front of it
  // (alpha_ip = w_ip / T_ip in place of w_ip): one the views see only
  // through others keeps closer to its decoded colour.
  bool prior_from_unoccluded = true;
  double min_alpha = kCoveredAlpha;
  // Leave the colour of hidden Gaussians (feature kAgreementChannel 0, see
  // gaussian_decoder.h: behind the surface every context view sees) as
  // decoded; needs a scene with that channel.
  bool keep_hidden = true;
  // Compositing weights under this are not fitted: a contribution below one
  // 8-bit level (1/255, the rasterizer's own alpha cut-off) of a colour in
  // [0, 1]. Their Gaussians' colours enter those pixels as decoded (the
  // fit's target is the image less what they add,
  // CompositingWeights::omitted).
  float min_weight = 1.f / 255.f;
  float min_colour = -0.5f;  // Colours are kept in [min_colour, max_colour].
  float max_colour = 1.5f;
  // Fit a colour gradient across each Gaussian as well
  // (GaussianScene::colour_gradients): three unknowns per channel instead of
  // one, pulled to 0 by gradient_prior_weight relative to their own data
  // weight, kept in [-max_gradient, max_gradient] per std-dev.
  bool colour_gradients = true;
  double gradient_prior_weight = 0.1;
  float max_gradient = 1.f;
  // Memory bound, in units of kWeightUnitBytes (4 bytes): the fit holds
  // every view's weights at once, a unit per (pixel, Gaussian) pair and per
  // slot of its tiles' tables (about one per Gaussian and tile it reaches),
  // and with colour gradients 24 bytes more per Gaussian in each view (its
  // screen frame, 6 units); 2 GB. The default synth clip has 71 M pairs for
  // analytic, 157 M for pixel-aligned; six 1936x1216 DGP cameras at two
  // times 177 M pairs, twelve views 386 M pairs. A clip whose context views need more is
  // fitted on 1 pixel in k of each view (RefinementStats::pixel_stride; k the smallest that fits,
  // at most max_pixel_stride), with gradients if they fit so, else flat
  // (RefinementStats::flat_fallback); if even flat colours do not fit, the decoded colours are
  // kept: the fit is skipped, never half-done, and RefinementStats says so. So a worker inside its
  // memory limit (8 GiB, half of it scene cache, in deploy/k8s) does not run out on large real
  // clips.
  int64_t max_pairs = 512'000'000;
  int max_pixel_stride = 4;  // In [1, 7].
  // Where > 0, max_pairs is raised (never lowered) to this share of the
  // memory the process may still take when the fit starts
  // (AvailableMemoryBytes(), common/memory_info.h), less what the fit holds
  // besides the weights: its vectors (kFitBytesPerGaussian) and the views'
  // per-pixel arrays (kFitBytesPerPixel). A clip over max_pairs is then
  // fitted on more of its pixels, or with gradients, where the machine has
  // the memory; RefinementStats::max_pairs says the bound used. 0: the bound
  // is max_pairs, whatever the machine.
  double available_memory_share = 0;
  // Where the solve runs (the residuals, sums and iterations over the
  // recorded weights): the CPU, or GPU cuda:N (cuda_colour_fit.h; the
  // weights are recorded on the CPU either way, and the results agree to
  // float rounding).
  ComputeDevice device;
};

// What a refinement did, over the fitted context pixels.
struct RefinementStats {
  int64_t pixels = 0;  // Context pixels in the fit (alpha >= min_alpha).
  int64_t pairs = 0;   // Contributing (pixel, Gaussian) pairs over all views.
  // Memory of the recorded weights and tables (kWeightUnitBytes per unit
  // of max_pairs).
  int64_t weight_bytes = 0;
  // The fit's pixels: 1 in pixel_stride of each view (1: every pixel).
  int pixel_stride = 1;
  // The memory bound the fit ran under, in units of kWeightUnitBytes
  // (RefinementOptions::max_pairs, or more by available_memory_share).
  int64_t max_pairs = 0;
  double rmse_before = 0;  // RGB root mean square error of the renders, [0, 1] units.
  double rmse_after = 0;
  // True when the views needed more than max_pairs pairs and the colours
  // were left as decoded (pairs is then the count when recording stopped).
  bool skipped_over_budget = false;
  // True when colour gradients were asked for but passed max_pairs even at
  // max_pixel_stride, so the colours were fitted flat (skipped_over_budget
  // then says whether even that passed it).
  bool flat_fallback = false;
  // Wall seconds spent recording the views' weights (every attempt at a
  // stride), and in the rest of the fit (its set-up and iterations).
  double record_seconds = 0;
  double solve_seconds = 0;
  bool on_gpu = false;        // The solve ran on RefinementOptions::device's GPU.
  int64_t gpu_bytes = 0;      // GPU memory the solve held.
  double upload_seconds = 0;  // Of solve_seconds: copying the weights to the GPU.
};

// Refines the first three feature channels of `scene` in place against
// `views`. INVALID_ARGUMENT when the scene has fewer than 3 feature channels
// or options are out of range; errors of ComputeCompositingWeights, and of
// the GPU (CudaColourFit: no CUDA in the build, no such GPU, out of its
// memory) for a cuda device, otherwise. `scene` is unchanged on error.
absl::StatusOr<RefinementStats> RefineColours(const std::vector<ContextView>& views,
                                              const RefinementOptions& options,
                                              GaussianScene* scene);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_COLOUR_REFINEMENT_H_
