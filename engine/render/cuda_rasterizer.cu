// The CUDA rasterizer (cuda_rasterizer.h). The passes of Render() on a GPU:
//  1. Project, one thread per Gaussian (splat_projection.h's ProjectSplat,
//     SH colour, screen colour gradients), and count the 16x16 tiles the
//     ellipse touches (VisitTiles, the CPU binning's exact test).
//  2. An exclusive scan of the counts gives each Gaussian its slots; a second
//     visit writes (tile << 32 | depth bits, index) pairs into them, in index
//     order.
//  3. One stable radix sort of the pairs: each tile's list in depth order,
//     ties in index order, as the CPU's.
//  4. Composite: a block of 256 threads per tile, a thread per pixel; the
//     tile's Gaussians are staged through shared memory 256 at a time, front
//     to back, each pixel stopping once its transmittance falls under 1e-4
//     and the block once all its pixels have. Channels are blended K at a
//     time (3, or 8 for wider features), one launch per group; the first
//     launch also writes alpha, depth and instance ids.
#include <cuda_runtime.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_scan.cuh>
#include <mutex>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "engine/render/cuda_rasterizer.h"
#include "engine/render/cuda_support.h"
#include "engine/render/raster_frame.h"
#include "engine/render/raster_sh.h"
#include "engine/render/raster_tile.h"
#include "engine/render/splat_projection.h"

namespace pf {
namespace {

using raster::kMaxAlpha;
using raster::kMinAlpha;
using raster::kMinTransmittance;
using raster::kTile;
using raster::kTilePixels;
using raster::Projected;

using cuda::CeilDiv;
using cuda::CudaError;
using cuda::DeviceBuffer;

// Per owner (0 background, k instance k), as the kernels read it.
struct OwnerPose {
  float r[9];
  float t[3];
  float eye[3];
  uint32_t live;
};

struct ProjectArgs {
  size_t n;
  raster::SplatArrays arrays;
  raster::ProjectionCamera camera;  // camera.lens is plain numbers.
  int tiles_x;
  const uint32_t* owners;
  const OwnerPose* poses;
  const float* sh;  // [N, 3, coeffs] or null.
  int sh_degree;
  const float* colour_gradients;  // [N, 6] or null.
  Projected* projected;
  float* screen_gradients;  // [N, 6] when colour_gradients.
  float* sh_rgb;            // [N, 3] when sh.
  uint64_t* tiles_touched;  // [N]
  unsigned long long* visible;
};

// Projects Gaussian i; returns the number of tiles it touches (0: unseen).
__device__ uint64_t ProjectOne(const ProjectArgs& a, size_t i) {
  a.tiles_touched[i] = 0;
  const uint32_t owner = a.owners[i];
  const OwnerPose& pose = a.poses[owner];
  if (!pose.live) return 0;
  raster::SplatGeometry g;
  if (!raster::ProjectSplat(a.arrays, i, a.camera, pose.r, pose.t, &g)) return 0;
  a.projected[i] = raster::ToProjected(g, owner);
  if (a.colour_gradients != nullptr) {
    raster::ScreenColourGradients(a.colour_gradients + 6 * i, g, a.screen_gradients + 6 * i);
  }
  if (a.sh != nullptr) {
    const int coeffs = (a.sh_degree + 1) * (a.sh_degree + 1);
    raster::EvalShColorFrom(a.sh + i * 3 * coeffs, a.sh_degree, a.arrays.means + 3 * i, pose.eye,
                            a.sh_rgb + 3 * i);
  }
  uint64_t count = 0;
  raster::VisitTiles(g.mx, g.my, g.ca, g.cb, g.cc, g.span_d2, g.ext_x, g.ext_y, a.camera.width,
                     a.camera.height, a.tiles_x, [&](uint32_t) { ++count; });
  a.tiles_touched[i] = count;
  return count;
}

__global__ void ProjectKernel(ProjectArgs a) {
  const size_t i = blockIdx.x * static_cast<size_t>(blockDim.x) + threadIdx.x;
  const uint64_t count = i < a.n ? ProjectOne(a, i) : 0;
  // One atomic per warp for the visible count.
  const unsigned seen = __ballot_sync(0xffffffffu, count > 0);
  if (threadIdx.x % 32 == 0 && seen != 0) atomicAdd(a.visible, __popc(seen));
}

struct EmitArgs {
  size_t n;
  int width, height, tiles_x;
  const Projected* projected;
  const uint64_t* tiles_touched;
  const uint64_t* offsets;
  uint64_t* keys;
  uint32_t* values;
  float order_band;  // GaussianScene::order_band.
};

__global__ void EmitKernel(EmitArgs a) {
  const size_t i = blockIdx.x * static_cast<size_t>(blockDim.x) + threadIdx.x;
  if (i >= a.n || a.tiles_touched[i] == 0) return;
  const Projected& g = a.projected[i];
  const uint32_t depth_bits =
      raster::SortDepthBits(g.depth, static_cast<uint32_t>(i), a.order_band);
  uint64_t slot = a.offsets[i];
  raster::VisitTiles(g.mx, g.my, g.ca, g.cb, g.cc, g.span_d2, g.ext_x, g.ext_y, a.width, a.height,
                     a.tiles_x, [&](uint32_t tile) {
                       a.keys[slot] = (static_cast<uint64_t>(tile) << 32) | depth_bits;
                       a.values[slot] = static_cast<uint32_t>(i);
                       ++slot;
                     });
}

// ranges[t] = [begin, end) of tile t's pairs in the sorted keys.
__global__ void RangesKernel(const uint64_t* keys, uint64_t num_pairs, uint2* ranges) {
  const uint64_t k = blockIdx.x * static_cast<uint64_t>(blockDim.x) + threadIdx.x;
  if (k >= num_pairs) return;
  const uint32_t tile = static_cast<uint32_t>(keys[k] >> 32);
  if (k == 0 || static_cast<uint32_t>(keys[k - 1] >> 32) != tile) ranges[tile].x = k;
  if (k + 1 == num_pairs || static_cast<uint32_t>(keys[k + 1] >> 32) != tile) {
    ranges[tile].y = k + 1;
  }
}

struct CompositeArgs {
  int width, height, tiles_x;
  const uint2* ranges;
  const uint32_t* values;  // Gaussian indices, per tile front to back.
  const Projected* projected;
  const float* source;  // [N, source_stride] channel values.
  int source_stride;
  int first, count;        // Channels [first, first + count) of source.
  const float* gradients;  // [N, 6] screen gradients of channels 0..2, or null.
  float* out;              // [H, W, out_stride], channel first + c at first + c.
  int out_stride;
  float* rgb;                    // [H, W, 3] copy of channels 0..2, or null.
  bool primary;                  // Also write alpha, depth, instance ids, counters.
  float* alpha;                  // [H, W]
  float* depth;                  // [H, W] or null.
  uint32_t* instance;            // [H, W] or null.
  unsigned long long* counters;  // [2]: pairs tested, pairs contributing.
};

template <int K>
__global__ void __launch_bounds__(kTilePixels) CompositeKernel(CompositeArgs a) {
  constexpr float kMinusHalfLog2e = -0.72134752044448170f;
  constexpr int kVectors = (K + 3) / 4;  // float4s of channel values per Gaussian.
  // The staged batch, packed so that a pixel reads each Gaussian with a few
  // wide (broadcast) loads.
  __shared__ float4 s_centre_conic[kTilePixels];  // mx, my, ca, cb
  __shared__ float4 s_rest[kTilePixels];          // cc, opacity, span_d2, depth
  __shared__ uint32_t s_owner[kTilePixels];
  __shared__ float4 s_value[kTilePixels][kVectors];
  __shared__ float s_grad[kTilePixels][6];
  __shared__ unsigned long long s_counts[2];
  const int tile = blockIdx.x;
  const int t = threadIdx.x;
  const int px = (tile % a.tiles_x) * kTile + t % kTile;
  const int py = (tile / a.tiles_x) * kTile + t / kTile;
  const bool inside = px < a.width && py < a.height;
  const float fx = px + 0.5f, fy = py + 0.5f;
  const uint2 range = a.ranges[tile];
  const bool gradients = a.gradients != nullptr && a.first < 3;
  if (t < 2) s_counts[t] = 0;

  float trans = 1.f;
  float acc[K];
  for (int c = 0; c < K; ++c) acc[c] = 0.f;
  float acc_depth = 0.f, best_weight = 0.f;
  uint32_t best_owner = 0;
  unsigned tested = 0, contributing = 0;
  bool done = !inside;

  for (uint32_t start = range.x; start < range.y; start += kTilePixels) {
    if (__syncthreads_count(done) == kTilePixels) break;
    const uint32_t k = start + t;
    if (k < range.y) {
      const uint32_t i = a.values[k];
      const Projected& g = a.projected[i];
      s_centre_conic[t] = make_float4(g.mx, g.my, g.ca, g.cb);
      s_rest[t] = make_float4(g.cc, g.opacity, g.span_d2, g.depth);
      s_owner[t] = g.owner;
      const float* v = a.source + static_cast<size_t>(i) * a.source_stride + a.first;
      float* staged = reinterpret_cast<float*>(&s_value[t][0]);
      for (int c = 0; c < 4 * kVectors; ++c) staged[c] = c < a.count ? v[c] : 0.f;
      if (gradients) {
        for (int c = 0; c < 6; ++c) s_grad[t][c] = a.gradients[6 * static_cast<size_t>(i) + c];
      }
    }
    __syncthreads();
    const int batch = static_cast<int>(min(range.y - start, static_cast<uint32_t>(kTilePixels)));
    for (int j = 0; j < batch && !done; ++j) {
      const float4 g = s_centre_conic[j];
      const float4 r = s_rest[j];
      const float dx = fx - g.x;
      const float dy = fy - g.y;
      const float d2 = g.z * dx * dx + 2.f * g.w * dy * dx + r.x * dy * dy;
      if (d2 > r.z) continue;
      ++tested;
      const float alpha = fminf(kMaxAlpha, r.y * exp2f(d2 * kMinusHalfLog2e));
      if (alpha < kMinAlpha) continue;
      ++contributing;
      const float weight = alpha * trans;
      float value[4 * kVectors];
      for (int q = 0; q < kVectors; ++q) {
        const float4 v = s_value[j][q];
        value[4 * q] = v.x, value[4 * q + 1] = v.y, value[4 * q + 2] = v.z, value[4 * q + 3] = v.w;
      }
      if (gradients) {
        for (int c = 0; c + a.first < 3 && c < K; ++c) {
          const int channel = a.first + c;
          value[c] = (value[c] + s_grad[j][2 * channel + 1] * dy) + s_grad[j][2 * channel] * dx;
        }
      }
      for (int c = 0; c < K; ++c) acc[c] += weight * value[c];
      acc_depth += weight * r.w;
      if (weight > best_weight) {
        best_weight = weight;
        best_owner = s_owner[j];
      }
      trans *= 1.f - alpha;
      if (trans < kMinTransmittance) done = true;
    }
  }

  if (inside) {
    const size_t pixel = static_cast<size_t>(py) * a.width + px;
    for (int c = 0; c < K && c < a.count; ++c) {
      a.out[pixel * a.out_stride + a.first + c] = acc[c];
      if (a.rgb != nullptr && a.first + c < 3) a.rgb[pixel * 3 + a.first + c] = acc[c];
    }
    if (a.primary) {
      const float alpha = 1.f - trans;
      a.alpha[pixel] = alpha;
      if (a.depth != nullptr) a.depth[pixel] = alpha > 0 ? acc_depth / alpha : 0.f;
      if (a.instance != nullptr) a.instance[pixel] = best_owner;
    }
  }
  if (a.primary) {
    __syncthreads();
    atomicAdd(&s_counts[0], static_cast<unsigned long long>(tested));
    atomicAdd(&s_counts[1], static_cast<unsigned long long>(contributing));
    __syncthreads();
    if (t == 0) {
      atomicAdd(&a.counters[0], s_counts[0]);
      atomicAdd(&a.counters[1], s_counts[1]);
    }
  }
}

}  // namespace

struct CudaScene::Impl {
  int device = 0;
  size_t n = 0;
  int num_channels = 3;
  int sh_degree = -1;
  int64_t time_origin_us = 0;
  FadeSpan fade_span;
  std::vector<InstanceTrack> instances;
  float low_pass = 0;
  float order_band = 0;
  // The scene.
  DeviceBuffer<float> means, rotations, log_scales, opacity_logits, times, lifespans, features, sh,
      colour_gradients;
  DeviceBuffer<uint32_t> owners;
  // Work buffers, grown as needed.
  mutable std::mutex mutex;
  mutable DeviceBuffer<Projected> projected;
  mutable DeviceBuffer<float> screen_gradients, sh_rgb;
  mutable DeviceBuffer<uint64_t> tiles_touched, offsets, keys, keys_sorted;
  mutable DeviceBuffer<uint32_t> values, values_sorted;
  mutable DeviceBuffer<unsigned char> temp;
  mutable DeviceBuffer<uint2> ranges;
  mutable DeviceBuffer<OwnerPose> poses;
  mutable DeviceBuffer<unsigned long long> counters;  // visible, tested, contributing
  mutable DeviceBuffer<float> out_features, out_rgb, out_alpha, out_depth;
  mutable DeviceBuffer<uint32_t> out_instance;
  cudaStream_t stream = nullptr;
  cudaEvent_t start = nullptr, stop = nullptr;

  ~Impl() {
    if (start != nullptr) cudaEventDestroy(start);
    if (stop != nullptr) cudaEventDestroy(stop);
    if (stream != nullptr) cudaStreamDestroy(stream);
  }

  size_t Bytes() const {
    return means.bytes() + rotations.bytes() + log_scales.bytes() + opacity_logits.bytes() +
           times.bytes() + lifespans.bytes() + features.bytes() + sh.bytes() +
           colour_gradients.bytes() + owners.bytes() + projected.bytes() +
           screen_gradients.bytes() + sh_rgb.bytes() + tiles_touched.bytes() + offsets.bytes() +
           keys.bytes() + keys_sorted.bytes() + values.bytes() + values_sorted.bytes() +
           temp.bytes() + ranges.bytes() + poses.bytes() + counters.bytes() + out_features.bytes() +
           out_rgb.bytes() + out_alpha.bytes() + out_depth.bytes() + out_instance.bytes();
  }

  absl::StatusOr<RenderBuffers> Render(const RenderCamera& camera, int64_t timestamp_us,
                                       const std::vector<ActorEdit>& edits,
                                       const RenderOptions& options,
                                       CudaRenderTiming* timing) const;
};

bool HaveCudaRasterizer() { return true; }

absl::Status CheckCudaDevice(int device) {
  int count = 0;
  const cudaError_t error = cudaGetDeviceCount(&count);
  if (error != cudaSuccess) {
    cudaGetLastError();
    return absl::FailedPreconditionError(
        absl::StrCat("no CUDA GPU usable: ", cudaGetErrorString(error)));
  }
  if (device < 0 || device >= count) {
    return absl::FailedPreconditionError(
        absl::StrCat("no GPU cuda:", device, ": this machine has ", count, " CUDA GPU(s)"));
  }
  return absl::OkStatus();
}

std::string CudaDeviceDescription(int device) {
  if (absl::Status s = CheckCudaDevice(device); !s.ok()) return std::string(s.message());
  cudaDeviceProp prop;
  if (cudaGetDeviceProperties(&prop, device) != cudaSuccess) {
    cudaGetLastError();
    return "unknown GPU";
  }
  return absl::StrFormat("%s (sm_%d%d, %d SMs, %.1f GiB)", prop.name, prop.major, prop.minor,
                         prop.multiProcessorCount,
                         static_cast<double>(prop.totalGlobalMem) / (1 << 30));
}

CudaScene::CudaScene(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
CudaScene::~CudaScene() = default;
int CudaScene::device() const { return impl_->device; }
size_t CudaScene::size() const { return impl_->n; }
size_t CudaScene::device_bytes() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->Bytes();
}

absl::StatusOr<std::unique_ptr<CudaScene>> CudaScene::Upload(const GaussianScene& scene,
                                                             int device) {
  if (absl::Status s = CheckRenderable(scene); !s.ok()) return s;
  if (absl::Status s = CheckCudaDevice(device); !s.ok()) return s;
  PF_CUDA_RETURN_IF_ERROR(cudaSetDevice(device));
  auto impl = std::make_unique<Impl>();
  impl->device = device;
  impl->n = scene.size();
  impl->num_channels = scene.num_channels;
  impl->sh_degree = scene.sh_degree;
  impl->time_origin_us = scene.time_origin_us;
  impl->fade_span = scene.fade_span;
  impl->instances = scene.instances;
  impl->low_pass = scene.low_pass;
  impl->order_band = scene.order_band;
  for (absl::Status s :
       {impl->means.Upload(scene.means), impl->rotations.Upload(scene.rotations),
        impl->log_scales.Upload(scene.log_scales),
        impl->opacity_logits.Upload(scene.opacity_logits), impl->times.Upload(scene.times),
        impl->lifespans.Upload(scene.lifespans), impl->features.Upload(scene.features),
        impl->sh.Upload(scene.sh), impl->colour_gradients.Upload(scene.colour_gradients),
        impl->owners.Upload(scene.owners)}) {
    if (!s.ok()) return s;
  }
  PF_CUDA_RETURN_IF_ERROR(cudaStreamCreateWithFlags(&impl->stream, cudaStreamNonBlocking));
  PF_CUDA_RETURN_IF_ERROR(cudaEventCreate(&impl->start));
  PF_CUDA_RETURN_IF_ERROR(cudaEventCreate(&impl->stop));
  return std::unique_ptr<CudaScene>(new CudaScene(std::move(impl)));
}

absl::StatusOr<RenderBuffers> CudaScene::Render(const RenderCamera& camera, int64_t timestamp_us,
                                                const std::vector<ActorEdit>& edits,
                                                const RenderOptions& options,
                                                CudaRenderTiming* timing) const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->Render(camera, timestamp_us, edits, options, timing);
}

absl::StatusOr<RenderBuffers> CudaScene::Impl::Render(const RenderCamera& camera,
                                                      int64_t timestamp_us,
                                                      const std::vector<ActorEdit>& edits,
                                                      const RenderOptions& options,
                                                      CudaRenderTiming* timing) const {
  if (camera.rolling_shutter.has_value()) {
    return absl::InvalidArgumentError(
        "camera: a rolling shutter renders on the CPU only (DeviceRenderer falls back to it)");
  }
  raster::RenderFrame frame;
  if (absl::Status s = raster::SetUpRenderFrame(instances, time_origin_us, fade_span, camera,
                                                timestamp_us, edits, options.near_plane, &frame);
      !s.ok()) {
    return s;
  }
  PF_CUDA_RETURN_IF_ERROR(cudaSetDevice(device));
  const size_t num_owners = instances.size() + 1;
  std::vector<OwnerPose> host_poses(num_owners);
  for (size_t k = 0; k < num_owners; ++k) {
    OwnerPose& p = host_poses[k];
    std::memcpy(p.r, frame.camera_from_owner[k].r, sizeof(p.r));
    std::memcpy(p.t, frame.camera_from_owner[k].t, sizeof(p.t));
    std::memcpy(p.eye, &frame.eye_in_owner[3 * k], sizeof(p.eye));
    p.live = frame.owner_live[k];
  }
  const int num_tiles = frame.tiles_x * frame.tiles_y;
  const size_t pixels = static_cast<size_t>(frame.width) * frame.height;
  const bool use_sh = sh_degree >= 0;
  const bool has_gradients = colour_gradients.capacity > 0 && n > 0;
  for (absl::Status s :
       {projected.Reserve(n), tiles_touched.Reserve(n), offsets.Reserve(n),
        screen_gradients.Reserve(has_gradients ? 6 * n : 0), sh_rgb.Reserve(use_sh ? 3 * n : 0),
        ranges.Reserve(num_tiles), poses.Reserve(num_owners), counters.Reserve(3),
        out_rgb.Reserve(3 * pixels), out_alpha.Reserve(pixels),
        out_features.Reserve(options.features ? pixels * num_channels : 0),
        out_depth.Reserve(options.depth ? pixels : 0),
        out_instance.Reserve(options.instance ? pixels : 0)}) {
    if (!s.ok()) return s;
  }
  cudaStream_t st = stream;
  PF_CUDA_RETURN_IF_ERROR(cudaEventRecord(start, st));
  PF_CUDA_RETURN_IF_ERROR(cudaMemcpyAsync(
      poses.data, host_poses.data(), num_owners * sizeof(OwnerPose), cudaMemcpyHostToDevice, st));
  PF_CUDA_RETURN_IF_ERROR(cudaMemsetAsync(counters.data, 0, 3 * sizeof(unsigned long long), st));
  PF_CUDA_RETURN_IF_ERROR(cudaMemsetAsync(ranges.data, 0, num_tiles * sizeof(uint2), st));

  // 1. Project.
  constexpr int kThreads = 256;
  if (n > 0) {
    ProjectArgs p;
    p.n = n;
    p.arrays = {means.data, rotations.data, log_scales.data, opacity_logits.data,
                times.data, lifespans.data, low_pass};
    p.camera = frame;
    p.tiles_x = frame.tiles_x;
    p.owners = owners.data;
    p.poses = poses.data;
    p.sh = use_sh ? sh.data : nullptr;
    p.sh_degree = sh_degree;
    p.colour_gradients = has_gradients ? colour_gradients.data : nullptr;
    p.projected = projected.data;
    p.screen_gradients = screen_gradients.data;
    p.sh_rgb = sh_rgb.data;
    p.tiles_touched = tiles_touched.data;
    p.visible = counters.data;
    ProjectKernel<<<CeilDiv(n, kThreads), kThreads, 0, st>>>(p);
    PF_CUDA_RETURN_IF_ERROR(cudaGetLastError());
  }

  // 2. Slots per Gaussian, then the (tile, depth) pairs.
  uint64_t num_pairs = 0;
  if (n > 0) {
    size_t scan_bytes = 0;
    PF_CUDA_RETURN_IF_ERROR(cub::DeviceScan::ExclusiveSum(nullptr, scan_bytes, tiles_touched.data,
                                                          offsets.data, n, st));
    if (absl::Status s = temp.Reserve(scan_bytes); !s.ok()) return s;
    PF_CUDA_RETURN_IF_ERROR(cub::DeviceScan::ExclusiveSum(temp.data, scan_bytes, tiles_touched.data,
                                                          offsets.data, n, st));
    uint64_t last_offset = 0, last_count = 0;
    PF_CUDA_RETURN_IF_ERROR(cudaMemcpyAsync(&last_offset, offsets.data + n - 1, sizeof(uint64_t),
                                            cudaMemcpyDeviceToHost, st));
    PF_CUDA_RETURN_IF_ERROR(cudaMemcpyAsync(&last_count, tiles_touched.data + n - 1,
                                            sizeof(uint64_t), cudaMemcpyDeviceToHost, st));
    PF_CUDA_RETURN_IF_ERROR(cudaStreamSynchronize(st));
    num_pairs = last_offset + last_count;
  }
  if (num_pairs >= (uint64_t{1} << 32)) {
    return absl::ResourceExhaustedError(
        absl::StrCat("CUDA render: ", num_pairs, " Gaussian-tile pairs exceed 2^32"));
  }
  if (num_pairs > 0) {
    for (absl::Status s : {keys.Reserve(num_pairs), keys_sorted.Reserve(num_pairs),
                           values.Reserve(num_pairs), values_sorted.Reserve(num_pairs)}) {
      if (!s.ok()) return s;
    }
    EmitArgs e{n,
               frame.width,
               frame.height,
               frame.tiles_x,
               projected.data,
               tiles_touched.data,
               offsets.data,
               keys.data,
               values.data,
               order_band};
    EmitKernel<<<CeilDiv(n, kThreads), kThreads, 0, st>>>(e);
    PF_CUDA_RETURN_IF_ERROR(cudaGetLastError());

    // 3. Sort by (tile, depth); stable, so ties keep index order.
    int tile_bits = 1;
    while ((int64_t{1} << tile_bits) < num_tiles) ++tile_bits;
    size_t sort_bytes = 0;
    PF_CUDA_RETURN_IF_ERROR(cub::DeviceRadixSort::SortPairs(
        nullptr, sort_bytes, keys.data, keys_sorted.data, values.data, values_sorted.data,
        num_pairs, 0, 32 + tile_bits, st));
    if (absl::Status s = temp.Reserve(sort_bytes); !s.ok()) return s;
    PF_CUDA_RETURN_IF_ERROR(cub::DeviceRadixSort::SortPairs(
        temp.data, sort_bytes, keys.data, keys_sorted.data, values.data, values_sorted.data,
        num_pairs, 0, 32 + tile_bits, st));
    RangesKernel<<<CeilDiv(num_pairs, kThreads), kThreads, 0, st>>>(keys_sorted.data, num_pairs,
                                                                    ranges.data);
    PF_CUDA_RETURN_IF_ERROR(cudaGetLastError());
  }

  // 4. Composite, K channels per launch.
  CompositeArgs c;
  c.width = frame.width;
  c.height = frame.height;
  c.tiles_x = frame.tiles_x;
  c.ranges = ranges.data;
  c.values = values_sorted.data;
  c.projected = projected.data;
  c.gradients = has_gradients ? screen_gradients.data : nullptr;
  c.alpha = out_alpha.data;
  c.depth = options.depth ? out_depth.data : nullptr;
  c.instance = options.instance ? out_instance.data : nullptr;
  c.counters = counters.data + 1;
  bool primary = true;
  auto launch = [&](const float* source, int stride, int first, int count, float* out,
                    int out_stride, float* rgb) -> absl::Status {
    c.source = source;
    c.source_stride = stride;
    c.first = first;
    c.count = count;
    c.out = out;
    c.out_stride = out_stride;
    c.rgb = rgb;
    c.primary = primary;
    primary = false;
    if (count <= 3) {
      CompositeKernel<3><<<num_tiles, kTilePixels, 0, st>>>(c);
    } else {
      CompositeKernel<8><<<num_tiles, kTilePixels, 0, st>>>(c);
    }
    return CudaError(cudaGetLastError(), "composite kernel");
  };
  // Channel groups of `channels` source channels into `out`; the first three
  // also into `rgb` when given.
  auto blend = [&](const float* source, int channels, float* out, float* rgb) -> absl::Status {
    const int group = channels <= 3 ? 3 : 8;
    for (int first = 0; first < channels; first += group) {
      const int count = std::min(group, channels - first);
      if (absl::Status s = launch(source, channels, first, count, out, channels, rgb); !s.ok()) {
        return s;
      }
    }
    return absl::OkStatus();
  };
  if (use_sh) {
    if (absl::Status s = blend(sh_rgb.data, 3, out_rgb.data, nullptr); !s.ok()) return s;
  }
  if (options.features) {
    if (absl::Status s =
            blend(features.data, num_channels, out_features.data, use_sh ? nullptr : out_rgb.data);
        !s.ok()) {
      return s;
    }
  } else if (!use_sh) {
    // The colour alone: the first three feature channels into rgb.
    if (absl::Status s = launch(features.data, num_channels, 0, 3, out_rgb.data, 3, nullptr);
        !s.ok()) {
      return s;
    }
  }
  PF_CUDA_RETURN_IF_ERROR(cudaEventRecord(stop, st));

  // Download.
  RenderBuffers out;
  out.width = frame.width;
  out.height = frame.height;
  out.channels = num_channels;
  out.rgb.resize(pixels * 3);
  out.alpha.resize(pixels);
  if (options.features) out.features.resize(pixels * num_channels);
  if (options.depth) out.depth.resize(pixels);
  if (options.instance) out.instance.resize(pixels);
  PF_CUDA_RETURN_IF_ERROR(cudaEventSynchronize(stop));
  const auto download_start = std::chrono::steady_clock::now();
  auto download = [&](void* host, const void* device_data, size_t bytes) -> absl::Status {
    if (bytes == 0) return absl::OkStatus();
    return CudaError(cudaMemcpyAsync(host, device_data, bytes, cudaMemcpyDeviceToHost, st),
                     "cudaMemcpyAsync to the host");
  };
  unsigned long long counts[3] = {};
  for (absl::Status s :
       {download(out.rgb.data(), out_rgb.data, out.rgb.size() * sizeof(float)),
        download(out.alpha.data(), out_alpha.data, out.alpha.size() * sizeof(float)),
        download(out.features.data(), out_features.data, out.features.size() * sizeof(float)),
        download(out.depth.data(), out_depth.data, out.depth.size() * sizeof(float)),
        download(out.instance.data(), out_instance.data, out.instance.size() * sizeof(uint32_t)),
        download(counts, counters.data, sizeof(counts))}) {
    if (!s.ok()) return s;
  }
  PF_CUDA_RETURN_IF_ERROR(cudaStreamSynchronize(st));
  if (timing != nullptr) {
    float device_ms = 0;
    PF_CUDA_RETURN_IF_ERROR(cudaEventElapsedTime(&device_ms, start, stop));
    timing->device_ms = device_ms;
    timing->download_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - download_start)
            .count();
  }
  out.stats.gaussians_visible = static_cast<int64_t>(counts[0]);
  out.stats.pairs_tested = static_cast<int64_t>(counts[1]);
  out.stats.pairs_contributing = static_cast<int64_t>(counts[2]);
  return out;
}

}  // namespace pf
