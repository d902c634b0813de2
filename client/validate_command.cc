// pf validate: placeholder until its issue lands; replaced by the real command.
#include "client/commands.h"

namespace pf {

int RunValidate(const std::vector<std::string>& args) {
  (void)args;
  return ReportError("validate", absl::UnimplementedError("not built yet"));
}

}  // namespace pf
