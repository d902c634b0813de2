// Rendering on the CPU or a GPU (device_renderer.h).
#include "worker/engine/render/device_renderer.h"

#include <string>

#include "absl/strings/str_cat.h"

namespace pf {

absl::StatusOr<std::unique_ptr<DeviceRenderer>> DeviceRenderer::Create(const GaussianScene* scene,
                                                                       const ComputeDevice& device,
                                                                       const std::string& field) {
  if (absl::Status s = CheckRenderable(*scene); !s.ok()) return s;
  std::unique_ptr<CudaScene> gpu;
  if (device.kind == ComputeDevice::Kind::kCuda) {
    if (absl::Status s = CheckCudaDevice(device.index); !s.ok()) {
      return absl::FailedPreconditionError(
          absl::StrCat(field, ": '", device.ToString(), "' cannot render: ", s.message()));
    }
    absl::StatusOr<std::unique_ptr<CudaScene>> uploaded = CudaScene::Upload(*scene, device.index);
    if (!uploaded.ok()) return uploaded.status();
    gpu = std::move(*uploaded);
  }
  return std::unique_ptr<DeviceRenderer>(new DeviceRenderer(scene, device, std::move(gpu)));
}

absl::StatusOr<RenderBuffers> DeviceRenderer::Render(const RenderCamera& camera,
                                                     int64_t timestamp_us,
                                                     const std::vector<ActorEdit>& edits,
                                                     const RenderOptions& options) const {
  if (gpu_ != nullptr) return gpu_->Render(camera, timestamp_us, edits, options);
  return pf::Render(*scene_, camera, timestamp_us, edits, options);
}

}  // namespace pf
