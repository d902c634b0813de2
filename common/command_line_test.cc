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

}  // namespace
}  // namespace pf
