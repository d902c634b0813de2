// pf import waymo|dgp: turns a driving log into a clip directory and prints
// one summary line (warnings, if any, go to stderr).
//
//   pf import waymo SEGMENT.tfrecord --out DIR [--cameras FRONT,FRONT_LEFT]
//       [--start-us T --duration-us D] [--roles paper|all-context]
//   pf import dgp SCENE_DIR --out DIR [--cameras CAMERA_01,...] [...same]
#include <cstdio>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "client/commands.h"
#include "common/command_line.h"
#include "common/file_util.h"
#include "common/status_macros.h"
#include "worker/engine/importers/clip_output.h"
#include "worker/engine/importers/dgp_importer.h"
#include "worker/engine/importers/waymo_importer.h"

namespace pf {
namespace {

constexpr char kImportUsage[] =
    "usage: pf import waymo SEGMENT.tfrecord --out DIR [--cameras A,B] "
    "[--start-us T] [--duration-us D] [--roles paper|all-context]\n"
    "       pf import dgp SCENE_DIR --out DIR [--cameras A,B] [--start-us T] "
    "[--duration-us D] [--roles paper|all-context]\n"
    "T and D are microseconds from the log's first timestamp.";

absl::StatusOr<ImportOptions> ParseOptions(const CommandLine& cl) {
  ImportOptions options;
  options.out_dir = cl.Get("out");
  if (options.out_dir.empty()) return absl::InvalidArgumentError("--out DIR is required");
  RETURN_IF_ERROR(CheckOutputDirPath("--out", options.out_dir));
  options.cameras = cl.GetList("cameras");
  ASSIGN_OR_RETURN(options.start_us, cl.GetInt("start-us", 0));
  if (options.start_us < 0) return absl::InvalidArgumentError("--start-us must be >= 0");
  if (cl.Has("duration-us")) {
    ASSIGN_OR_RETURN(int64_t duration, cl.GetInt("duration-us", 0));
    if (duration <= 0) return absl::InvalidArgumentError("--duration-us must be positive");
    options.duration_us = duration;
  }
  ASSIGN_OR_RETURN(options.roles, ParseRolePolicy(cl.Get("roles", "paper")));
  return options;
}

absl::StatusOr<std::string> Import(const std::vector<std::string>& args) {
  ASSIGN_OR_RETURN(CommandLine cl, CommandLine::Parse(args, {"out", "cameras", "start-us",
                                                             "duration-us", "roles"}));
  if (cl.positional().size() != 2) {
    return absl::InvalidArgumentError(
        absl::StrCat(cl.positional().empty() ? "expected a format (waymo or dgp) and a source path"
                                             : "expected a source path after the format",
                     "\n", kImportUsage));
  }
  const std::string& format = cl.positional()[0];
  const std::string& source = cl.positional()[1];
  ASSIGN_OR_RETURN(ImportOptions options, ParseOptions(cl));
  ImportResult result;
  if (format == "waymo") {
    ASSIGN_OR_RETURN(result, ImportWaymo(source, options));
  } else if (format == "dgp") {
    ASSIGN_OR_RETURN(result, ImportDgp(source, options));
  } else {
    return absl::InvalidArgumentError(
        absl::StrCat("unknown format '", format, "' (waymo or dgp)\n", kImportUsage));
  }
  for (const std::string& warning : result.warnings) {
    std::fprintf(stderr, "pf import: warning: %s\n", warning.c_str());
  }
  return absl::StrCat(result.manifest_path, ": ", SummarizeClip(result.clip));
}

}  // namespace

int RunImport(const std::vector<std::string>& args) {
  const absl::StatusOr<std::string> summary = Import(args);
  if (!summary.ok()) {
    // A corrupt or truncated log (DATA_LOSS) is bad input, not a failure here.
    const int code = ReportError("import", summary.status());
    return summary.status().code() == absl::StatusCode::kDataLoss ? kExitBadInput : code;
  }
  std::printf("%s\n", summary->c_str());
  return kExitOk;
}

}  // namespace pf
