// Test helpers.
#include "tests/test_util.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>

#include "common/subprocess.h"

namespace pf::testing {
namespace {

namespace fs = std::filesystem;

std::mutex g_dirs_mutex;
std::vector<std::string>* g_dirs = nullptr;

void RemoveTempDirs() {
  std::lock_guard<std::mutex> lock(g_dirs_mutex);
  if (g_dirs == nullptr || std::getenv("PF_KEEP_TEST_DIRS") != nullptr) return;
  for (const std::string& dir : *g_dirs) {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
}

std::string EnvOr(const char* name, const std::string& fallback) {
  const char* value = std::getenv(name);
  return value != nullptr && *value != '\0' ? value : fallback;
}

// The slowdown of this build's sanitizer, if any.
double SanitizerSlowdown() {
#if defined(__SANITIZE_THREAD__)
  return 5;
#elif defined(__SANITIZE_ADDRESS__)
  return 3;
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
  return 5;
#elif __has_feature(address_sanitizer)
  return 3;
#else
  return 1;
#endif
#else
  return 1;
#endif
}

}  // namespace

double TimeScale() {
  double scale = SanitizerSlowdown();
  double load[1];
  const long cores = ::sysconf(_SC_NPROCESSORS_ONLN);
  if (::getloadavg(load, 1) == 1 && cores > 0) scale *= std::max(1.0, load[0] / cores);
  if (const char* extra = std::getenv("PF_TEST_TIME_SCALE"); extra != nullptr) {
    const double factor = std::atof(extra);
    if (factor > 0 && std::isfinite(factor)) scale *= factor;
  }
  return std::max(1.0, scale);
}

std::chrono::milliseconds Scaled(std::chrono::milliseconds nominal) {
  return std::chrono::milliseconds(
      static_cast<int64_t>(std::ceil(static_cast<double>(nominal.count()) * TimeScale())));
}

std::string MakeTempDir(const std::string& prefix) {
  std::string pattern = (fs::path(EnvOr("TMPDIR", "/tmp")) / (prefix + "_XXXXXX")).string();
  if (::mkdtemp(pattern.data()) == nullptr) std::abort();
  std::lock_guard<std::mutex> lock(g_dirs_mutex);
  if (g_dirs == nullptr) {
    g_dirs = new std::vector<std::string>();
    std::atexit(RemoveTempDirs);
  }
  g_dirs->push_back(pattern);
  return pattern;
}

std::optional<std::string> DataDir(const std::string& subdir) {
  const std::string root = EnvOr("PF_DATA_DIR", PF_DEFAULT_DATA_DIR);
  if (root.empty()) return std::nullopt;
  const fs::path path = subdir.empty() ? fs::path(root) : fs::path(root) / subdir;
  std::error_code ec;
  if (!fs::exists(path, ec)) return std::nullopt;
  return path.string();
}

std::string BinPath(const std::string& name) {
  return (fs::path(EnvOr("PF_BIN_DIR", PF_DEFAULT_BIN_DIR)) / name).string();
}

std::string SourceDir() { return EnvOr("PF_SOURCE_DIR", PF_DEFAULT_SOURCE_DIR); }

CommandResult RunCommand(const std::vector<std::string>& argv) {
  CommandResult result;
  absl::StatusOr<ProcessResult> run = RunProcess(argv);
  if (!run.ok()) {
    result.err = std::string(run.status().message());
    return result;
  }
  result.exit_code = run->exit_code;
  result.out = std::move(run->out);
  result.err = std::move(run->err);
  return result;
}

std::string WithoutDateTime(std::string bytes) {
  const std::string attribute("capDate\0string\0", 15);
  const size_t at = bytes.find(attribute);
  if (at == std::string::npos || at + attribute.size() + 4 > bytes.size()) return bytes;
  const size_t value = at + attribute.size() + 4;  // After the int32 size.
  const uint8_t* size = reinterpret_cast<const uint8_t*>(&bytes[at + attribute.size()]);
  const size_t length = size[0] | size[1] << 8 | size[2] << 16 | size_t{size[3]} << 24;
  for (size_t i = value; i < std::min(bytes.size(), value + length); ++i) bytes[i] = '-';
  return bytes;
}

nlohmann::json ReadJsonFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return nlohmann::json::parse(text.str());
}

}  // namespace pf::testing
