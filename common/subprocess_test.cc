// Tests of RunProcess: exit status, both output streams, signals, and a
// program that cannot be started.
#include "common/subprocess.h"

#include <gtest/gtest.h>

namespace pf {
namespace {

TEST(RunProcess, CapturesExitStatusAndBothStreams) {
  const auto run = RunProcess({"/bin/sh", "-c", "echo out; echo err >&2; exit 7"});
  ASSERT_TRUE(run.ok()) << run.status();
  EXPECT_EQ(run->exit_code, 7);
  EXPECT_EQ(run->out, "out\n");
  EXPECT_EQ(run->err, "err\n");
}

TEST(RunProcess, KilledBySignalIs128PlusTheSignal) {
  const auto run = RunProcess({"/bin/sh", "-c", "kill -9 $$"});
  ASSERT_TRUE(run.ok()) << run.status();
  EXPECT_EQ(run->exit_code, 128 + 9);
}

TEST(RunProcess, MissingProgramIsNotFoundNamingIt) {
  const auto run = RunProcess({"/nonexistent/python3", "-c", "pass"});
  ASSERT_FALSE(run.ok());
  EXPECT_EQ(run.status().code(), absl::StatusCode::kNotFound);
  EXPECT_NE(run.status().message().find("/nonexistent/python3"), absl::string_view::npos);
}

}  // namespace
}  // namespace pf
