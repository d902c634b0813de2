// pf bench raster: times Render() on the street-like benchmark scene and
// prints one JSON object on stdout.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <vector>

#include "absl/strings/str_format.h"
#include "client/commands.h"
#include "common/command_line.h"
#include "common/status_macros.h"
#include "common/thread_pool.h"
#include "worker/engine/render/bench_scene.h"
#include "worker/engine/render/raster_tile.h"
#include "worker/engine/render/rasterizer.h"

namespace pf {
namespace {

// Returns INVALID_ARGUMENT naming `flag` unless lo <= value <= hi.
absl::Status CheckRange(const char* flag, int64_t value, int64_t lo, int64_t hi) {
  if (value < lo || value > hi) {
    return absl::InvalidArgumentError(
        absl::StrFormat("--%s: %d is outside [%d, %d]", flag, value, lo, hi));
  }
  return absl::OkStatus();
}

double Median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  const size_t mid = values.size() / 2;
  return values.size() % 2 == 1 ? values[mid] : 0.5 * (values[mid - 1] + values[mid]);
}

absl::Status BenchRaster(const std::vector<std::string>& args) {
  ASSIGN_OR_RETURN(CommandLine cl, CommandLine::Parse(args, {"gaussians", "width", "height",
                                                             "channels", "repeat", "seed"}));
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

  const auto build_start = std::chrono::steady_clock::now();
  const BenchScene bench =
      MakeBenchScene(gaussians, static_cast<int>(width), static_cast<int>(height),
                     static_cast<int>(channels), static_cast<uint64_t>(seed));
  const double build_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - build_start)
          .count();

  // One untimed render warms caches and the thread pool.
  RenderOptions options;
  ASSIGN_OR_RETURN(RenderBuffers buffers,
                   Render(bench.scene, bench.camera, bench.timestamp_us, {}, options));
  // Wall time per render, and the process CPU time (all threads) it used:
  // on a shared machine the second says what the work costs.
  std::vector<double> ms, cpu_ms;
  for (int64_t r = 0; r < repeat; ++r) {
    const std::clock_t cpu_start = std::clock();
    const auto start = std::chrono::steady_clock::now();
    ASSIGN_OR_RETURN(buffers, Render(bench.scene, bench.camera, bench.timestamp_us, {}, options));
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
                     .count());
    cpu_ms.push_back(1000.0 * static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC);
  }
  std::vector<double> sorted = ms;
  std::sort(sorted.begin(), sorted.end());
  const double median = Median(ms);
  const double cpu_median = Median(cpu_ms);
  const RasterStats& stats = buffers.stats;
  double coverage = 0;
  for (float a : buffers.alpha) coverage += a;
  coverage /= static_cast<double>(buffers.alpha.size());

  std::printf(
      "{\"benchmark\":\"raster\",\"gaussians\":%lld,\"width\":%lld,\"height\":%lld,"
      "\"channels\":%lld,\"threads\":%d,\"kernel\":\"%s\",\"repeat\":%lld,\"ms_median\":%.3f,"
      "\"ms_min\":%.3f,\"ms_max\":%.3f,\"cpu_ms_median\":%.3f,\"gaussians_visible\":%lld,\"pairs_"
      "tested\":%lld,"
      "\"pairs_contributing\":%lld,\"pairs_ratio\":%.3f,\"pairs_per_ms\":%.0f,"
      "\"mean_alpha\":%.4f,\"scene_build_ms\":%.1f,\"scene\":%s}\n",
      static_cast<long long>(gaussians), static_cast<long long>(width),
      static_cast<long long>(height), static_cast<long long>(channels),
      DefaultThreadPool().num_threads() + 1, raster::TileKernelName(),
      static_cast<long long>(repeat), median, sorted[0], sorted.back(), cpu_median,
      static_cast<long long>(stats.gaussians_visible), static_cast<long long>(stats.pairs_tested),
      static_cast<long long>(stats.pairs_contributing),
      stats.pairs_contributing > 0
          ? static_cast<double>(stats.pairs_tested) / static_cast<double>(stats.pairs_contributing)
          : 0.0,
      median > 0 ? static_cast<double>(stats.pairs_tested) / median : 0.0, coverage, build_ms,
      bench.description.c_str());
  return absl::OkStatus();
}

}  // namespace

int RunBench(const std::vector<std::string>& args) {
  if (args.empty() || args[0] != "raster") {
    return ReportError(
        "bench", absl::InvalidArgumentError("usage: pf bench raster [--gaussians N] [--width W "
                                            "--height H] [--channels C] [--repeat R] [--seed S]"));
  }
  const absl::Status status = BenchRaster({args.begin() + 1, args.end()});
  if (!status.ok()) return ReportError("bench raster", status);
  return kExitOk;
}

}  // namespace pf
