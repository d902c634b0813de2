// pf in remote mode, run as a process, for what needs no server: an
// unreachable server is exit 3 with its address named, and bad local input
// (views file, clip files, job ids) is exit 2 before any connection.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>

#include "common/elapsed.h"
#include "engine/clip/clip_test_util.h"
#include "tests/test_util.h"

namespace pf {
namespace {

using testing::BinPath;
using testing::CommandResult;
using testing::RunCommand;

// Nothing listens on port 1 of the loopback.
constexpr char kNoServer[] = "127.0.0.1:1";

// Runs `argv` and returns its result and how long it took in seconds.
CommandResult RunTimed(const std::vector<std::string>& argv, double* seconds) {
  const auto start = std::chrono::steady_clock::now();
  CommandResult result = RunCommand(argv);
  *seconds = SecondsSince(start);
  return result;
}

TEST(RemoteCli, UnreachableServerIsExitThreeNamingIt) {
  double seconds = 0;
  const CommandResult result =
      RunTimed({BinPath("pf"), "--server", kNoServer, "scene", "list"}, &seconds);
  EXPECT_EQ(result.exit_code, 3) << result.err;
  EXPECT_NE(result.err.find("pf: server 127.0.0.1:1 unreachable: "), std::string::npos)
      << result.err;
  EXPECT_TRUE(result.out.empty()) << result.out;
  // The connection deadline is 5 s.
  EXPECT_LT(seconds, testing::TimeScale() * 10.0);
}

TEST(RemoteCli, ServerFromEnvironmentWhenNoFlag) {
  const CommandResult result = RunCommand(
      {"/usr/bin/env", std::string("PF_SERVER=") + kNoServer, BinPath("pf"), "jobs", "list"});
  EXPECT_EQ(result.exit_code, 3) << result.err;
  EXPECT_NE(result.err.find("pf: server 127.0.0.1:1 unreachable: "), std::string::npos)
      << result.err;
}

TEST(RemoteCli, JobsWithoutServerIsBadInput) {
  const CommandResult result =
      RunCommand({"/usr/bin/env", "-u", "PF_SERVER", BinPath("pf"), "jobs", "list"});
  EXPECT_EQ(result.exit_code, 2) << result.err;
  EXPECT_NE(result.err.find("--server"), std::string::npos) << result.err;
}

// Nothing listens at kNoServer, so a call to it would end the command with
// exit 3 "unreachable": exit 2 naming the file shows it was read first.
TEST(RemoteCli, MissingViewsFileIsExitTwoBeforeConnecting) {
  const std::string dir = testing::MakeTempDir("remote_cli");
  const std::string views = dir + "/missing.json";
  const CommandResult result = RunCommand({BinPath("pf"), "--server", kNoServer, "render", "S",
                                           "--cameras", views, "--out", dir + "/d"});
  EXPECT_EQ(result.exit_code, 2) << result.err;
  EXPECT_NE(result.err.find(views), std::string::npos) << result.err;
  EXPECT_EQ(result.err.find("unreachable"), std::string::npos) << result.err;
  EXPECT_FALSE(std::filesystem::exists(dir + "/d"));
}

// How a server scene was reconstructed is settled: reconstruction flags with
// `render SCENE` are refused (they are for `render --clip`), before anything
// else is read or the server is called.
TEST(RemoteCli, ReconstructionFlagsWithAServerSceneAreRefused) {
  const std::string dir = testing::MakeTempDir("remote_cli");
  for (const std::vector<std::string> flag : {std::vector<std::string>{"--low-pass", "0.3"},
                                              {"--model", "pixel-aligned"},
                                              {"--no-facades"}}) {
    std::vector<std::string> argv = {BinPath("pf"), "--server",  kNoServer,          "render",
                                     "scenes/s1",   "--cameras", dir + "/views.json"};
    argv.insert(argv.end(), flag.begin(), flag.end());
    const CommandResult result = RunCommand(argv);
    EXPECT_EQ(result.exit_code, 2) << result.err;
    EXPECT_NE(result.err.find(flag[0] + ": a reconstruction flag, only for render --clip; "
                                        "scenes/s1 is reconstructed already"),
              std::string::npos)
        << result.err;
  }
}

TEST(RemoteCli, MalformedViewsFileIsExitTwoNamingIt) {
  const std::string dir = testing::MakeTempDir("remote_cli");
  const std::string views = dir + "/views.json";
  { std::ofstream(views) << R"({"views": [{"camera": "front", "timestampUs": "soon"}]})"; }
  const CommandResult result =
      RunCommand({BinPath("pf"), "--server", kNoServer, "render", "scenes/s1", "--cameras", views,
                  "--wait", "--out", dir + "/d"});
  EXPECT_EQ(result.exit_code, 2) << result.err;
  EXPECT_NE(result.err.find(views + ": not a RenderViews JSON"), std::string::npos) << result.err;
}

TEST(RemoteCli, ClipWithMissingFileIsExitTwoNamingFieldAndPath) {
  const std::string dir = testing::MakeTempDir("remote_cli");
  const std::string manifest = testing::WriteTestClip(dir, testing::MakeTestClip(dir));
  std::filesystem::remove(dir + "/images/front_1.png");
  const CommandResult result =
      RunCommand({BinPath("pf"), "--server", kNoServer, "scene", "create", manifest, "--wait"});
  EXPECT_EQ(result.exit_code, 2) << result.err;
  EXPECT_NE(result.err.find("pf scene create: frames[2].image: file not found: "),
            std::string::npos)
      << result.err;
  EXPECT_NE(result.err.find("images/front_1.png"), std::string::npos) << result.err;
}

TEST(RemoteCli, SceneNameGivenAsJobIsExitTwo) {
  const CommandResult result =
      RunCommand({BinPath("pf"), "--server", kNoServer, "jobs", "get", "scenes/s1"});
  EXPECT_EQ(result.exit_code, 2) << result.err;
  EXPECT_NE(result.err.find("pf scene get scenes/s1"), std::string::npos) << result.err;
}

TEST(RemoteCli, LocalCommandWithServerIsRefused) {
  const CommandResult result =
      RunCommand({BinPath("pf"), "--server", kNoServer, "validate", "clip.json"});
  EXPECT_EQ(result.exit_code, 2) << result.err;
  EXPECT_NE(result.err.find("'validate' is not a remote command"), std::string::npos) << result.err;
  const CommandResult no_address = RunCommand({BinPath("pf"), "--server"});
  EXPECT_EQ(no_address.exit_code, 2) << no_address.err;
  EXPECT_NE(no_address.err.find("--server needs an address"), std::string::npos) << no_address.err;
}

TEST(RemoteCli, HelpAfterARemoteCommandPrintsItsUsage) {
  // `pf help` promises COMMAND --help; with --server it once said "unknown
  // flag --help". No server is needed for it.
  for (const std::vector<std::string> words : {std::vector<std::string>{"scene", "list", "--help"},
                                               {"scene", "create", "clip.json", "-h"},
                                               {"render", "--help"},
                                               {"jobs", "wait", "operations/x", "--help"}}) {
    std::vector<std::string> argv = {BinPath("pf"), "--server", kNoServer};
    argv.insert(argv.end(), words.begin(), words.end());
    const CommandResult result = RunCommand(argv);
    EXPECT_EQ(result.exit_code, 0) << words[0] << ": " << result.err;
    EXPECT_EQ(result.out.rfind("usage: pf --server ADDR " + words[0], 0), 0u) << result.out;
    EXPECT_TRUE(result.err.empty()) << result.err;
  }
}

// An --out directory that cannot be written is found before the job is
// submitted (exit 2 naming it), not after it has rendered.
TEST(RemoteCli, AnOutDirectoryThatCannotBeWrittenIsExitTwoBeforeConnecting) {
  const std::string dir = testing::MakeTempDir("remote_cli");
  const std::string views = dir + "/views.json";
  { std::ofstream(views) << R"({"views": [{"camera": "front"}]})"; }
  { std::ofstream(dir + "/file") << "x"; }
  const std::string out = dir + "/file/sub";  // Under a file: never creatable.
  for (const std::vector<std::string> words :
       {std::vector<std::string>{"render", "scenes/s1", "--cameras", views, "--wait", "--out", out},
        {"jobs", "wait", "operations/x", "--out", out}}) {
    std::vector<std::string> argv = {BinPath("pf"), "--server", kNoServer};
    argv.insert(argv.end(), words.begin(), words.end());
    const CommandResult result = RunCommand(argv);
    EXPECT_EQ(result.exit_code, 2) << words[0] << ": " << result.err;
    EXPECT_NE(result.err.find("--out: '" + out + "'"), std::string::npos) << result.err;
    EXPECT_EQ(result.err.find("unreachable"), std::string::npos) << result.err;
  }
}

}  // namespace
}  // namespace pf
