// Running a program as a child process and collecting its output: for
// helpers the engine calls out to (the PandaSet pickle reader) and for tests
// that run our binaries.
#ifndef POINTFORWARD_COMMON_SUBPROCESS_H_
#define POINTFORWARD_COMMON_SUBPROCESS_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace pf {

struct ProcessResult {
  int exit_code = -1;  // The exit status, or 128 + signal.
  std::string out;     // Standard output.
  std::string err;     // Standard error.
};

// Runs `argv` (argv[0] a path; PATH is not searched) with this process's
// environment, waits for it and returns its exit status and output.
// NOT_FOUND naming argv[0] when it cannot be started (missing or not
// executable); INTERNAL when the pipes cannot be made.
absl::StatusOr<ProcessResult> RunProcess(const std::vector<std::string>& argv);

}  // namespace pf

#endif  // POINTFORWARD_COMMON_SUBPROCESS_H_
