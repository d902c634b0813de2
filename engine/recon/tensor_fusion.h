// Spatial-temporal fusion (fusion.h) as batched LibTorch tensor work on a
// chosen device, so that the same code runs on CPU and GPU workers.
//
// The rules are fusion.h's, step for step: every query is moved by its
// frame's camera-from-frame transform of each view (instances re-posed to the
// view's time), projected through the view's camera model (pinhole, OpenCV,
// fisheye or f-theta), tested against the view's depth (observation, occlusion, or seen
// past across the 3x3 neighbourhood, which here is a 3x3 min-pool of the
// depth map), weighed, and its colour sampled bilinearly. Geometry runs in
// float64 as the C++ kernel does, so both give the same observations and
// colours equal to float rounding (tensor_fusion_test.cc compares them).
//
// Queries go through in batches so memory stays bounded (about 1 KB per
// query in flight). On the CPU, ATen runs single-threaded and the batches run
// in parallel on DefaultThreadPool(); on a GPU they run one after another.
#ifndef POINTFORWARD_ENGINE_RECON_TENSOR_FUSION_H_
#define POINTFORWARD_ENGINE_RECON_TENSOR_FUSION_H_

#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "engine/recon/compute_device.h"
#include "engine/recon/fusion.h"

namespace pf {

// Queries per batch, by default.
inline constexpr int64_t kCpuFusionBatch = 1 << 17;
inline constexpr int64_t kGpuFusionBatch = 1 << 20;

// Camera-frame points (x, y, z) projected by the tensor kernel's copy of
// the camera models (float64, on the CPU): the pixel (u, v) and whether
// CameraModel::Project would accept the point. tensor_fusion_test.cc pins
// it to CameraModel for every lens.
struct TensorProjection {
  std::vector<double> u, v;
  std::vector<bool> valid;
};
TensorProjection ProjectWithTensors(const CameraModel& camera, const std::vector<double>& x,
                                    const std::vector<double>& y, const std::vector<double>& z);

// Fuses `queries` over `views` on `device` as FuseQueries does, `batch`
// queries at a time (0: the device's default above). FAILED_PRECONDITION
// when the device is not available; INTERNAL, with LibTorch's message, if
// LibTorch throws.
absl::StatusOr<FusedQueries> FuseQueriesOnDevice(const QuerySet& queries,
                                                 const std::vector<FusionView>& views,
                                                 const std::vector<InstanceTrack>& tracks,
                                                 const FusionOptions& options,
                                                 const ComputeDevice& device, int64_t batch = 0);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_TENSOR_FUSION_H_
