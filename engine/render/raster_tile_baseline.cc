// The tile kernel for the x86-64 baseline (4 lanes), and the run-time choice
// between it and the AVX2 and AVX-512 builds.
#include <atomic>
#include <cstdlib>
#include <cstring>

#include "engine/render/raster_tile.h"
#include "engine/render/raster_tile_kernel.h"

namespace pf::raster {
namespace {

enum Kernel : int { kBaseline, kAvx2, kAvx512, kNumKernels };
constexpr const char* kKernelNames[kNumKernels] = {"baseline", "avx2", "avx512"};

bool Runs(Kernel kernel) {
#if defined(PF_RENDER_HAVE_AVX2_KERNEL)
  if (kernel == kAvx512) return __builtin_cpu_supports("avx512f");
  if (kernel == kAvx2) return __builtin_cpu_supports("avx2");
  return true;
#else
  return kernel == kBaseline;
#endif
}

// The kernel PF_RENDER_KERNEL names if this CPU runs it, else AVX2 where the
// CPU has it. AVX-512 is asked for by name only: on the AMD EPYC (Zen 4) it
// was measured slower than AVX2 (docs/PERFORMANCE.md).
Kernel DefaultKernel() {
  static const Kernel kernel = [] {
    if (const char* env = std::getenv("PF_RENDER_KERNEL"); env != nullptr) {
      for (int k = 0; k < kNumKernels; ++k) {
        if (std::strcmp(env, kKernelNames[k]) == 0 && Runs(Kernel(k))) return Kernel(k);
      }
    }
    return Runs(kAvx2) ? kAvx2 : kBaseline;
  }();
  return kernel;
}

// The widest kernel this CPU runs, whatever PF_RENDER_KERNEL says.
Kernel WidestKernel() { return Runs(kAvx512) ? kAvx512 : Runs(kAvx2) ? kAvx2 : kBaseline; }

std::atomic<int> g_kernel_for_testing{-1};

Kernel CurrentKernel() {
  const int forced = g_kernel_for_testing.load(std::memory_order_relaxed);
  return forced >= 0 ? Kernel(forced) : DefaultKernel();
}

}  // namespace

bool UseTileKernelForTesting(const char* name) {
  if (name == nullptr) {
    g_kernel_for_testing = -1;
    return true;
  }
  for (int k = 0; k < kNumKernels; ++k) {
    if (std::strcmp(name, kKernelNames[k]) == 0 && Runs(Kernel(k))) {
      g_kernel_for_testing = k;
      return true;
    }
  }
  return false;
}

void CompositeTileBaseline(TileJob* job) { CompositeTileFor<4>(job); }

void BlendPeakTileBaseline(const PeakGaussian* gaussians, int count, float* out) {
  BlendPeakTileFor<4>(gaussians, count, out);
}

#if !defined(PF_RENDER_HAVE_AVX2_KERNEL)
void CompositeTileAvx2(TileJob* job) { CompositeTileFor<4>(job); }
void CompositeTileAvx512(TileJob* job) { CompositeTileFor<4>(job); }
void BlendPeakTileAvx2(const PeakGaussian* gaussians, int count, float* out) {
  BlendPeakTileFor<4>(gaussians, count, out);
}
void BlendPeakTileAvx512(const PeakGaussian* gaussians, int count, float* out) {
  BlendPeakTileFor<4>(gaussians, count, out);
}
#endif

void CompositeTile(TileJob* job) {
  switch (CurrentKernel()) {
    case kAvx512:
      CompositeTileAvx512(job);
      break;
    case kAvx2:
      CompositeTileAvx2(job);
      break;
    default:
      CompositeTileBaseline(job);
  }
}

void BlendPeakTile(const PeakGaussian* gaussians, int count, float* out) {
  switch (WidestKernel()) {
    case kAvx512:
      BlendPeakTileAvx512(gaussians, count, out);
      break;
    case kAvx2:
      BlendPeakTileAvx2(gaussians, count, out);
      break;
    default:
      BlendPeakTileBaseline(gaussians, count, out);
  }
}

const char* BlendPeakKernelName() { return kKernelNames[WidestKernel()]; }

const char* TileKernelName() { return kKernelNames[CurrentKernel()]; }

}  // namespace pf::raster
