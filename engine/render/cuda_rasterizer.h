// The rasterizer on an NVIDIA GPU: the same projection (splat_projection.h),
// the same tile binning and depth order, and the same front-to-back
// compositing as Render() (rasterizer.h), written as CUDA kernels
// (cuda_rasterizer.cu). Every output of Render() (features, RGB, alpha,
// depth, instance ids; lifespans, instance motion and actor edits) with the
// same meaning; values agree with the CPU path to float rounding (the
// exponential and the summation order of a pixel differ in the last bits).
//
// A build without CUDA (CMake found no nvcc, or PF_CUDA=OFF) has the same
// functions; they report that the build has no CUDA.
//
//   ASSIGN_OR_RETURN(std::unique_ptr<CudaScene> gpu, CudaScene::Upload(scene, 0));
//   ASSIGN_OR_RETURN(RenderBuffers out, gpu->Render(camera, timestamp_us, edits));
#ifndef POINTFORWARD_ENGINE_RENDER_CUDA_RASTERIZER_H_
#define POINTFORWARD_ENGINE_RENDER_CUDA_RASTERIZER_H_

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "engine/render/gaussian_scene.h"
#include "engine/render/rasterizer.h"

namespace pf {

// True when this build has the CUDA rasterizer.
bool HaveCudaRasterizer();

// OK when GPU `device` can render in this process; FAILED_PRECONDITION
// saying why not (no CUDA in this build, no driver, fewer GPUs) otherwise.
absl::Status CheckCudaDevice(int device);

// Returns "NVIDIA H100 80GB HBM3 (sm_90, 132 SMs, 79.2 GiB)" for `device`,
// or why it cannot be named.
std::string CudaDeviceDescription(int device);

// Where the time of one GPU render went.
struct CudaRenderTiming {
  double device_ms = 0;    // From the first kernel to the last (CUDA events).
  double download_ms = 0;  // Copying the outputs to host memory.
};

// A Gaussian scene held in a GPU's memory, rendered there. Upload once,
// render many views. Render() may be called from any thread; calls on one
// CudaScene run one at a time (they share its work buffers).
class CudaScene {
 public:
  ~CudaScene();
  CudaScene(const CudaScene&) = delete;
  CudaScene& operator=(const CudaScene&) = delete;

  // Copies `scene` to GPU `device`. INVALID_ARGUMENT as CheckRenderable(),
  // FAILED_PRECONDITION as CheckCudaDevice(), RESOURCE_EXHAUSTED when the
  // GPU's memory is too small.
  static absl::StatusOr<std::unique_ptr<CudaScene>> Upload(const GaussianScene& scene, int device);

  int device() const;
  size_t size() const;
  // Bytes of GPU memory held: the scene and the work buffers of the
  // largest render so far.
  size_t device_bytes() const;

  // Render() of the uploaded scene on the GPU: the same arguments, outputs
  // and errors. `timing` (may be null) receives where the time went.
  absl::StatusOr<RenderBuffers> Render(const RenderCamera& camera, int64_t timestamp_us,
                                       const std::vector<ActorEdit>& edits,
                                       const RenderOptions& options = {},
                                       CudaRenderTiming* timing = nullptr) const;

 private:
  struct Impl;
  explicit CudaScene(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RENDER_CUDA_RASTERIZER_H_
