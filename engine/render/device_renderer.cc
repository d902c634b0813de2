// Rendering on the CPU or a GPU (device_renderer.h).
#include "engine/render/device_renderer.h"

#include <string>

#include "absl/strings/str_cat.h"
#include "engine/render/render_blur.h"

namespace pf {

absl::StatusOr<std::unique_ptr<DeviceRenderer>> DeviceRenderer::Create(const GaussianScene* scene,
                                                                       const ComputeDevice& device,
                                                                       const std::string& field) {
  std::unique_ptr<CudaScene> gpu;
  if (device.kind == ComputeDevice::Kind::kCuda) {
    // Upload checks the scene, then the device.
    absl::StatusOr<std::unique_ptr<CudaScene>> uploaded = CudaScene::Upload(*scene, device.index);
    if (absl::IsFailedPrecondition(uploaded.status())) {
      return absl::FailedPreconditionError(absl::StrCat(
          field, ": '", device.ToString(), "' cannot render: ", uploaded.status().message()));
    }
    if (!uploaded.ok()) return uploaded.status();
    gpu = std::move(*uploaded);
  } else if (absl::Status s = CheckRenderable(*scene); !s.ok()) {
    return s;
  }
  return std::unique_ptr<DeviceRenderer>(new DeviceRenderer(scene, device, std::move(gpu)));
}

absl::StatusOr<RenderBuffers> DeviceRenderer::Render(const RenderCamera& camera,
                                                     int64_t timestamp_us,
                                                     const std::vector<ActorEdit>& edits,
                                                     const RenderOptions& options) const {
  // A blur grown past the scene's leaves the actors at the scene's: that
  // needs the instance ids.
  const float sigma = RenderBlurAt(*scene_, camera);
  const bool actors_apart = sigma > scene_->render_blur && !scene_->instances.empty();
  RenderOptions with_ids = options;
  with_ids.instance = options.instance || actors_apart;
  // The CUDA rasterizer has no rolling shutter: such views render on the CPU.
  absl::StatusOr<RenderBuffers> out =
      gpu_ != nullptr && !camera.rolling_shutter.has_value()
          ? gpu_->Render(camera, timestamp_us, edits, with_ids)
          : pf::Render(*scene_, camera, timestamp_us, edits, with_ids);
  if (!out.ok()) return out;
  BlurRender(sigma, scene_->render_blur, &*out);
  if (!options.instance) out->instance.clear();
  return out;
}

}  // namespace pf
