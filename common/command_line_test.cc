// Tests for the command-line parser.
#include "common/command_line.h"

#include <gtest/gtest.h>

namespace pf {
namespace {

TEST(CommandLine, ParsesValuesBooleansAndPositionals) {
  auto cl = CommandLine::Parse({"clip.json", "--out", "dir", "--seed=7", "--wait", "extra"},
                               {"out", "seed"}, {"wait"});
  ASSERT_TRUE(cl.ok()) << cl.status();
  EXPECT_EQ(cl->positional(), (std::vector<std::string>{"clip.json", "extra"}));
  EXPECT_EQ(cl->Get("out"), "dir");
  EXPECT_EQ(*cl->GetInt("seed", 1), 7);
  EXPECT_EQ(*cl->GetInt("absent", 42), 42);
  EXPECT_TRUE(cl->Has("wait"));
  EXPECT_FALSE(cl->Has("out-missing"));
}

TEST(CommandLine, RejectsUnknownFlagsAndMissingValuesNamingThem) {
  auto unknown = CommandLine::Parse({"--bogus", "1"}, {"out"});
  ASSERT_FALSE(unknown.ok());
  EXPECT_NE(unknown.status().message().find("--bogus"), std::string::npos);
  auto missing = CommandLine::Parse({"--out"}, {"out"});
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.status().message().find("--out needs a value"), std::string::npos);
  auto cl = CommandLine::Parse({"--seed", "x1"}, {"seed"});
  ASSERT_TRUE(cl.ok());
  EXPECT_NE(cl->GetInt("seed", 0).status().message().find("--seed"), std::string::npos);
}

TEST(CommandLine, DoubleDashEndsFlags) {
  auto cl = CommandLine::Parse({"--", "--out"}, {"out"});
  ASSERT_TRUE(cl.ok());
  EXPECT_EQ(cl->positional(), std::vector<std::string>{"--out"});
}

TEST(CommandLine, RequireNamesTheFirstMissingFlagAndShowsTheUsage) {
  auto cl = CommandLine::Parse({"scene", "--out", "dir"}, {"out", "cameras"});
  ASSERT_TRUE(cl.ok());
  EXPECT_TRUE(cl->Require({"out"}, "usage: x").ok());
  const absl::Status missing = cl->Require({"out", "cameras"}, "usage: pf render ...");
  EXPECT_EQ(missing.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(missing.message(), "--cameras: required\nusage: pf render ...");
}

TEST(CommandLine, RequireBothNamesTheMissingPartner) {
  auto width_only = CommandLine::Parse({"--width", "64"}, {"width", "height"});
  ASSERT_TRUE(width_only.ok());
  EXPECT_EQ(width_only->RequireBoth("width", "height").message(),
            "--height: required with --width");
  auto height_only = CommandLine::Parse({"--height", "48"}, {"width", "height"});
  EXPECT_EQ(height_only->RequireBoth("width", "height").message(),
            "--width: required with --height");
  auto both = CommandLine::Parse({"--height", "48", "--width", "64"}, {"width", "height"});
  EXPECT_TRUE(both->RequireBoth("width", "height").ok());
  auto neither = CommandLine::Parse({}, {"width", "height"});
  EXPECT_TRUE(neither->RequireBoth("width", "height").ok());
}

// Empty items are kept for the caller to reject ("--lane-shift 1,,2" is a
// typo, not two shifts); an absent flag gives no items.
TEST(CommandLine, GetListKeepsEmptyItems) {
  auto cl = CommandLine::Parse({"--a", "1,,2", "--b", "", "--c", "x,y"}, {"a", "b", "c", "d"});
  ASSERT_TRUE(cl.ok());
  EXPECT_EQ(cl->GetList("a"), (std::vector<std::string>{"1", "", "2"}));
  EXPECT_EQ(cl->GetList("b"), std::vector<std::string>{""});
  EXPECT_EQ(cl->GetList("c"), (std::vector<std::string>{"x", "y"}));
  EXPECT_TRUE(cl->GetList("d").empty());
}

TEST(ExitStatusFor, BadFlagsAreTwoOtherErrorsOne) {
  EXPECT_EQ(ExitStatusFor("prog", absl::OkStatus()), 0);
  EXPECT_EQ(ExitStatusFor("prog", absl::InvalidArgumentError("--runs: 1 to 100, got 0")), 2);
  EXPECT_EQ(ExitStatusFor("prog", absl::NotFoundError("clip.json: no such file")), 1);
  EXPECT_EQ(ExitStatusFor("prog", absl::InternalError("broken")), 1);
}

}  // namespace
}  // namespace pf
