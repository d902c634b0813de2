// pf synth: placeholder until its issue lands; replaced by the real command.
#include "client/commands.h"

namespace pf {

int RunSynth(const std::vector<std::string>& args) {
  (void)args;
  return ReportError("synth", absl::UnimplementedError("not built yet"));
}

}  // namespace pf
