// The rasterizer benchmark (raster_bench.h).
#include "engine/render/raster_bench.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "common/bench_info.h"
#include "common/command_line.h"
#include "common/compute_device.h"
#include "common/status_macros.h"
#include "common/thread_pool.h"
#include "engine/render/bench_scene.h"
#include "engine/render/cuda_rasterizer.h"
#include "engine/render/raster_backward.h"
#include "engine/render/raster_tile.h"
#include "engine/render/rasterizer.h"

namespace pf {
namespace {

double MsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

// Returns INVALID_ARGUMENT naming `flag` unless lo <= value <= hi.
absl::Status CheckRange(const char* flag, int64_t value, int64_t lo, int64_t hi) {
  if (value < lo || value > hi) {
    return absl::InvalidArgumentError(
        absl::StrFormat("--%s: %d is outside [%d, %d]", flag, value, lo, hi));
  }
  return absl::OkStatus();
}

// The machine's blend peak on the image's tiles: kPeakGaussians per tile
// through raster::BlendPeakTile (its widest kernel), tiles spread over the
// pool as the rasterizer's are.
constexpr int kPeakGaussians = 128;

struct BlendPeak {
  double ms_median = 0;
  double pairs_per_ms = 0;
};

BlendPeak MeasureBlendPeak(int width, int height, int64_t repeat, uint64_t seed) {
  const int64_t tiles = static_cast<int64_t>((width + raster::kTile - 1) / raster::kTile) *
                        ((height + raster::kTile - 1) / raster::kTile);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  std::vector<raster::PeakGaussian> gaussians(static_cast<size_t>(tiles) * kPeakGaussians);
  for (raster::PeakGaussian& g : gaussians) {
    const float sigma = 1.f + 5.f * u(rng);  // 1-6 px, round.
    g = {raster::kTile * u(rng), raster::kTile * u(rng), 1.f / (sigma * sigma),   0.f,
         1.f / (sigma * sigma),  0.05f + 0.45f * u(rng), {u(rng), u(rng), u(rng)}};
  }
  std::vector<float> out(static_cast<size_t>(tiles) * 4 * raster::kTilePixels);
  auto pass = [&]() {
    DefaultThreadPool().ParallelFor(0, tiles, 4, [&](int64_t begin, int64_t end) {
      for (int64_t t = begin; t < end; ++t) {
        raster::BlendPeakTile(&gaussians[t * kPeakGaussians], kPeakGaussians,
                              &out[t * 4 * raster::kTilePixels]);
      }
    });
  };
  pass();  // Warms the pool and the caches.
  std::vector<double> ms;
  for (int64_t r = 0; r < repeat; ++r) {
    const auto start = std::chrono::steady_clock::now();
    pass();
    ms.push_back(MsSince(start));
  }
  BlendPeak peak;
  peak.ms_median = Median(ms);
  const double pairs = static_cast<double>(tiles) * raster::kTilePixels * kPeakGaussians;
  peak.pairs_per_ms = peak.ms_median > 0 ? pairs / peak.ms_median : 0;
  return peak;
}

}  // namespace

absl::Status RunRasterBench(const std::vector<std::string>& args) {
  ASSIGN_OR_RETURN(CommandLine cl, CommandLine::Parse(args,
                                                      {"gaussians", "width", "height", "channels",
                                                       "repeat", "seed", "device"},
                                                      {"compare-cpu", "backward"}));
  if (!cl.positional().empty()) {
    return absl::InvalidArgumentError("unexpected argument '" + cl.positional()[0] + "'");
  }
  RETURN_IF_ERROR(cl.RequireBoth("width", "height"));
  ASSIGN_OR_RETURN(const int64_t gaussians, cl.GetInt("gaussians", 100000));
  ASSIGN_OR_RETURN(const int64_t width, cl.GetInt("width", 768));
  ASSIGN_OR_RETURN(const int64_t height, cl.GetInt("height", 576));
  ASSIGN_OR_RETURN(const int64_t channels, cl.GetInt("channels", 3));
  ASSIGN_OR_RETURN(const int64_t repeat, cl.GetInt("repeat", 10));
  ASSIGN_OR_RETURN(const int64_t seed, cl.GetInt("seed", 1));
  RETURN_IF_ERROR(CheckRange("gaussians", gaussians, 1, 50'000'000));
  RETURN_IF_ERROR(CheckRange("width", width, 1, 16384));
  RETURN_IF_ERROR(CheckRange("height", height, 1, 16384));
  RETURN_IF_ERROR(CheckRange("channels", channels, 3, 256));
  RETURN_IF_ERROR(CheckRange("repeat", repeat, 1, 1000));
  RETURN_IF_ERROR(CheckRange("seed", seed, 0, int64_t{1} << 62));
  ASSIGN_OR_RETURN(const ComputeDevice device,
                   ParseComputeDevice(cl.Get("device", "cpu"), "--device"));
  const bool gpu = device.kind == ComputeDevice::Kind::kCuda;
  const bool backward = cl.Has("backward");
  if (gpu && backward) {
    return absl::UnimplementedError(
        "--backward: the backward pass runs on the CPU only so far; drop --device or --backward");
  }
  if (gpu) {
    if (absl::Status s = CheckCudaDevice(device.index); !s.ok()) {
      return absl::FailedPreconditionError(
          absl::StrCat("--device ", device.ToString(), ": ", s.message()));
    }
  }

  const auto build_start = std::chrono::steady_clock::now();
  const BenchScene bench =
      MakeBenchScene(gaussians, static_cast<int>(width), static_cast<int>(height),
                     static_cast<int>(channels), static_cast<uint64_t>(seed));
  const double build_ms = MsSince(build_start);

  // On a GPU the scene is uploaded once, as a worker keeps its hot scene
  // there.
  std::unique_ptr<CudaScene> gpu_scene;
  double upload_ms = 0;
  if (gpu) {
    const auto start = std::chrono::steady_clock::now();
    ASSIGN_OR_RETURN(gpu_scene, CudaScene::Upload(bench.scene, device.index));
    upload_ms = MsSince(start);
  }
  RenderOptions options;
  CudaRenderTiming timing;
  auto render = [&]() -> absl::StatusOr<RenderBuffers> {
    if (gpu) return gpu_scene->Render(bench.camera, bench.timestamp_us, {}, options, &timing);
    return Render(bench.scene, bench.camera, bench.timestamp_us, {}, options);
  };
  // One untimed render warms caches and the thread pool (or the GPU).
  ASSIGN_OR_RETURN(RenderBuffers buffers, render());
  // Wall time per render, and the process CPU time (all threads) it used:
  // on a shared machine the second says what the work costs. On a GPU also
  // the kernels' own time and the copy of the outputs to host memory.
  std::vector<double> ms, cpu_ms, device_ms, download_ms, project_ms, sort_bin_ms, composite_ms;
  for (int64_t r = 0; r < repeat; ++r) {
    const std::clock_t cpu_start = std::clock();
    const auto start = std::chrono::steady_clock::now();
    ASSIGN_OR_RETURN(buffers, render());
    ms.push_back(MsSince(start));
    cpu_ms.push_back(1000.0 * static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC);
    device_ms.push_back(timing.device_ms);
    download_ms.push_back(timing.download_ms);
    project_ms.push_back(buffers.stats.project_ms);
    sort_bin_ms.push_back(buffers.stats.sort_bin_ms);
    composite_ms.push_back(buffers.stats.composite_ms);
  }
  std::vector<double> sorted = ms;
  std::sort(sorted.begin(), sorted.end());
  const double median = Median(ms);
  const double cpu_median = Median(cpu_ms);
  const RasterStats& stats = buffers.stats;
  double coverage = 0;
  for (float a : buffers.alpha) coverage += a;
  coverage /= static_cast<double>(buffers.alpha.size());

  std::string gpu_json;
  if (gpu && cl.Has("compare-cpu")) {
    // The same view on the CPU: how far the GPU's image is from it.
    ASSIGN_OR_RETURN(const RenderBuffers cpu,
                     Render(bench.scene, bench.camera, bench.timestamp_us, {}, options));
    double sum = 0, alpha_diff = 0;
    for (size_t k = 0; k < cpu.rgb.size(); ++k) {
      sum += (cpu.rgb[k] - buffers.rgb[k]) * (cpu.rgb[k] - buffers.rgb[k]);
    }
    for (size_t k = 0; k < cpu.alpha.size(); ++k) {
      alpha_diff = std::max(alpha_diff, std::abs(double{cpu.alpha[k]} - buffers.alpha[k]));
    }
    const double mse = sum / static_cast<double>(cpu.rgb.size());
    absl::StrAppendFormat(&gpu_json, ",\"psnr_vs_cpu\":%.2f,\"alpha_max_diff_vs_cpu\":%.2g",
                          mse > 0 ? 10 * std::log10(1 / mse) : 200.0, alpha_diff);
  }
  if (gpu) {
    absl::StrAppendFormat(&gpu_json,
                          ",\"gpu\":\"%s\",\"device_ms_median\":%.3f,\"device_ms_min\":%.3f,"
                          "\"download_ms_median\":%.3f,\"upload_ms\":%.1f,\"gpu_bytes\":%d",
                          CudaDeviceDescription(device.index), Median(device_ms),
                          *std::min_element(device_ms.begin(), device_ms.end()),
                          Median(download_ms), upload_ms, gpu_scene->device_bytes());
  }
  // On the CPU, the blend peak of this machine, measured in the same run:
  // what share of it the rasterizer's tested pairs reach.
  const double pairs_per_ms = median > 0 ? static_cast<double>(stats.pairs_tested) / median : 0.0;
  std::string cpu_json;
  if (!gpu) {
    const BlendPeak peak = MeasureBlendPeak(static_cast<int>(width), static_cast<int>(height),
                                            repeat, static_cast<uint64_t>(seed));
    // Where a CPU render's time goes, pass by pass.
    absl::StrAppendFormat(&cpu_json,
                          ",\"project_ms_median\":%.3f,\"sort_bin_ms_median\":%.3f,"
                          "\"composite_ms_median\":%.3f",
                          Median(project_ms), Median(sort_bin_ms), Median(composite_ms));
    absl::StrAppendFormat(&cpu_json,
                          ",\"peak_kernel\":\"%s\",\"peak_gaussians_per_tile\":%d,"
                          "\"peak_ms_median\":%.3f,\"peak_pairs_per_ms\":%.0f,"
                          "\"share_of_peak\":%.3f",
                          raster::BlendPeakKernelName(), kPeakGaussians, peak.ms_median,
                          peak.pairs_per_ms,
                          peak.pairs_per_ms > 0 ? pairs_per_ms / peak.pairs_per_ms : 0.0);
  }
  // The backward pass of the same view, for a loss that reads every output.
  std::string backward_json;
  if (backward) {
    RenderOutputGradients grads;
    std::mt19937 rng(static_cast<uint32_t>(seed));
    std::uniform_real_distribution<float> u(-1.f, 1.f);
    grads.rgb.resize(buffers.rgb.size());
    grads.alpha.resize(buffers.alpha.size());
    grads.depth.resize(buffers.depth.size());
    grads.features.resize(buffers.features.size());
    for (std::vector<float>* v : {&grads.rgb, &grads.alpha, &grads.depth, &grads.features}) {
      for (float& x : *v) x = u(rng);
    }
    BackwardStats bstats;
    auto run = [&]() -> absl::Status {
      return RenderBackward(bench.scene, bench.camera, bench.timestamp_us, {}, grads, options,
                            &bstats)
          .status();
    };
    RETURN_IF_ERROR(run());  // Warm.
    std::vector<double> bms, bcpu;
    for (int64_t r = 0; r < repeat; ++r) {
      const std::clock_t cpu_start = std::clock();
      const auto start = std::chrono::steady_clock::now();
      RETURN_IF_ERROR(run());
      bms.push_back(MsSince(start));
      bcpu.push_back(1000.0 * static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC);
    }
    const double bmedian = Median(bms);
    absl::StrAppendFormat(
        &backward_json,
        ",\"backward_ms_median\":%.3f,\"backward_ms_min\":%.3f,\"backward_cpu_ms_median\":%.3f,"
        "\"backward_over_forward\":%.2f,\"backward_tile_pairs\":%d,"
        "\"backward_pairs_contributing\":%d,\"backward_contributing_pairs_per_ms\":%.0f,"
        "\"forward_contributing_pairs_per_ms\":%.0f,\"backward_working_bytes\":%d",
        bmedian, *std::min_element(bms.begin(), bms.end()), Median(bcpu),
        median > 0 ? bmedian / median : 0.0, bstats.pairs, bstats.pairs_contributing,
        bmedian > 0 ? static_cast<double>(bstats.pairs_contributing) / bmedian : 0.0,
        median > 0 ? static_cast<double>(stats.pairs_contributing) / median : 0.0,
        bstats.working_bytes);
  }
  std::printf(
      "{\"benchmark\":\"raster\",\"device\":\"%s\",\"cpu\":\"%s\",\"gaussians\":%lld,\"width\":%"
      "lld,\"height\":%"
      "lld,"
      "\"channels\":%lld,\"threads\":%d,\"kernel\":\"%s\",\"repeat\":%lld,\"ms_median\":%.3f,"
      "\"ms_min\":%.3f,\"ms_max\":%.3f,\"cpu_ms_median\":%.3f,\"gaussians_visible\":%lld,\"pairs_"
      "tested\":%lld,"
      "\"pairs_contributing\":%lld,\"pairs_ratio\":%.3f,\"pairs_per_ms\":%.0f,"
      "\"mean_alpha\":%.4f,\"scene_build_ms\":%.1f%s%s%s,\"scene\":%s}\n",
      device.ToString().c_str(), CpuModel().c_str(), static_cast<long long>(gaussians),
      static_cast<long long>(width), static_cast<long long>(height),
      static_cast<long long>(channels), WorkingThreads(), gpu ? "cuda" : raster::TileKernelName(),
      static_cast<long long>(repeat), median, sorted[0], sorted.back(), cpu_median,
      static_cast<long long>(stats.gaussians_visible), static_cast<long long>(stats.pairs_tested),
      static_cast<long long>(stats.pairs_contributing),
      stats.pairs_contributing > 0
          ? static_cast<double>(stats.pairs_tested) / static_cast<double>(stats.pairs_contributing)
          : 0.0,
      pairs_per_ms, coverage, build_ms, cpu_json.c_str(), gpu_json.c_str(), backward_json.c_str(),
      bench.description.c_str());
  return absl::OkStatus();
}

}  // namespace pf
