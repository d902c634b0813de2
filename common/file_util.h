// File helpers: whole-file reads, atomic writes, and resolving user-given
// relative paths under a root without letting them escape it.
#ifndef POINTFORWARD_COMMON_FILE_UTIL_H_
#define POINTFORWARD_COMMON_FILE_UTIL_H_

#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace pf {

// Returns the whole content of `path`; NOT_FOUND or another error naming the
// path.
absl::StatusOr<std::string> ReadFileToString(const std::string& path);

// Writes `contents` to `path` through a temporary file in the same directory
// and a rename, so a reader sees either the old file or the whole new one.
// Creates missing parent directories.
absl::Status WriteFileAtomic(const std::string& path, std::string_view contents);

// Returns a temporary name beside `path` for writers that must produce the
// file themselves (libraries that take a path); rename it over `path` with
// CommitTempFile() when complete. The name keeps `path`'s file name at its
// end, so libraries that pick a format by extension still do.
std::string TempPathFor(const std::string& path);

// A name for this process unique across machines and containers sharing a
// volume (where every process may be PID 1): "<hostname>-<pid>-<random>".
const std::string& ProcessToken();

// True when `token` is the ProcessToken() of a process of this machine that
// has ended: same host name, and its pid no longer running, or now ours
// (an earlier PID 1 of a restarted container). Never for another machine's
// token, nor for a malformed one.
bool ProcessTokenEnded(std::string_view token);

// Renames `temp_path` to `path`; removes `temp_path` and returns an error
// naming `path` if that fails.
absl::Status CommitTempFile(const std::string& temp_path, const std::string& path);

// Creates `dir` and its parents if missing.
absl::Status MakeDirs(const std::string& dir);

// Checks, before any work, that an output named by command-line flag `flag`
// (e.g. "--out") can be written where `path` says: INVALID_ARGUMENT naming
// the flag when a file is to be written where a directory is
// (CheckOutputFilePath) or a directory where a file is (CheckOutputDirPath).
absl::Status CheckOutputFilePath(const std::string& flag, const std::string& path);
absl::Status CheckOutputDirPath(const std::string& flag, const std::string& path);

// Checks that directory `dir` could be made and written: it, or the nearest
// ancestor that exists, is a directory in which a file can be written (one
// is written and removed). Creates nothing; INVALID_ARGUMENT naming `flag`
// and why not. For outputs that arrive only after long work.
absl::Status CheckWritableDir(const std::string& flag, const std::string& dir);

// Returns `text` (an error message) with every mention of directory `dir`
// replaced by `shown_as`; when `shown_as` is empty, "dir/x" becomes "x". For
// messages that must not show a private directory (a server's scratch
// space, a worker's work directory) to whoever receives them.
std::string HideDirectory(std::string_view text, const std::string& dir,
                          std::string_view shown_as = "");

// How ResolvePath treats paths outside the root.
enum class PathPolicy {
  kUnderRootOnly,  // Absolute paths and "..", symlinks out of root: rejected.
  kAllowOutside,   // Absolute paths allowed; relative ones are joined to root.
};

// Resolves `relative` (as written in a manifest) against `root` and returns
// the lexically normalised path. With kUnderRootOnly, an empty path, an
// absolute path, a path whose ".." components climb above `root`, or an
// existing path whose symlinks resolve outside `root` is INVALID_ARGUMENT
// ("escapes the clip directory", "is absolute").
absl::StatusOr<std::string> ResolvePath(const std::string& root, const std::string& relative,
                                        PathPolicy policy);

}  // namespace pf

#endif  // POINTFORWARD_COMMON_FILE_UTIL_H_
