// The colour fit's solve on a GPU (cuda_colour_fit.h).
//
// Every view's entries are concatenated: entry e has its weight, the scene
// index of its Gaussian and (textured) the index of that Gaussian's screen
// frame in its view, frames concatenated the same way. The fitted pixels of
// all views form one list, each with its first entry, entry count, centre
// and image colour. A product pass runs a thread per fitted pixel over its
// row of A; A^T adds into the Gaussians atomically. The vector passes of an
// iteration run a thread per Gaussian and add their per-channel dot
// products into three doubles (block sums, then one atomic add per block).
#include <cuda_runtime.h>

#include <mutex>

#include "absl/strings/str_cat.h"
#include "engine/recon/colour_fit_blocks.h"
#include "engine/recon/cuda_colour_fit.h"
#include "engine/render/cuda_rasterizer.h"
#include "engine/render/cuda_support.h"

namespace pf {
namespace {

using colour_fit::kMinTransmittance;
using colour_fit::kSums;
using colour_fit::PreconditionBlock;
using cuda::CeilDiv;
using cuda::CudaError;
using cuda::DeviceBuffer;

constexpr int kThreads = 256;

// The concatenated system as the kernels read it.
struct System {
  const float* weight;       // [E]
  const uint32_t* gaussian;  // [E] scene index
  const uint32_t* frame;     // [E] index into frames
  const float* frames;       // [F, 6] (mx, my, ux, uy, vx, vy), textured only
  const uint64_t* begin;     // [P] first entry of each fitted pixel
  const uint32_t* count;     // [P]
  const float2* centre;      // [P] pixel centre (x + 0.5, y + 0.5)
  const float* rgb;          // [P, 3] image
  size_t pixels;
};

// (u, v) of entry e at pixel centre c: CompositingWeights::LocalCoords.
__device__ inline void EntryCoords(const System& s, uint64_t e, float2 c, float* u, float* v) {
  const float* f = s.frames + 6 * static_cast<size_t>(s.frame[e]);
  const float dx = c.x - f[0], dy = c.y - f[1];
  *u = f[2] * dx + f[3] * dy;
  *v = f[4] * dx + f[5] * dy;
}

// Calls f(g, w, u, v) for each entry of fitted pixel p in order, front to
// back: its Gaussian, weight and local coordinates (0 when flat).
template <bool kTextured, typename F>
__device__ void ForRow(const System& s, size_t p, F&& f) {
  const uint64_t b = s.begin[p], end = b + s.count[p];
  const float2 c = s.centre[p];
  for (uint64_t e = b; e < end; ++e) {
    float u = 0.f, v = 0.f;
    if constexpr (kTextured) EntryCoords(s, e, c, &u, &v);
    f(static_cast<size_t>(s.gaussian[e]), s.weight[e], u, v);
  }
}

// y = (A x)_p, per channel.
template <bool kTextured>
__device__ void RowTimes(const System& s, size_t p, const float* x, float y[3]) {
  y[0] = y[1] = y[2] = 0.f;
  ForRow<kTextured>(s, p, [&](size_t g, float w, float u, float v) {
    if constexpr (kTextured) {
      const float* xg = x + 9 * g;
      for (int ch = 0; ch < 3; ++ch)
        y[ch] += w * (xg[3 * ch] + u * xg[3 * ch + 1] + v * xg[3 * ch + 2]);
    } else {
      for (int ch = 0; ch < 3; ++ch) y[ch] += w * x[3 * g + ch];
    }
  });
}

// out += (row p of A)^T r.
template <bool kTextured>
__device__ void AddRowTransposed(const System& s, size_t p, const float r[3], float* out) {
  ForRow<kTextured>(s, p, [&](size_t g, float w, float u, float v) {
    if constexpr (kTextured) {
      float* og = out + 9 * g;
      for (int ch = 0; ch < 3; ++ch) {
        const float wr = w * r[ch];
        atomicAdd(og + 3 * ch, wr);
        atomicAdd(og + 3 * ch + 1, wr * u);
        atomicAdd(og + 3 * ch + 2, wr * v);
      }
    } else {
      for (int ch = 0; ch < 3; ++ch) atomicAdd(out + 3 * g + ch, w * r[ch]);
    }
  });
}

// Adds the block's per-channel values into sums[0..2] (one atomic add per
// block and channel). Every thread of the block must call it.
__device__ void BlockAdd3(double v0, double v1, double v2, double* sums) {
  __shared__ double partial[3][kThreads / 32];
  double v[3] = {v0, v1, v2};
  for (int c = 0; c < 3; ++c)
    for (int offset = 16; offset > 0; offset /= 2)
      v[c] += __shfl_down_sync(0xffffffffu, v[c], offset);
  const int lane = threadIdx.x % 32, warp = threadIdx.x / 32;
  if (lane == 0)
    for (int c = 0; c < 3; ++c) partial[c][warp] = v[c];
  __syncthreads();
  if (threadIdx.x < 3) {
    double total = 0;
    for (int w = 0; w < kThreads / 32; ++w) total += partial[threadIdx.x][w];
    atomicAdd(sums + threadIdx.x, total);
  }
}

// out += A^T M A x.
template <bool kTextured>
__global__ void NormalKernel(System s, const float* x, float* out) {
  const size_t p = blockIdx.x * size_t(blockDim.x) + threadIdx.x;
  if (p >= s.pixels) return;
  float y[3];
  RowTimes<kTextured>(s, p, x, y);
  AddRowTransposed<kTextured>(s, p, y, out);
}

// sums += per channel sum of (I - A x)^2 over the fitted pixels; out (when
// not null) += A^T M (I - A x).
template <bool kTextured>
__global__ void ResidualKernel(System s, const float* x, float* out, double* sums) {
  const size_t p = blockIdx.x * size_t(blockDim.x) + threadIdx.x;
  float r[3] = {0.f, 0.f, 0.f};
  if (p < s.pixels) {
    float y[3];
    RowTimes<kTextured>(s, p, x, y);
    for (int c = 0; c < 3; ++c) r[c] = s.rgb[3 * p + c] - y[c];
    if (out != nullptr) AddRowTransposed<kTextured>(s, p, r, out);
  }
  BlockAdd3(double(r[0]) * r[0], double(r[1]) * r[1], double(r[2]) * r[2], sums);
}

// out [N, kSums] += each Gaussian's sums (colour_fit_blocks.h).
template <bool kTextured>
__global__ void SumsKernel(System s, float* out) {
  const size_t p = blockIdx.x * size_t(blockDim.x) + threadIdx.x;
  if (p >= s.pixels) return;
  float in_front = 0.f;
  ForRow<kTextured>(s, p, [&](size_t g, float w, float u, float v) {
    const float alpha = w / fmaxf(kMinTransmittance, 1.f - in_front);
    in_front += w;
    const float ww = w * w;
    float* d = out + kSums * g;
    atomicAdd(d, ww);
    if constexpr (kTextured) {
      atomicAdd(d + 1, ww * u * u);
      atomicAdd(d + 2, ww * v * v);
      atomicAdd(d + 3, ww * u);
      atomicAdd(d + 4, ww * v);
      atomicAdd(d + 5, ww * u * v);
    }
    atomicAdd(d + 6, alpha * alpha);
  });
}

// Global frame index -> scene index of the entries of one view: frame[e] =
// frame_base + local[e] (uploaded into frame), gaussian[e] = ids[frame[e]].
__global__ void IndexKernel(uint32_t* frame, uint32_t* gaussian, size_t entries,
                            uint32_t frame_base, const uint32_t* ids) {
  const size_t e = blockIdx.x * size_t(blockDim.x) + threadIdx.x;
  if (e >= entries) return;
  const uint32_t f = frame[e] + frame_base;
  frame[e] = f;
  gaussian[e] = ids[f];
}

// The vector passes, a thread per Gaussian; K unknowns per channel.
struct Vectors {
  size_t n;
  float *x, *r, *p, *q;
  const float *prior, *inverse;
};

template <int K>
__device__ inline size_t InverseSize() {
  return K == 1 ? 1 : 6;
}

// p = z = B^-1 r; sums += r . z.
template <int K>
__global__ void StartKernel(Vectors v, double* sums) {
  const size_t i = blockIdx.x * size_t(blockDim.x) + threadIdx.x;
  double d[3] = {0, 0, 0};
  if (i < v.n) {
    const size_t k = 3 * K * i;
    float z[3 * K];
    PreconditionBlock(v.inverse + InverseSize<K>() * i, K, v.r + k, z);
    for (int j = 0; j < 3 * K; ++j) {
      v.p[k + j] = z[j];
      d[j / K] += double(v.r[k + j]) * z[j];
    }
  }
  BlockAdd3(d[0], d[1], d[2], sums);
}

// q += prior p; sums += p . q.
template <int K>
__global__ void PriorKernel(Vectors v, double* sums) {
  const size_t i = blockIdx.x * size_t(blockDim.x) + threadIdx.x;
  double d[3] = {0, 0, 0};
  if (i < v.n) {
    for (size_t j = 0, k = 3 * K * i; j < 3 * K; ++j, ++k) {
      v.q[k] += v.prior[k] * v.p[k];
      d[j / K] += double(v.p[k]) * v.q[k];
    }
  }
  BlockAdd3(d[0], d[1], d[2], sums);
}

// x += step p, r -= step q; sums += r . B^-1 r.
template <int K>
__global__ void UpdateKernel(Vectors v, float3 step, double* sums) {
  const size_t i = blockIdx.x * size_t(blockDim.x) + threadIdx.x;
  double d[3] = {0, 0, 0};
  if (i < v.n) {
    const float s[3] = {step.x, step.y, step.z};
    const size_t k = 3 * K * i;
    for (int j = 0; j < 3 * K; ++j) {
      v.x[k + j] += s[j / K] * v.p[k + j];
      v.r[k + j] -= s[j / K] * v.q[k + j];
    }
    float z[3 * K];
    PreconditionBlock(v.inverse + InverseSize<K>() * i, K, v.r + k, z);
    for (int j = 0; j < 3 * K; ++j) d[j / K] += double(v.r[k + j]) * z[j];
  }
  BlockAdd3(d[0], d[1], d[2], sums);
}

// p = B^-1 r + beta p.
template <int K>
__global__ void DirectionKernel(Vectors v, float3 beta) {
  const size_t i = blockIdx.x * size_t(blockDim.x) + threadIdx.x;
  if (i >= v.n) return;
  const float b[3] = {beta.x, beta.y, beta.z};
  const size_t k = 3 * K * i;
  float z[3 * K];
  PreconditionBlock(v.inverse + InverseSize<K>() * i, K, v.r + k, z);
  for (int j = 0; j < 3 * K; ++j) v.p[k + j] = z[j] + b[j / K] * v.p[k + j];
}

}  // namespace

struct CudaColourFit::Impl {
  int device = 0;
  size_t n = 0;
  bool textured = false;
  size_t pixels = 0;
  DeviceBuffer<float> weight, frames, rgb;
  DeviceBuffer<uint32_t> gaussian, frame, ids, count;
  DeviceBuffer<uint64_t> begin;
  DeviceBuffer<float2> centre;
  // The solve's vectors, [N, 3K] each, and three per-channel sums.
  DeviceBuffer<float> x, r, p, q, prior, inverse;
  DeviceBuffer<double> sums;
  bool started = false;
  std::mutex mutex;

  int per() const { return textured ? 9 : 3; }
  System system() const {
    return {weight.data, gaussian.data, frame.data, frames.data, begin.data,
            count.data,  centre.data,   rgb.data,   pixels};
  }
  Vectors vectors() const { return {n, x.data, r.data, p.data, q.data, prior.data, inverse.data}; }
  size_t Bytes() const {
    return weight.bytes() + frames.bytes() + rgb.bytes() + gaussian.bytes() + frame.bytes() +
           ids.bytes() + count.bytes() + begin.bytes() + centre.bytes() + x.bytes() + r.bytes() +
           p.bytes() + q.bytes() + prior.bytes() + inverse.bytes() + sums.bytes();
  }
  // Zeroes the three sums, runs launch(sums.data) (kernels that add into
  // them) and returns them.
  template <typename Launch>
  absl::StatusOr<ChannelSums> Summed(const Launch& launch) {
    PF_CUDA_RETURN_IF_ERROR(cudaMemset(sums.data, 0, 3 * sizeof(double)));
    launch(sums.data);
    PF_CUDA_RETURN_IF_ERROR(cudaGetLastError());
    ChannelSums out;
    PF_CUDA_RETURN_IF_ERROR(
        cudaMemcpy(out.data(), sums.data, 3 * sizeof(double), cudaMemcpyDeviceToHost));
    return out;
  }
  // The iterations of CudaColourFit::Solve for K unknowns per channel.
  template <int K>
  absl::Status Iterate(int iterations);
  absl::Status CheckVector(const std::vector<float>& v, size_t width, const char* what) const {
    if (v.size() == width * n) return absl::OkStatus();
    return absl::InvalidArgumentError(absl::StrCat("CudaColourFit: ", what, " has ", v.size(),
                                                   " values for ", n, " Gaussians x ", width));
  }
};

bool HaveCudaColourFit() { return true; }

CudaColourFit::CudaColourFit(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
CudaColourFit::~CudaColourFit() = default;

size_t CudaColourFit::device_bytes() const { return impl_->Bytes(); }

absl::StatusOr<std::unique_ptr<CudaColourFit>> CudaColourFit::Upload(
    const std::vector<ColourFitView>& views, size_t num_gaussians, bool textured, int device) {
  size_t entries = 0, frames = 0, pixels = 0;
  for (size_t v = 0; v < views.size(); ++v) {
    const CompositingWeights& a = *views[v].weights;
    const size_t size = static_cast<size_t>(a.width) * a.height;
    if (a.pixel_begin.size() != size || a.pixel_count.size() != size ||
        a.pixel_table.size() != size ||
        (textured && a.local_frames.size() != 6 * a.gaussians.size()) ||
        views[v].fitted == nullptr || views[v].image == nullptr) {
      return absl::InvalidArgumentError(
          absl::StrCat("CudaColourFit: view ", v, "'s weights, mask or image are incomplete",
                       textured ? " (a textured fit needs local coordinates)" : ""));
    }
    for (uint32_t id : a.gaussians) {
      if (id >= num_gaussians) {
        return absl::InvalidArgumentError(
            absl::StrCat("CudaColourFit: view ", v, " has Gaussian ", id, " of ", num_gaussians));
      }
    }
    entries += a.entries();
    frames += a.gaussians.size();
    for (size_t p = 0; p < size; ++p) pixels += views[v].fitted[p] != 0;
  }
  if (frames > UINT32_MAX) {
    return absl::InvalidArgumentError("CudaColourFit: more than 2^32 Gaussians in views");
  }
  if (absl::Status s = CheckCudaDevice(device); !s.ok()) return s;
  int major = 0;
  PF_CUDA_RETURN_IF_ERROR(
      cudaDeviceGetAttribute(&major, cudaDevAttrComputeCapabilityMajor, device));
  if (major < 8) {
    return absl::FailedPreconditionError(
        absl::StrCat("GPU cuda:", device, " has compute capability ", major,
                     ".x; the colour fit's kernels need 8.0 or newer"));
  }
  PF_CUDA_RETURN_IF_ERROR(cudaSetDevice(device));
  auto impl = std::make_unique<Impl>();
  impl->device = device;
  impl->n = num_gaussians;
  impl->textured = textured;
  impl->pixels = pixels;
  const size_t per = impl->per();
  for (absl::Status s :
       {impl->weight.Reserve(entries), impl->gaussian.Reserve(entries),
        impl->frame.Reserve(entries), impl->ids.Reserve(frames),
        impl->frames.Reserve(textured ? 6 * frames : 0), impl->begin.Reserve(pixels),
        impl->count.Reserve(pixels), impl->centre.Reserve(pixels), impl->rgb.Reserve(3 * pixels),
        impl->x.Reserve(per * num_gaussians), impl->r.Reserve(per * num_gaussians),
        impl->p.Reserve(per * num_gaussians), impl->q.Reserve(per * num_gaussians),
        impl->prior.Reserve(per * num_gaussians),
        impl->inverse.Reserve((textured ? 6 : 1) * num_gaussians), impl->sums.Reserve(3)}) {
    if (!s.ok()) return s;
  }
  auto copy = [](auto* device_ptr, const auto* host, size_t count) {
    return CudaError(cudaMemcpy(device_ptr, host, count * sizeof(*host), cudaMemcpyHostToDevice),
                     "cudaMemcpy to the GPU");
  };
  size_t entry_base = 0, frame_base = 0, pixel_base = 0;
  std::vector<uint64_t> begin;
  std::vector<uint32_t> count;
  std::vector<float2> centre;
  std::vector<float> rgb;
  std::vector<uint32_t> local;  // A view's entries unpacked (CompositingWeights::Unpack).
  std::vector<float> weight;
  for (const ColourFitView& view : views) {
    const CompositingWeights& a = *view.weights;
    const size_t size = static_cast<size_t>(a.width) * a.height;
    const size_t m = a.gaussians.size(), e = a.entries();
    a.Unpack(&local, &weight);
    for (absl::Status s :
         {copy(impl->weight.data + entry_base, weight.data(), e),
          copy(impl->frame.data + entry_base, local.data(), e),
          copy(impl->ids.data + frame_base, a.gaussians.data(), m),
          textured ? copy(impl->frames.data + 6 * frame_base, a.local_frames.data(), 6 * m)
                   : absl::OkStatus()}) {
      if (!s.ok()) return s;
    }
    if (e > 0) {
      IndexKernel<<<CeilDiv(e, kThreads), kThreads>>>(
          impl->frame.data + entry_base, impl->gaussian.data + entry_base, e,
          static_cast<uint32_t>(frame_base), impl->ids.data);
      PF_CUDA_RETURN_IF_ERROR(cudaGetLastError());
    }
    begin.clear();
    count.clear();
    centre.clear();
    rgb.clear();
    for (size_t p = 0; p < size; ++p) {
      if (!view.fitted[p]) continue;
      begin.push_back(entry_base + a.pixel_begin[p]);
      count.push_back(a.pixel_count[p]);
      float cx, cy;
      a.PixelCentre(p, &cx, &cy);
      centre.push_back(make_float2(cx, cy));
      for (int c = 0; c < 3; ++c) rgb.push_back(view.image[3 * p + c]);
    }
    for (absl::Status s : {copy(impl->begin.data + pixel_base, begin.data(), begin.size()),
                           copy(impl->count.data + pixel_base, count.data(), count.size()),
                           copy(impl->centre.data + pixel_base, centre.data(), centre.size()),
                           copy(impl->rgb.data + 3 * pixel_base, rgb.data(), rgb.size())}) {
      if (!s.ok()) return s;
    }
    entry_base += e;
    frame_base += m;
    pixel_base += begin.size();
  }
  PF_CUDA_RETURN_IF_ERROR(cudaDeviceSynchronize());
  return std::unique_ptr<CudaColourFit>(new CudaColourFit(std::move(impl)));
}

absl::StatusOr<ChannelSums> CudaColourFit::Residual(const std::vector<float>& x, bool start) {
  Impl& m = *impl_;
  std::lock_guard<std::mutex> lock(m.mutex);
  m.started = false;  // Set again once this residual is whole.
  if (absl::Status s = m.CheckVector(x, m.per(), "x"); !s.ok()) return s;
  PF_CUDA_RETURN_IF_ERROR(cudaSetDevice(m.device));
  PF_CUDA_RETURN_IF_ERROR(
      cudaMemcpy(m.x.data, x.data(), x.size() * sizeof(float), cudaMemcpyHostToDevice));
  if (start) PF_CUDA_RETURN_IF_ERROR(cudaMemset(m.r.data, 0, x.size() * sizeof(float)));
  float* out = start ? m.r.data : nullptr;
  absl::StatusOr<ChannelSums> sums = m.Summed([&](double* device_sums) {
    if (m.pixels == 0) return;
    const int blocks = CeilDiv(m.pixels, kThreads);
    if (m.textured) {
      ResidualKernel<true><<<blocks, kThreads>>>(m.system(), m.x.data, out, device_sums);
    } else {
      ResidualKernel<false><<<blocks, kThreads>>>(m.system(), m.x.data, out, device_sums);
    }
  });
  m.started = start && sums.ok();
  return sums;
}

absl::StatusOr<std::vector<float>> CudaColourFit::Sums() {
  Impl& m = *impl_;
  std::lock_guard<std::mutex> lock(m.mutex);
  PF_CUDA_RETURN_IF_ERROR(cudaSetDevice(m.device));
  DeviceBuffer<float> sums;
  if (absl::Status s = sums.Reserve(kSums * m.n); !s.ok()) return s;
  PF_CUDA_RETURN_IF_ERROR(cudaMemset(sums.data, 0, kSums * m.n * sizeof(float)));
  if (m.pixels > 0) {
    if (m.textured) {
      SumsKernel<true><<<CeilDiv(m.pixels, kThreads), kThreads>>>(m.system(), sums.data);
    } else {
      SumsKernel<false><<<CeilDiv(m.pixels, kThreads), kThreads>>>(m.system(), sums.data);
    }
    PF_CUDA_RETURN_IF_ERROR(cudaGetLastError());
  }
  std::vector<float> out(kSums * m.n);
  PF_CUDA_RETURN_IF_ERROR(
      cudaMemcpy(out.data(), sums.data, out.size() * sizeof(float), cudaMemcpyDeviceToHost));
  return out;
}

template <int K>
absl::Status CudaColourFit::Impl::Iterate(int iterations) {
  const Vectors v = vectors();
  const System sys = system();
  const int gaussian_blocks = CeilDiv(n, kThreads);
  absl::StatusOr<ChannelSums> rz =
      Summed([&](double* d) { StartKernel<K><<<gaussian_blocks, kThreads>>>(v, d); });
  if (!rz.ok()) return rz.status();
  for (int iteration = 0; iteration < iterations; ++iteration) {
    // q = (A^T M A + Lambda) p.
    PF_CUDA_RETURN_IF_ERROR(cudaMemset(v.q, 0, 3 * K * n * sizeof(float)));
    if (pixels > 0) {
      NormalKernel<K == 3><<<CeilDiv(pixels, kThreads), kThreads>>>(sys, v.p, v.q);
    }
    absl::StatusOr<ChannelSums> pq =
        Summed([&](double* d) { PriorKernel<K><<<gaussian_blocks, kThreads>>>(v, d); });
    if (!pq.ok()) return pq.status();
    float step[3];
    for (int c = 0; c < 3; ++c)
      step[c] = (*pq)[c] > 0 ? static_cast<float>((*rz)[c] / (*pq)[c]) : 0.f;
    absl::StatusOr<ChannelSums> rz_next = Summed([&](double* d) {
      UpdateKernel<K><<<gaussian_blocks, kThreads>>>(v, make_float3(step[0], step[1], step[2]), d);
    });
    if (!rz_next.ok()) return rz_next.status();
    float beta[3];
    for (int c = 0; c < 3; ++c)
      beta[c] = (*rz)[c] > 0 ? static_cast<float>((*rz_next)[c] / (*rz)[c]) : 0.f;
    DirectionKernel<K><<<gaussian_blocks, kThreads>>>(v, make_float3(beta[0], beta[1], beta[2]));
    PF_CUDA_RETURN_IF_ERROR(cudaGetLastError());
    rz = rz_next;
  }
  return absl::OkStatus();
}

absl::Status CudaColourFit::Solve(const std::vector<float>& prior,
                                  const std::vector<float>& inverse, int iterations,
                                  std::vector<float>* x) {
  Impl& m = *impl_;
  std::lock_guard<std::mutex> lock(m.mutex);
  if (!m.started) {
    return absl::FailedPreconditionError(
        "CudaColourFit::Solve: no start (call Residual(x0, true) first)");
  }
  for (absl::Status s : {m.CheckVector(prior, m.per(), "prior"),
                         m.CheckVector(inverse, m.textured ? 6 : 1, "inverse")}) {
    if (!s.ok()) return s;
  }
  PF_CUDA_RETURN_IF_ERROR(cudaSetDevice(m.device));
  PF_CUDA_RETURN_IF_ERROR(
      cudaMemcpy(m.prior.data, prior.data(), prior.size() * sizeof(float), cudaMemcpyHostToDevice));
  PF_CUDA_RETURN_IF_ERROR(cudaMemcpy(m.inverse.data, inverse.data(), inverse.size() * sizeof(float),
                                     cudaMemcpyHostToDevice));
  m.started = false;  // x and r move on from here, whatever happens.
  absl::Status status = m.textured ? m.Iterate<3>(iterations) : m.Iterate<1>(iterations);
  if (!status.ok()) return status;
  x->resize(m.per() * m.n);
  PF_CUDA_RETURN_IF_ERROR(
      cudaMemcpy(x->data(), m.x.data, x->size() * sizeof(float), cudaMemcpyDeviceToHost));
  return absl::OkStatus();
}

}  // namespace pf
