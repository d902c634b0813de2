// The CUDA rasterizer's functions in a build without CUDA: each says so.
#include "engine/render/cuda_rasterizer.h"

namespace pf {
namespace {

absl::Status NoCuda() {
  return absl::FailedPreconditionError(
      "this build has no CUDA rasterizer (CMake found no nvcc, or PF_CUDA=OFF): rebuild on a "
      "machine with the CUDA toolkit, or use --device cpu");
}

}  // namespace

struct CudaScene::Impl {};

bool HaveCudaRasterizer() { return false; }
absl::Status CheckCudaDevice(int) { return NoCuda(); }
std::string CudaDeviceDescription(int) { return std::string(NoCuda().message()); }

CudaScene::CudaScene(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
CudaScene::~CudaScene() = default;
int CudaScene::device() const { return 0; }
size_t CudaScene::size() const { return 0; }
size_t CudaScene::device_bytes() const { return 0; }

absl::StatusOr<std::unique_ptr<CudaScene>> CudaScene::Upload(const GaussianScene& scene, int) {
  if (absl::Status s = CheckRenderable(scene); !s.ok()) return s;
  return NoCuda();
}

absl::StatusOr<RenderBuffers> CudaScene::Render(const RenderCamera&, int64_t,
                                                const std::vector<ActorEdit>&, const RenderOptions&,
                                                CudaRenderTiming*) const {
  return NoCuda();
}

}  // namespace pf
