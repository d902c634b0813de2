// Available memory from /proc/meminfo and the cgroup's limit.
#include "common/memory_info.h"

#include <algorithm>
#include <charconv>
#include <fstream>
#include <sstream>
#include <string>

namespace pf {
namespace {

// The whole file, or "" where it cannot be read.
std::string ReadSmallFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) return "";
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string_view Trim(std::string_view text) {
  const size_t begin = text.find_first_not_of(" \t\r\n");
  if (begin == std::string_view::npos) return {};
  return text.substr(begin, text.find_last_not_of(" \t\r\n") - begin + 1);
}

// A decimal count of bytes, or -1.
int64_t ParseBytes(std::string_view text) {
  text = Trim(text);
  int64_t value = -1;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || value < 0) return -1;
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
  std::string_view rest = meminfo.substr(at + kKey.size());
  rest = rest.substr(0, rest.find('\n'));
  rest = Trim(rest);
  if (rest.size() < 2 || rest.substr(rest.size() - 2) != "kB") return -1;
  const int64_t kib = ParseBytes(rest.substr(0, rest.size() - 2));
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
