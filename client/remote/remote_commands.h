// The command groups of remote `pf` (one *.cc each) and the pieces they
// share. Each group takes the words after its name and returns the exit code
// for a finished command (0, or 1 when the job failed), or an error status
// that the dispatcher (remote_main.cc) reports and maps to an exit code.
#ifndef POINTFORWARD_CLIENT_REMOTE_REMOTE_COMMANDS_H_
#define POINTFORWARD_CLIENT_REMOTE_REMOTE_COMMANDS_H_

#include <cstdio>
#include <set>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "client/remote/remote_context.h"
#include "common/command_line.h"
#include "google/longrunning/operations.pb.h"
#include "pointforward/v1/resources.pb.h"
#include "pointforward/v1/service.pb.h"

namespace pf {

// pf scene create|get|list|delete|export (remote_scene.cc).
absl::StatusOr<int> RunRemoteScene(RemoteContext& ctx, const std::vector<std::string>& args);
// pf render SCENE | pf render --clip CLIP.json (remote_render.cc).
absl::StatusOr<int> RunRemoteRender(RemoteContext& ctx, const std::vector<std::string>& args);
// pf jobs list|get|cancel|wait (remote_jobs.cc).
absl::StatusOr<int> RunRemoteJobs(RemoteContext& ctx, const std::vector<std::string>& args);

// True when `args` ask for help (--help or -h anywhere): the command then
// prints its usage to stdout and exits 0, without connecting.
inline bool WantsHelp(const std::vector<std::string>& args) {
  for (const std::string& arg : args) {
    if (arg == "--help" || arg == "-h") return true;
  }
  return false;
}

// Returns the ReconstructionOptions the flags of `cl` ask for
// (remote_scene.cc); INVALID_ARGUMENT naming a bad flag.
absl::StatusOr<pointforward::v1::ReconstructionOptions> ReconstructionOptionsFromFlags(
    const CommandLine& cl);

// Prints a few lines describing `scene` (remote_scene.cc).
void PrintSceneSummary(std::FILE* out, const pointforward::v1::Scene& scene);

// Returns `message` as indented proto3 JSON (Any fields unpacked).
absl::StatusOr<std::string> ToJson(const google::protobuf::Message& message);

// For a done, successful render operation: fetches its RenderJob and
// downloads its files into `out_dir`, then prints "downloaded N files to DIR"
// (remote_render.cc).
absl::Status DownloadRenderResult(RemoteContext& ctx,
                                  const google::longrunning::Operation& operation,
                                  const std::string& out_dir);

}  // namespace pf

#endif  // POINTFORWARD_CLIENT_REMOTE_REMOTE_COMMANDS_H_
