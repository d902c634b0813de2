// Parsing and checking of --device.
#include "engine/recon/compute_device.h"

#include "absl/strings/str_cat.h"

#if PF_HAVE_TORCH
#include <torch/cuda.h>
#include <torch/version.h>
#endif

namespace pf {

#if PF_HAVE_TORCH

bool HaveTensorBackend() { return true; }

std::string TensorBackendDescription() {
  const int gpus = torch::cuda::is_available() ? static_cast<int>(torch::cuda::device_count()) : 0;
  return absl::StrCat("LibTorch ", TORCH_VERSION, " (CUDA GPUs: ", gpus, ")");
}

absl::Status CheckComputeDevice(const ComputeDevice& device, const std::string& field) {
  if (device.kind == ComputeDevice::Kind::kCpu) return absl::OkStatus();
  if (!torch::cuda::is_available()) {
    return absl::FailedPreconditionError(
        absl::StrCat(field, ": '", device.ToString(), "' is not available: this LibTorch (",
                     TORCH_VERSION, ") sees no CUDA GPU (a CPU-only build, or no GPU/driver)"));
  }
  const int gpus = static_cast<int>(torch::cuda::device_count());
  if (device.index >= gpus) {
    return absl::FailedPreconditionError(absl::StrCat(field, ": '", device.ToString(),
                                                      "' is not available: this machine has ", gpus,
                                                      gpus == 1 ? " GPU" : " GPUs"));
  }
  return absl::OkStatus();
}

#else  // !PF_HAVE_TORCH

bool HaveTensorBackend() { return false; }

std::string TensorBackendDescription() { return "none (plain C++ on the CPU)"; }

absl::Status CheckComputeDevice(const ComputeDevice& device, const std::string& field) {
  if (device.kind == ComputeDevice::Kind::kCpu) return absl::OkStatus();
  return absl::FailedPreconditionError(
      absl::StrCat(field, ": '", device.ToString(),
                   "' is not available: this build has no LibTorch (configure with LibTorch "
                   "installed to run fusion on a GPU)"));
}

#endif  // PF_HAVE_TORCH

}  // namespace pf
