// Where the batched tensor work of a reconstruction runs: `--device cpu` or
// `--device cuda:N` (`cuda` is `cuda:0`).
//
// In a build with LibTorch (CMake finds it; PF_TORCH=OFF leaves it out),
// fusion runs as LibTorch tensor work on the chosen device
// (tensor_fusion.h). Without LibTorch only `cpu` exists, and fusion runs the
// plain C++ kernel of fusion.h. Where the build has CUDA the colour fit's
// solve runs on the same GPU (cuda_colour_fit.h). The other per-pixel kernels
// (depth completion, sampling, recording the fit's weights) are C++ on the
// CPU either way.
//
//   ASSIGN_OR_RETURN(ComputeDevice device, ParseComputeDevice(flag, "--device"));
//   RETURN_IF_ERROR(CheckComputeDevice(device, "--device"));
#ifndef POINTFORWARD_ENGINE_RECON_COMPUTE_DEVICE_H_
#define POINTFORWARD_ENGINE_RECON_COMPUTE_DEVICE_H_

#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "common/compute_device.h"

namespace pf {

// Returns true when this build runs fusion with LibTorch.
bool HaveTensorBackend();

// Returns a line naming the tensor backend: "LibTorch 1.13.1 (CUDA: 0 GPUs)"
// or "none (plain C++ on the CPU)".
std::string TensorBackendDescription();

// Returns OK when `device` can run work in this process, FAILED_PRECONDITION
// naming `field` and saying why not otherwise (no LibTorch in this build, a
// LibTorch without CUDA, no GPU N).
absl::Status CheckComputeDevice(const ComputeDevice& device, const std::string& field);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_COMPUTE_DEVICE_H_
