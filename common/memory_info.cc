// Available memory from /proc/meminfo and the cgroup's limit.
#include "common/memory_info.h"

#include <algorithm>
#include <sstream>
#include <string>

#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/strip.h"
#include "common/file_util.h"

namespace pf {
namespace {

// The whole file, or "" where it cannot be read.
std::string ReadSmallFile(const std::string& path) { return ReadFileToString(path).value_or(""); }

// A decimal count of bytes (surrounding whitespace allowed), or -1.
int64_t ParseBytes(std::string_view text) {
  int64_t value = -1;
  if (!absl::SimpleAtoi(absl::string_view(text.data(), text.size()), &value) || value < 0) {
    return -1;
  }
  return value;
}

// The value of `key` in a cgroup memory.stat text ("key value" lines), or 0.
int64_t StatValue(std::string_view stat, std::string_view key) {
  std::istringstream lines{std::string(stat)};
  for (std::string name, value; lines >> name >> value;) {
    if (name == key) return std::max<int64_t>(0, ParseBytes(value));
  }
  return 0;
}

// The least room under the limits of the process's cgroup and its
// ancestors, or -1.
int64_t CgroupRoomOfProcess() {
  // cgroup v2: "0::/path" in /proc/self/cgroup; inside a container the
  // group is usually the namespace's root, /sys/fs/cgroup itself.
  std::string path;
  std::istringstream groups(ReadSmallFile("/proc/self/cgroup"));
  for (std::string line; std::getline(groups, line);) {
    if (line.rfind("0::", 0) == 0) path = line.substr(3);
  }
  constexpr std::string_view kRoot = "/sys/fs/cgroup";
  int64_t least = -1;
  bool any_v2 = false;
  for (std::string dir = std::string(kRoot) + path;;) {
    while (dir.size() > kRoot.size() && dir.back() == '/') dir.pop_back();
    const std::string limit = ReadSmallFile(dir + "/memory.max");
    if (!limit.empty()) {
      any_v2 = true;
      const int64_t room =
          CgroupRoom(limit, ReadSmallFile(dir + "/memory.current"),
                     StatValue(ReadSmallFile(dir + "/memory.stat"), "inactive_file"));
      if (room >= 0) least = least < 0 ? room : std::min(least, room);
    }
    if (dir.size() <= kRoot.size()) break;
    dir = dir.substr(0, dir.rfind('/'));
  }
  if (any_v2) return least;
  const std::string v1 = std::string(kRoot) + "/memory";
  return CgroupRoom(ReadSmallFile(v1 + "/memory.limit_in_bytes"),
                    ReadSmallFile(v1 + "/memory.usage_in_bytes"),
                    StatValue(ReadSmallFile(v1 + "/memory.stat"), "total_inactive_file"));
}

}  // namespace

int64_t MemAvailableFromMeminfo(std::string_view meminfo) {
  constexpr std::string_view kKey = "MemAvailable:";
  const size_t at = meminfo.find(kKey);
  if (at == std::string_view::npos) return -1;
  std::string_view line = meminfo.substr(at + kKey.size());
  line = line.substr(0, line.find('\n'));
  absl::string_view rest = absl::StripAsciiWhitespace(absl::string_view(line.data(), line.size()));
  if (!absl::ConsumeSuffix(&rest, "kB")) return -1;
  const int64_t kib = ParseBytes(std::string_view(rest.data(), rest.size()));
  return kib < 0 ? -1 : 1024 * kib;
}

int64_t CgroupRoom(std::string_view limit, std::string_view usage, int64_t reclaimable) {
  const int64_t max = ParseBytes(limit);
  const int64_t used = ParseBytes(usage);
  // cgroup v1 writes "no limit" as the largest page multiple under 2^63.
  constexpr int64_t kNoLimit = int64_t{1} << 62;
  if (max < 0 || used < 0 || max >= kNoLimit) return -1;
  return std::max<int64_t>(0, max - std::max<int64_t>(0, used - std::max<int64_t>(0, reclaimable)));
}

int64_t AvailableMemoryBytes() {
  const int64_t system = MemAvailableFromMeminfo(ReadSmallFile("/proc/meminfo"));
  const int64_t group = CgroupRoomOfProcess();
  if (system < 0) return group;
  if (group < 0) return system;
  return std::min(system, group);
}

}  // namespace pf
