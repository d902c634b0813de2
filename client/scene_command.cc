// pf scene: placeholder until its issue lands; replaced by the real command.
#include "client/commands.h"

namespace pf {

int RunScene(const std::vector<std::string>& args) {
  (void)args;
  return ReportError("scene", absl::UnimplementedError("not built yet"));
}

}  // namespace pf
