// Renders one scene on the device that --device names: the CPU rasterizer
// (rasterizer.h), or the CUDA one with the scene uploaded to the GPU once
// (cuda_rasterizer.h). The same outputs either way, blurred by the scene's
// render blur at the camera (render_blur.h RenderBlurAt, the actors at the
// scene's render_blur; Render() of rasterizer.h draws them unblurred).
//
//   ASSIGN_OR_RETURN(auto renderer, DeviceRenderer::Create(&scene, device));
//   ASSIGN_OR_RETURN(RenderBuffers out, renderer->Render(camera, t, edits, options));
#ifndef POINTFORWARD_ENGINE_RENDER_DEVICE_RENDERER_H_
#define POINTFORWARD_ENGINE_RENDER_DEVICE_RENDERER_H_

#include <cstdint>
#include <memory>
#include <vector>

#include "absl/status/statusor.h"
#include "common/compute_device.h"
#include "engine/render/cuda_rasterizer.h"
#include "engine/render/gaussian_scene.h"
#include "engine/render/rasterizer.h"

namespace pf {

class DeviceRenderer {
 public:
  // `scene` must outlive the renderer. INVALID_ARGUMENT as
  // CheckRenderable(); for a GPU, FAILED_PRECONDITION naming `field` when it
  // cannot be used (no CUDA in this build, no such GPU) and the errors of
  // CudaScene::Upload.
  static absl::StatusOr<std::unique_ptr<DeviceRenderer>> Create(const GaussianScene* scene,
                                                                const ComputeDevice& device,
                                                                const std::string& field);

  // Render() of the scene on the device.
  absl::StatusOr<RenderBuffers> Render(const RenderCamera& camera, int64_t timestamp_us,
                                       const std::vector<ActorEdit>& edits,
                                       const RenderOptions& options = {}) const;

  const ComputeDevice& device() const { return device_; }
  const GaussianScene& scene() const { return *scene_; }

 private:
  DeviceRenderer(const GaussianScene* scene, const ComputeDevice& device,
                 std::unique_ptr<CudaScene> gpu)
      : scene_(scene), device_(device), gpu_(std::move(gpu)) {}

  const GaussianScene* scene_;
  ComputeDevice device_;
  std::unique_ptr<CudaScene> gpu_;  // Set for a GPU.
};

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RENDER_DEVICE_RENDERER_H_
