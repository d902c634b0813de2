// The colour fit's solve (colour_refinement.h) on an NVIDIA GPU. The CPU
// records every context view's compositing weights as before; this holds
// them, the fitted pixels and the images in GPU memory and runs there what
// the CPU solve runs over them: the residual, each Gaussian's sums (the
// preconditioner's blocks are built from them on the host) and the
// preconditioned conjugate-gradient iterations, one thread per fitted pixel
// for the products with A and A^T (the transposed sums by atomic adds) and
// one per Gaussian for the vector updates. The atomic sums run in an order
// that changes from run to run, so results agree with the CPU solve (and with
// another GPU run) to float rounding amplified by the iterations: residuals
// within 1e-3 relative, colours the views determine within 2e-4 on the
// default synth clip, up to 0.02 for colours they barely determine (renders
// of the two fits over 85 dB apart; cuda_colour_fit_test).
//
// A build without CUDA has the same functions; they say it has none.
//
//   ASSIGN_OR_RETURN(std::unique_ptr<CudaColourFit> gpu,
//                    CudaColourFit::Upload(views, scene.size(), textured, 0));
//   ASSIGN_OR_RETURN(ChannelSums before, gpu->Residual(x, true));
//   ASSIGN_OR_RETURN(std::vector<float> sums, gpu->Sums());
//   RETURN_IF_ERROR(gpu->Solve(prior, inverse, iterations, &x));
#ifndef POINTFORWARD_ENGINE_RECON_CUDA_COLOUR_FIT_H_
#define POINTFORWARD_ENGINE_RECON_CUDA_COLOUR_FIT_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "engine/render/compositing_weights.h"

namespace pf {

// True when this build has the GPU colour fit (CMake found nvcc).
bool HaveCudaColourFit();

// One context view's share of the fit: its weights (with local coordinates
// when the fit is textured), which pixels are fitted and the image.
struct ColourFitView {
  const CompositingWeights* weights = nullptr;
  const uint8_t* fitted = nullptr;  // [H * W] non-zero: the pixel is in the fit (the mask M).
  const float* image = nullptr;     // [H * W, 3]
};

// Per RGB channel.
using ChannelSums = std::array<double, 3>;

// The fit's system in GPU memory. The unknowns x are [N, 3, K] as in
// colour_refinement.cc: per Gaussian and RGB channel the colour and, when
// textured (K = 3), its gradients (g_u, g_v); K = 1 otherwise.
class CudaColourFit {
 public:
  ~CudaColourFit();
  CudaColourFit(const CudaColourFit&) = delete;
  CudaColourFit& operator=(const CudaColourFit&) = delete;

  // Copies the views to GPU `device`. INVALID_ARGUMENT when a view's arrays
  // disagree or a textured fit's weights lack local coordinates;
  // FAILED_PRECONDITION for a GPU older than compute capability 8.0 (the
  // kernels are built for 8.0 and newer);
  // FAILED_PRECONDITION when the GPU cannot be used (CheckCudaDevice);
  // RESOURCE_EXHAUSTED when its memory is too small.
  static absl::StatusOr<std::unique_ptr<CudaColourFit>> Upload(
      const std::vector<ColourFitView>& views, size_t num_gaussians, bool textured, int device);

  size_t device_bytes() const;  // GPU memory held.

  // Sum over the fitted pixels of (I - A x)^2, per channel. With `start`,
  // also keeps x and the residual A^T M (I - A x) on the GPU as the start of
  // Solve().
  absl::StatusOr<ChannelSums> Residual(const std::vector<float>& x, bool start);

  // Each Gaussian's colour_fit::kSums sums over the fitted pixels, [N, kSums].
  absl::StatusOr<std::vector<float>> Sums();

  // `iterations` of conjugate gradients on (A^T M A + diag(prior)) x =
  // A^T M I + diag(prior) x0 from the x of the last Residual(x0, true),
  // preconditioned by `inverse` (per Gaussian, colour_fit::PreconditionBlock's
  // 1 or 6 floats); writes the result to `x`. FAILED_PRECONDITION without a
  // started residual.
  absl::Status Solve(const std::vector<float>& prior, const std::vector<float>& inverse,
                     int iterations, std::vector<float>* x);

 private:
  struct Impl;
  explicit CudaColourFit(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_CUDA_COLOUR_FIT_H_
