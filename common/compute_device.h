// A device named by --device: `cpu` or `cuda:N` (`cuda` is `cuda:0`). What
// runs there is each stage's own business (recon/compute_device.h for
// fusion, render/cuda_rasterizer.h for rendering).
#ifndef POINTFORWARD_COMMON_COMPUTE_DEVICE_H_
#define POINTFORWARD_COMMON_COMPUTE_DEVICE_H_

#include <string>

#include "absl/status/statusor.h"

namespace pf {

struct ComputeDevice {
  enum class Kind { kCpu, kCuda };
  Kind kind = Kind::kCpu;
  int index = 0;  // The GPU of kCuda.

  // Returns "cpu" or "cuda:N".
  std::string ToString() const;
  bool operator==(const ComputeDevice&) const = default;
};

// Parses "cpu", "cuda" or "cuda:N". INVALID_ARGUMENT naming `field` (e.g.
// "--device", "options.device") for anything else.
absl::StatusOr<ComputeDevice> ParseComputeDevice(const std::string& spec, const std::string& field);

}  // namespace pf

#endif  // POINTFORWARD_COMMON_COMPUTE_DEVICE_H_
