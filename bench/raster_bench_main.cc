// pf_raster_bench: `pf bench raster` as a program of its own, which needs
// only the rasterizer's libraries (for GPU machines that have none of the
// service's other dependencies; scripts/cuda-raster-run.sh).
#include <cstdio>
#include <string>
#include <vector>

#include "engine/render/raster_bench.h"

int main(int argc, char** argv) {
  const std::vector<std::string> args(argv + 1, argv + argc);
  const absl::Status status = pf::RunRasterBench(args);
  if (!status.ok()) {
    std::fprintf(stderr, "pf_raster_bench: %s\nusage: pf_raster_bench %s\n",
                 std::string(status.message()).c_str(), pf::kRasterBenchUsage);
    return 2;
  }
  return 0;
}
