// The exit codes and error line every subcommand of `pf` shares, local and
// remote (client/commands.h).
#include "client/commands.h"

#include <cstdio>
#include <string>

namespace pf {

int ExitCodeFor(const absl::Status& status) {
  switch (status.code()) {
    case absl::StatusCode::kOk:
      return kExitOk;
    case absl::StatusCode::kInvalidArgument:
    case absl::StatusCode::kNotFound:
    case absl::StatusCode::kOutOfRange:
    case absl::StatusCode::kFailedPrecondition:
    case absl::StatusCode::kAlreadyExists:
      return kExitBadInput;
    case absl::StatusCode::kUnavailable:
      return kExitUnreachable;
    default:
      return kExitFailed;
  }
}

int ReportError(const std::string& command, const absl::Status& status) {
  std::fprintf(stderr, "pf %s: %s\n", command.c_str(), std::string(status.message()).c_str());
  return ExitCodeFor(status);
}

}  // namespace pf
