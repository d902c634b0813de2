// pf bench raster: the rasterizer benchmark (engine/render/raster_bench.h).
// pf bench reconstruct CLIP.json [reconstruction flags] [--repeat N]: the
// whole reconstruction of a clip N times (default 3), its stages' median
// seconds, the Gaussians and the peak memory, as one JSON line on stdout;
// compare two builds by running both on the same clip in turn. The first run
// also pays for fresh memory (common/memory_reuse.h): seconds_first.
#include <algorithm>
#include <cstdio>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/commands.h"
#include "common/bench_info.h"
#include "common/command_line.h"
#include "common/status_macros.h"
#include "engine/clip/clip_validator.h"
#include "engine/recon/recon_option_table.h"
#include "engine/recon/recon_options.h"
#include "engine/recon/reconstruction.h"
#include "engine/render/raster_bench.h"
#include "nlohmann/json.hpp"

namespace pf {
namespace {

constexpr char kReconstructBenchUsage[] =
    "CLIP.json [--repeat N] [the flags of pf reconstruct but --out]";

absl::Status RunReconstructBench(const std::vector<std::string>& args) {
  std::set<std::string> value_flags = ReconValueFlags();
  value_flags.insert("repeat");
  std::set<std::string> switches = ReconSwitchFlags();
  switches.insert("allow-outside-paths");
  ASSIGN_OR_RETURN(const CommandLine cl, CommandLine::Parse(args, value_flags, switches));
  if (cl.positional().size() != 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("usage: pf bench reconstruct ", kReconstructBenchUsage));
  }
  ASSIGN_OR_RETURN(const int64_t repeat, cl.GetInt("repeat", 3));
  if (repeat < 1 || repeat > 100) {
    return absl::InvalidArgumentError(absl::StrCat("--repeat: must be in [1, 100], got ", repeat));
  }
  ASSIGN_OR_RETURN(const ReconOptions options, ReconOptionsFromFlags(cl));
  ValidateOptions validate;
  validate.allow_outside_paths = options.allow_outside_paths;
  ASSIGN_OR_RETURN(const LoadedClip loaded, LoadValidClip(cl.positional()[0], validate));

  std::map<std::string, std::vector<double>> stage_seconds;
  std::vector<std::string> order;
  std::vector<double> totals;
  int64_t gaussians = 0;
  int views = 0;
  for (int64_t run = 0; run < repeat; ++run) {
    ASSIGN_OR_RETURN(const ReconResult result, Reconstruct(loaded, options));
    for (const auto& [stage, seconds] : result.stats.stage_seconds) {
      if (run == 0) order.push_back(stage);
      stage_seconds[stage].push_back(seconds);
    }
    totals.push_back(result.stats.total_seconds);
    gaussians = static_cast<int64_t>(result.scene.size());
    views = result.stats.views;
    std::fprintf(stderr, "pf bench reconstruct: run %lld/%lld: %.2f s, %lld Gaussians\n",
                 static_cast<long long>(run + 1), static_cast<long long>(repeat),
                 result.stats.total_seconds, static_cast<long long>(gaussians));
  }
  nlohmann::ordered_json stages = nlohmann::ordered_json::object();
  for (const std::string& stage : order) stages[stage] = Median(stage_seconds[stage]);
  nlohmann::ordered_json out = {{"benchmark", "reconstruct"},
                                {"clip", cl.positional()[0]},
                                {"model", options.model},
                                {"cpu", CpuModel()},
                                {"threads", WorkingThreads()},
                                {"device", options.device.ToString()},
                                {"views", views},
                                {"gaussians", gaussians},
                                {"repeat", repeat},
                                {"seconds_median", Median(totals)},
                                {"seconds_min", *std::min_element(totals.begin(), totals.end())},
                                {"seconds_first", totals.front()},
                                {"stage_seconds_median", stages},
                                {"peak_rss_mib", double(PeakRssBytes()) / (1 << 20)}};
  std::printf("%s\n", out.dump().c_str());
  return absl::OkStatus();
}

}  // namespace

int RunBench(const std::vector<std::string>& args) {
  const std::string what = args.empty() ? "" : args[0];
  const std::vector<std::string> rest(args.begin() + (args.empty() ? 0 : 1), args.end());
  absl::Status status;
  if (what == "raster") {
    status = RunRasterBench(rest);
  } else if (what == "reconstruct") {
    status = RunReconstructBench(rest);
  } else {
    return ReportError("bench", absl::InvalidArgumentError(absl::StrCat(
                                    "usage: pf bench raster ", kRasterBenchUsage,
                                    "\n       pf bench reconstruct ", kReconstructBenchUsage)));
  }
  if (!status.ok()) return ReportError(absl::StrCat("bench ", what), status);
  return kExitOk;
}

}  // namespace pf
