// pf bench raster: the rasterizer benchmark (engine/render/raster_bench.h).
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/commands.h"
#include "engine/render/raster_bench.h"

namespace pf {

int RunBench(const std::vector<std::string>& args) {
  if (args.empty() || args[0] != "raster") {
    return ReportError("bench", absl::InvalidArgumentError(
                                    absl::StrCat("usage: pf bench raster ", kRasterBenchUsage)));
  }
  const absl::Status status = RunRasterBench({args.begin() + 1, args.end()});
  if (!status.ok()) return ReportError("bench raster", status);
  return kExitOk;
}

}  // namespace pf
