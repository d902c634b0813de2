// pf render: placeholder until its issue lands; replaced by the real command.
#include "client/commands.h"

namespace pf {

int RunRender(const std::vector<std::string>& args) {
  (void)args;
  return ReportError("render", absl::UnimplementedError("not built yet"));
}

}  // namespace pf
