// Helpers for tests: a fresh temporary directory, the sample-data directory,
// and running our binaries as child processes with their output captured.
#ifndef POINTFORWARD_TESTS_TEST_UTIL_H_
#define POINTFORWARD_TESTS_TEST_UTIL_H_

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace pf::testing {

// Returns a new empty directory under $TMPDIR (or /tmp), removed when the
// process exits normally.
std::string MakeTempDir(const std::string& prefix = "pf_test");

// Returns the sample-data directory (PF_DATA_DIR) if it exists, with
// `subdir` appended; nullopt when absent. Tests GTEST_SKIP() on nullopt with
// a message naming the setting.
std::optional<std::string> DataDir(const std::string& subdir = "");

// Returns the path of one of our binaries in build/bin (PF_BIN_DIR).
std::string BinPath(const std::string& name);

// Returns the repository root (PF_SOURCE_DIR).
std::string SourceDir();

struct CommandResult {
  int exit_code = -1;  // The exit status, or 128 + signal.
  std::string out;     // Standard output.
  std::string err;     // Standard error.
};

// Runs `argv` (argv[0] a path) to completion and captures its output.
CommandResult RunCommand(const std::vector<std::string>& argv);

// The JSON document in the file at `path` (report.json, manifest.json, ...);
// throws nlohmann::json::parse_error when it is missing or not JSON, which
// fails the calling test.
nlohmann::json ReadJsonFile(const std::string& path);

// Returns the bytes of an EXR file with the value of its "capDate" header
// attribute (the time of writing, which OpenImageIO adds as DateTime, to the
// second) blanked out, so two writes of the same image compare equal; PNGs
// and EXRs without the attribute are returned unchanged.
std::string WithoutDateTime(std::string bytes);

}  // namespace pf::testing

// Skips the current test when the sample data is missing.
#define PF_REQUIRE_DATA(var, subdir)                                            \
  const std::optional<std::string> var##_opt = ::pf::testing::DataDir(subdir);  \
  if (!var##_opt) {                                                             \
    GTEST_SKIP() << "sample data '" << (subdir)                                 \
                 << "' not found: set PF_DATA_DIR (CMake -DPF_DATA_DIR or the " \
                    "environment) to the shared/data directory";                \
  }                                                                             \
  const std::string var = *var##_opt

#endif  // POINTFORWARD_TESTS_TEST_UTIL_H_
