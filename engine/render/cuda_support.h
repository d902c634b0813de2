// What the CUDA sources share (included by .cu files only): CUDA errors as
// absl::Status, a growing device allocation, and launch arithmetic.
#ifndef POINTFORWARD_ENGINE_RENDER_CUDA_SUPPORT_H_
#define POINTFORWARD_ENGINE_RENDER_CUDA_SUPPORT_H_

#include <cuda_runtime.h>

#include <algorithm>
#include <cstddef>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace pf::cuda {

// OK for cudaSuccess; else RESOURCE_EXHAUSTED (out of memory) or INTERNAL
// naming `what` and the error. Clears a non-sticky error.
inline absl::Status CudaError(cudaError_t error, const char* what) {
  if (error == cudaSuccess) return absl::OkStatus();
  const std::string message = absl::StrCat("CUDA: ", what, ": ", cudaGetErrorName(error), " (",
                                           cudaGetErrorString(error), ")");
  cudaGetLastError();
  if (error == cudaErrorMemoryAllocation) return absl::ResourceExhaustedError(message);
  return absl::InternalError(message);
}

#define PF_CUDA_RETURN_IF_ERROR(call)                                                         \
  do {                                                                                        \
    if (absl::Status cuda_status = ::pf::cuda::CudaError((call), #call); !cuda_status.ok()) { \
      return cuda_status;                                                                     \
    }                                                                                         \
  } while (false)

// A device allocation that only grows.
template <typename T>
struct DeviceBuffer {
  T* data = nullptr;
  size_t capacity = 0;  // Elements.

  DeviceBuffer() = default;
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;
  ~DeviceBuffer() { cudaFree(data); }
  absl::Status Reserve(size_t n) {
    if (n <= capacity) return absl::OkStatus();
    cudaFree(data);
    data = nullptr;
    capacity = 0;
    PF_CUDA_RETURN_IF_ERROR(cudaMalloc(&data, std::max<size_t>(n, 1) * sizeof(T)));
    capacity = n;
    return absl::OkStatus();
  }
  absl::Status Upload(const std::vector<T>& host) {
    if (absl::Status s = Reserve(host.size()); !s.ok()) return s;
    if (host.empty()) return absl::OkStatus();
    return CudaError(cudaMemcpy(data, host.data(), host.size() * sizeof(T), cudaMemcpyHostToDevice),
                     "cudaMemcpy to the GPU");
  }
  size_t bytes() const { return capacity * sizeof(T); }
};

// Blocks of `threads` covering `n` items.
inline int CeilDiv(size_t n, int threads) { return static_cast<int>((n + threads - 1) / threads); }

}  // namespace pf::cuda

#endif  // POINTFORWARD_ENGINE_RENDER_CUDA_SUPPORT_H_
