// Machine and process facts for benchmarks: see machine_info.h.
#include "common/machine_info.h"

#include <sys/resource.h>

#include <fstream>

#include "absl/strings/ascii.h"
#include "common/thread_pool.h"

namespace pf {

std::string CpuModel() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("model name", 0) == 0) {
      const size_t colon = line.find(':');
      if (colon != std::string::npos) {
        return std::string(absl::StripAsciiWhitespace(line.substr(colon + 1)));
      }
    }
  }
  return "unknown";
}

int WorkingThreads() { return DefaultThreadPool().num_threads() + 1; }

int64_t PeakRssBytes() {
  struct rusage usage {};
  if (getrusage(RUSAGE_SELF, &usage) != 0) return 0;
  return int64_t{usage.ru_maxrss} * 1024;  // Linux reports KiB.
}

}  // namespace pf
