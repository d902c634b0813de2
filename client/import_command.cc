// pf import: placeholder until its issue lands; replaced by the real command.
#include "client/commands.h"

namespace pf {

int RunImport(const std::vector<std::string>& args) {
  (void)args;
  return ReportError("import", absl::UnimplementedError("not built yet"));
}

}  // namespace pf
