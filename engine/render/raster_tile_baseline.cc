// The tile kernel for the x86-64 baseline (4 lanes), and the run-time choice
// between it and the AVX2 build.
#include <atomic>
#include <cstdlib>
#include <string_view>

#include "engine/render/raster_tile.h"
#include "engine/render/raster_tile_kernel.h"

namespace pf::raster {
namespace {

// AVX2 when the CPU has it, unless PF_RENDER_KERNEL=baseline asks otherwise
// (to compare the two builds).
bool UseAvx2() {
#if defined(PF_RENDER_HAVE_AVX2_KERNEL)
  static const bool avx2 = [] {
    const char* env = std::getenv("PF_RENDER_KERNEL");
    if (env != nullptr && std::string_view(env) == "baseline") return false;
    return static_cast<bool>(__builtin_cpu_supports("avx2"));
  }();
  return avx2;
#else
  return false;
#endif
}

std::atomic<bool> g_force_baseline{false};

}  // namespace

void ForceBaselineKernelForTesting(bool force) { g_force_baseline = force; }

void CompositeTileBaseline(TileJob* job) { CompositeTileFor<4>(job); }

#if !defined(PF_RENDER_HAVE_AVX2_KERNEL)
void CompositeTileAvx2(TileJob* job) { CompositeTileFor<4>(job); }
#endif

void CompositeTile(TileJob* job) {
  if (UseAvx2() && !g_force_baseline.load(std::memory_order_relaxed)) {
    CompositeTileAvx2(job);
  } else {
    CompositeTileBaseline(job);
  }
}

const char* TileKernelName() { return UseAvx2() && !g_force_baseline.load() ? "avx2" : "baseline"; }

}  // namespace pf::raster
