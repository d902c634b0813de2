// File helpers.
#include "common/file_util.h"

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "common/status_macros.h"

namespace pf {
namespace fs = std::filesystem;

absl::StatusOr<std::string> ReadFileToString(const std::string& path) {
  std::error_code dir_ec;
  if (fs::is_directory(path, dir_ec)) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": is a directory, not a file"));
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    std::error_code ec;
    if (!fs::exists(path, ec)) return absl::NotFoundError(absl::StrCat(path, ": file not found"));
    return absl::PermissionDeniedError(absl::StrCat(path, ": cannot open: ", std::strerror(errno)));
  }
  std::ostringstream buffer;
  buffer << in.rdbuf();
  if (in.bad()) return absl::DataLossError(absl::StrCat(path, ": read error"));
  return std::move(buffer).str();
}

namespace {

// This machine's name as ProcessToken() writes it: letters and digits, '_'
// for anything else, at most 32 characters.
std::string HostToken() {
  char host[256] = {};
  if (gethostname(host, sizeof(host) - 1) != 0) host[0] = '\0';
  std::string name;
  for (const char* c = host; *c != '\0' && name.size() < 32; ++c) {
    name += std::isalnum(static_cast<unsigned char>(*c)) ? *c : '_';
  }
  return name.empty() ? "host" : name;
}

}  // namespace

const std::string& ProcessToken() {
  static const std::string token = [] {
    std::random_device random;
    return absl::StrCat(HostToken(), "-", ::getpid(), "-", absl::Hex(random(), absl::kZeroPad8));
  }();
  return token;
}

bool ProcessTokenEnded(std::string_view token) {
  const std::vector<std::string> parts =
      absl::StrSplit(absl::string_view(token.data(), token.size()), '-');
  int64_t pid = 0;
  if (parts.size() != 3 || parts[0] != HostToken() || !absl::SimpleAtoi(parts[1], &pid) ||
      pid <= 0) {
    return false;
  }
  if (token == ProcessToken()) return false;
  if (pid == ::getpid()) return true;  // An earlier process with our pid (PID 1 in a container).
  return ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH;
}

std::string HideDirectory(std::string_view text, const std::string& dir,
                          std::string_view shown_as) {
  std::string out(text);
  if (dir.empty()) return out;
  std::string trimmed = dir;
  while (trimmed.size() > 1 && trimmed.back() == '/') trimmed.pop_back();
  size_t at = 0;
  while ((at = out.find(trimmed, at)) != std::string::npos) {
    size_t length = trimmed.size();
    if (shown_as.empty() && at + length < out.size() && out[at + length] == '/') ++length;
    out.replace(at, length, shown_as);
    at += shown_as.size();
  }
  return out;
}

std::string TempPathFor(const std::string& path) {
  static std::atomic<int> counter{0};
  const fs::path p(path);
  return (p.parent_path() /
          absl::StrCat(".pf-tmp-", ProcessToken(), "-", counter++, "-", p.filename().string()))
      .string();
}

absl::Status CommitTempFile(const std::string& temp_path, const std::string& path) {
  std::error_code ec;
  fs::rename(temp_path, path, ec);
  if (ec) {
    const std::string reason = ec.message();
    const bool is_dir = fs::is_directory(path, ec);
    fs::remove(temp_path, ec);
    if (is_dir) {
      return absl::FailedPreconditionError(
          absl::StrCat(path, ": is a directory (give a file path to write)"));
    }
    return absl::InternalError(absl::StrCat(path, ": rename failed: ", reason));
  }
  return absl::OkStatus();
}

absl::Status CheckOutputFilePath(const std::string& flag, const std::string& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    return absl::InvalidArgumentError(
        absl::StrCat(flag, ": '", path, "' is a directory; give the path of the file to write"));
  }
  return absl::OkStatus();
}

absl::Status CheckOutputDirPath(const std::string& flag, const std::string& path) {
  std::error_code ec;
  if (fs::exists(path, ec) && !fs::is_directory(path, ec)) {
    return absl::InvalidArgumentError(absl::StrCat(
        flag, ": '", path, "' is a file; give a directory (it is created if missing)"));
  }
  return absl::OkStatus();
}

absl::Status CheckWritableDir(const std::string& flag, const std::string& dir) {
  RETURN_IF_ERROR(CheckOutputDirPath(flag, dir));
  // The directory, or the nearest ancestor that exists: where the first
  // file or directory would be made.
  std::error_code ec;
  fs::path existing = fs::absolute(dir, ec).lexically_normal();
  while (!fs::exists(existing, ec) && existing.has_relative_path()) {
    existing = existing.parent_path();
  }
  if (!fs::is_directory(existing, ec)) {
    return absl::InvalidArgumentError(absl::StrCat(flag, ": '", dir, "' cannot be created: '",
                                                   existing.string(), "' is not a directory"));
  }
  const std::string probe = (existing / absl::StrCat(".pf-write-check-", ProcessToken())).string();
  std::FILE* file = std::fopen(probe.c_str(), "wb");
  if (file == nullptr) {
    return absl::InvalidArgumentError(absl::StrCat(
        flag, ": '", dir, "' is not writable: ", existing.string(), ": ", std::strerror(errno)));
  }
  std::fclose(file);
  fs::remove(probe, ec);
  return absl::OkStatus();
}

absl::Status MakeDirs(const std::string& dir) {
  if (dir.empty()) return absl::OkStatus();
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec)
    return absl::InternalError(absl::StrCat(dir, ": cannot create directory: ", ec.message()));
  return absl::OkStatus();
}

absl::Status WriteFileAtomic(const std::string& path, std::string_view contents) {
  const fs::path parent = fs::path(path).parent_path();
  if (!parent.empty()) {
    if (absl::Status s = MakeDirs(parent.string()); !s.ok()) return s;
  }
  const std::string temp = TempPathFor(path);
  {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    if (!out)
      return absl::InternalError(absl::StrCat(path, ": cannot write: ", std::strerror(errno)));
    out.write(contents.data(), static_cast<std::streamsize>(contents.size()));
    out.flush();
    if (!out) {
      out.close();
      std::error_code ec;
      fs::remove(temp, ec);
      return absl::InternalError(absl::StrCat(path, ": write failed (disk full?)"));
    }
  }
  return CommitTempFile(temp, path);
}

absl::StatusOr<std::string> ResolvePath(const std::string& root, const std::string& relative,
                                        PathPolicy policy) {
  if (relative.empty()) return absl::InvalidArgumentError("path is empty");
  if (relative.find('\0') != std::string::npos) {
    return absl::InvalidArgumentError("path contains a NUL character");
  }
  const fs::path rel(relative);
  if (rel.is_absolute()) {
    if (policy == PathPolicy::kAllowOutside) return rel.lexically_normal().string();
    return absl::InvalidArgumentError(
        absl::StrCat("'", relative, "' is absolute; paths must be relative to the clip directory"));
  }
  const fs::path root_abs = fs::absolute(root).lexically_normal();
  const fs::path joined = (root_abs / rel).lexically_normal();
  if (policy == PathPolicy::kAllowOutside) return joined.string();
  const fs::path inside = joined.lexically_relative(root_abs);
  if (inside.empty() || *inside.begin() == "..") {
    return absl::InvalidArgumentError(absl::StrCat("'", relative, "' escapes the clip directory"));
  }
  // Symlinks: compare the real locations where the file exists.
  std::error_code ec;
  const fs::path real_root = fs::weakly_canonical(root_abs, ec);
  const fs::path real = fs::weakly_canonical(joined, ec);
  if (!ec) {
    const fs::path real_inside = real.lexically_relative(real_root);
    if (real_inside.empty() || *real_inside.begin() == "..") {
      return absl::InvalidArgumentError(
          absl::StrCat("'", relative, "' escapes the clip directory through a symbolic link"));
    }
  }
  return joined.string();
}

}  // namespace pf
