// The subcommands of `pf`. Each takes the words after its name and returns
// the process exit code: 0 success, 1 failure (a job failed or was
// cancelled), 2 bad input, 3 server unreachable. Each lives in its own
// *_command.cc.
#ifndef POINTFORWARD_CLIENT_COMMANDS_H_
#define POINTFORWARD_CLIENT_COMMANDS_H_

#include <string>
#include <vector>

#include "absl/status/status.h"

namespace pf {

// Exit codes shared by all subcommands.
inline constexpr int kExitOk = 0;
inline constexpr int kExitFailed = 1;
inline constexpr int kExitBadInput = 2;
inline constexpr int kExitUnreachable = 3;

// Maps a Status to an exit code: bad input (INVALID_ARGUMENT, NOT_FOUND,
// OUT_OF_RANGE, FAILED_PRECONDITION, ALREADY_EXISTS) is 2, UNAVAILABLE is 3,
// anything else that is not OK is 1.
int ExitCodeFor(const absl::Status& status);

// Prints "pf <command>: <message>" to stderr and returns ExitCodeFor(status).
int ReportError(const std::string& command, const absl::Status& status);

int RunValidate(const std::vector<std::string>& args);     // pf validate
int RunSynth(const std::vector<std::string>& args);        // pf synth [render]
int RunImport(const std::vector<std::string>& args);       // pf import waymo|dgp
int RunScene(const std::vector<std::string>& args);        // pf scene info|export
int RunRender(const std::vector<std::string>& args);       // pf render
int RunBench(const std::vector<std::string>& args);        // pf bench raster|reconstruct
int RunReconstruct(const std::vector<std::string>& args);  // pf reconstruct
int RunEval(const std::vector<std::string>& args);         // pf eval
int RunDepthEval(const std::vector<std::string>& args);    // pf depth-eval
int RunLidar(const std::vector<std::string>& args);        // pf lidar spec

}  // namespace pf

#endif  // POINTFORWARD_CLIENT_COMMANDS_H_
