// The GPU colour fit's functions in a build without CUDA: each says so.
#include "engine/recon/cuda_colour_fit.h"
#include "engine/render/cuda_rasterizer.h"

namespace pf {

struct CudaColourFit::Impl {};

bool HaveCudaColourFit() { return false; }

CudaColourFit::CudaColourFit(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
CudaColourFit::~CudaColourFit() = default;
size_t CudaColourFit::device_bytes() const { return 0; }

absl::StatusOr<std::unique_ptr<CudaColourFit>> CudaColourFit::Upload(
    const std::vector<ColourFitView>&, size_t, bool, int device) {
  return CheckCudaDevice(device);  // Says the build has no CUDA.
}

absl::StatusOr<ChannelSums> CudaColourFit::Residual(const std::vector<float>&, bool) {
  return CheckCudaDevice(0);
}

absl::StatusOr<std::vector<float>> CudaColourFit::Sums() { return CheckCudaDevice(0); }

absl::Status CudaColourFit::Solve(const std::vector<float>&, const std::vector<float>&, int,
                                  std::vector<float>*) {
  return CheckCudaDevice(0);
}

}  // namespace pf
