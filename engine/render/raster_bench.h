// `pf bench raster` (and pf_raster_bench, the same program alone for GPU
// machines without our other dependencies): renders the street-like
// benchmark scene (bench_scene.h) on the CPU or a GPU and prints one JSON
// object on stdout.
//
//   [--gaussians N] [--width W --height H] [--channels C] [--repeat R]
//   [--seed S] [--device cpu|cuda:N] [--compare-cpu]
//
// On a GPU the JSON adds the kernels' time (device_ms_*), the copy of the
// outputs (download_ms_median) and the scene's upload; --compare-cpu also
// renders the view on the CPU and adds the PSNR of the GPU's RGB against it.
#ifndef POINTFORWARD_ENGINE_RENDER_RASTER_BENCH_H_
#define POINTFORWARD_ENGINE_RENDER_RASTER_BENCH_H_

#include <string>
#include <vector>

#include "absl/status/status.h"

namespace pf {

// The usage line of the flags.
inline constexpr char kRasterBenchUsage[] =
    "[--gaussians N] [--width W --height H] [--channels C] [--repeat R] [--seed S] "
    "[--device cpu|cuda:N] [--compare-cpu]";

// Runs the benchmark with `args` (the flags above). INVALID_ARGUMENT naming a
// bad flag, FAILED_PRECONDITION when the device cannot be used.
absl::Status RunRasterBench(const std::vector<std::string>& args);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RENDER_RASTER_BENCH_H_
