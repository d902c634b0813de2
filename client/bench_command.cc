// pf bench: placeholder until its issue lands; replaced by the real command.
#include "client/commands.h"

namespace pf {

int RunBench(const std::vector<std::string>& args) {
  (void)args;
  return ReportError("bench", absl::UnimplementedError("not built yet"));
}

}  // namespace pf
