// Helpers for tests: a fresh temporary directory, the sample-data directory,
// and running our binaries as child processes with their output captured.
#ifndef POINTFORWARD_TESTS_TEST_UTIL_H_
#define POINTFORWARD_TESTS_TEST_UTIL_H_

#include <chrono>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace pf::testing {

// How many times longer than in an optimised build on an idle machine a wait
// on the clock may need to be in this process: 3 under AddressSanitizer, 5
// under ThreadSanitizer (1 otherwise), times the load per core when that is
// above 1 (the one-minute load average over the online cores, read at each
// call), times PF_TEST_TIME_SCALE when set (a positive number). Never below 1.
double TimeScale();

// Returns `nominal` times TimeScale(): the deadline of a wait, or the bound a
// test puts on how long something took. Every wait on the clock in a test
// goes through it (WaitFor, ChildProcess::Kill and the RPC deadlines of
// tests/ do), so a sanitizer build or a busy machine only makes tests slower.
std::chrono::milliseconds Scaled(std::chrono::milliseconds nominal);

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
