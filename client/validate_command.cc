// pf validate CLIP.json [--allow-outside-paths]: checks a clip manifest and the
// files it references. Prints one summary line on stdout and exits 0 when the
// clip is valid; otherwise prints every problem as "FIELD: MESSAGE", one per
// line on stdout, and exits 2.
#include <cstdio>
#include <string>
#include <vector>

#include "client/commands.h"
#include "common/command_line.h"
#include "engine/clip/clip_validator.h"

namespace pf {

int RunValidate(const std::vector<std::string>& args) {
  absl::StatusOr<CommandLine> cl = CommandLine::Parse(args, {}, {"allow-outside-paths"});
  if (!cl.ok()) return ReportError("validate", cl.status());
  if (cl->positional().size() != 1) {
    return ReportError("validate", absl::InvalidArgumentError(
                                       "usage: pf validate CLIP.json [--allow-outside-paths]"));
  }
  const std::string& path = cl->positional()[0];
  ValidateOptions options;
  options.allow_outside_paths = cl->Has("allow-outside-paths");

  const ClipReport report = ValidateClipFile(path, options);
  if (report.ok()) {
    std::printf("valid: %s\n", report.summary.ToString().c_str());
    return kExitOk;
  }
  for (const ClipProblem& problem : report.problems) {
    std::printf("%s\n", ClipProblemLine(problem, path).c_str());
  }
  std::fflush(stdout);
  std::fprintf(stderr, "pf validate: %zu problem%s in %s\n", report.problems.size(),
               report.problems.size() == 1 ? "" : "s", path.c_str());
  return kExitBadInput;
}

}  // namespace pf
