// Tests of the token file, the bearer header and the Authenticator's lookup
// and reload, over real files.
#include "server/auth.h"

#include <atomic>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "common/hash.h"
#include "gtest/gtest.h"
#include "tests/test_util.h"

namespace pf {
namespace {

constexpr char kAlice[] = "alice-token-0123456789";
constexpr char kFarm[] = "farm-token-0123456789ab";

std::string Line(const std::string& token, const std::string& rest) {
  return Sha256Hex(token) + " " + rest + "\n";
}

TEST(ParseTokenFile, ReadsOwnersAndRolesSkippingCommentsAndBlankLines) {
  const std::string text = "# tokens\n\n" + Line(kAlice, "alice") + "  " +
                           Line(kFarm, "farm worker") + Line("root-token-0123456789", "ops\tadmin");
  absl::StatusOr<std::vector<TokenEntry>> tokens = ParseTokenFile(text, "t.txt");
  ASSERT_TRUE(tokens.ok()) << tokens.status();
  ASSERT_EQ(tokens->size(), 3u);
  EXPECT_EQ((*tokens)[0].sha256_hex, Sha256Hex(kAlice));
  EXPECT_EQ((*tokens)[0].owner, "alice");
  EXPECT_EQ((*tokens)[0].role, Role::kUser);
  EXPECT_EQ((*tokens)[1].owner, "farm");
  EXPECT_EQ((*tokens)[1].role, Role::kWorker);
  EXPECT_EQ((*tokens)[2].owner, "ops");
  EXPECT_EQ((*tokens)[2].role, Role::kAdmin);
}

TEST(ParseTokenFile, NamesTheFileLineAndProblem) {
  const auto error = [](const std::string& text) {
    return std::string(ParseTokenFile(text, "t.txt").status().message());
  };
  EXPECT_EQ(
      error(Line(kAlice, "alice") + "ABC alice\n").rfind("t.txt:2: 'ABC' is not a SHA-256", 0), 0u);
  EXPECT_EQ(error(Sha256Hex(kAlice) + "\n").rfind("t.txt:1: 1 words", 0), 0u);
  EXPECT_EQ(error(Line(kAlice, "alice root")).rfind("t.txt:1: unknown role 'root'", 0), 0u);
  EXPECT_EQ(error(Line(kAlice, "alice") + Line(kAlice, "bob")).rfind("t.txt:2: the same token", 0),
            0u);
  EXPECT_NE(error(Line(kAlice, "alice admin extra")).find("4 words"), std::string::npos);
}

TEST(HashToken, IsTheSha256AndRefusesShortOrSpacedTokens) {
  EXPECT_EQ(*HashToken(kAlice), Sha256Hex(kAlice));
  EXPECT_EQ(HashToken("short").status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(HashToken("a token with spaces in it").status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(BearerToken, ParsesTheSchemeCaseInsensitively) {
  EXPECT_EQ(*BearerToken("Bearer abc"), "abc");
  EXPECT_EQ(*BearerToken("bearer  abc "), "abc");
  EXPECT_EQ(BearerToken("").status().message(), "missing bearer token");
  EXPECT_EQ(BearerToken("Basic abc").status().code(), absl::StatusCode::kUnauthenticated);
  EXPECT_EQ(BearerToken("Bearer ").status().code(), absl::StatusCode::kUnauthenticated);
}

TEST(Authenticator, OffLetsEveryoneInAsAdmin) {
  Authenticator off;
  EXPECT_FALSE(off.enabled());
  absl::StatusOr<Caller> caller = off.AuthenticateHeader("");
  ASSERT_TRUE(caller.ok());
  EXPECT_EQ(caller->owner, "");
  EXPECT_TRUE(caller->admin());
}

TEST(Authenticator, FindsTokensAndPicksUpChangesWithinTheReloadInterval) {
  const std::string path = testing::MakeTempDir("auth_test") + "/tokens.txt";
  std::ofstream(path) << Line(kAlice, "alice");
  absl::StatusOr<std::unique_ptr<Authenticator>> auth = Authenticator::FromFile(path);
  ASSERT_TRUE(auth.ok()) << auth.status();

  absl::StatusOr<Caller> alice = (*auth)->AuthenticateHeader(std::string("Bearer ") + kAlice);
  ASSERT_TRUE(alice.ok()) << alice.status();
  EXPECT_EQ(alice->owner, "alice");
  EXPECT_FALSE(alice->worker());
  EXPECT_EQ((*auth)->AuthenticateHeader("").status().message(), "missing bearer token");
  EXPECT_EQ((*auth)->AuthenticateHeader(std::string("Bearer ") + kFarm).status().message(),
            "unknown token");

  // Added: known after the reload interval.
  std::ofstream(path, std::ios::app) << Line(kFarm, "farm worker");
  std::this_thread::sleep_for(Authenticator::kReloadInterval + std::chrono::milliseconds(100));
  absl::StatusOr<Caller> farm = (*auth)->AuthenticateHeader(std::string("Bearer ") + kFarm);
  ASSERT_TRUE(farm.ok()) << farm.status();
  EXPECT_TRUE(farm->worker());
  EXPECT_FALSE(farm->admin());

  // A malformed file keeps the tokens read before.
  std::ofstream(path) << "garbage\n";
  std::this_thread::sleep_for(Authenticator::kReloadInterval + std::chrono::milliseconds(100));
  EXPECT_TRUE((*auth)->AuthenticateHeader(std::string("Bearer ") + kFarm).ok());

  // Removed: refused after the reload interval.
  std::ofstream(path) << Line(kAlice, "alice");
  std::this_thread::sleep_for(Authenticator::kReloadInterval + std::chrono::milliseconds(100));
  EXPECT_EQ((*auth)->AuthenticateHeader(std::string("Bearer ") + kFarm).status().code(),
            absl::StatusCode::kUnauthenticated);
  EXPECT_TRUE((*auth)->AuthenticateHeader(std::string("Bearer ") + kAlice).ok());
}

TEST(Authenticator, FromFileRefusesAMissingFile) {
  absl::StatusOr<std::unique_ptr<Authenticator>> auth =
      Authenticator::FromFile("/nonexistent/tokens.txt");
  EXPECT_EQ(auth.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(std::string(auth.status().message()).find("/nonexistent/tokens.txt"),
            std::string::npos);
}

// The server authenticates on every gRPC thread at once while the file is
// replaced (as an operator's `mv` does): every call sees either the old or
// the new token set, never a half-read one. Run under ThreadSanitizer by
// `make test-tsan`.
TEST(Authenticator, ConcurrentCallersDuringReloadsSeeWholeTokenSets) {
  const std::string dir = testing::MakeTempDir("auth_test");
  const std::string path = dir + "/tokens.txt";
  std::ofstream(path) << Line(kAlice, "alice");
  absl::StatusOr<std::unique_ptr<Authenticator>> auth = Authenticator::FromFile(path);
  ASSERT_TRUE(auth.ok()) << auth.status();

  std::atomic<bool> stop{false};
  std::atomic<int> alice_refused{0}, wrong_owner{0}, calls{0};
  std::vector<std::thread> callers;
  for (int i = 0; i < 4; ++i) {
    callers.emplace_back([&] {
      while (!stop.load()) {
        absl::StatusOr<Caller> alice = (*auth)->AuthenticateHeader(std::string("Bearer ") + kAlice);
        if (!alice.ok()) {
          ++alice_refused;
        } else if (alice->owner != "alice") {
          ++wrong_owner;
        }
        absl::StatusOr<Caller> farm = (*auth)->AuthenticateHeader(std::string("Bearer ") + kFarm);
        if (farm.ok() && farm->owner != "farm") ++wrong_owner;
        ++calls;
      }
    });
  }
  // Four replacements, one per reload interval, alternately adding and
  // removing the farm's token; the last one leaves it in.
  for (int round = 0; round < 4; ++round) {
    const std::string next = dir + "/tokens.next";
    std::ofstream(next) << Line(kAlice, "alice")
                        << (round % 2 == 1 ? Line(kFarm, "farm worker") : "");
    std::filesystem::rename(next, path);
    std::this_thread::sleep_for(Authenticator::kReloadInterval + std::chrono::milliseconds(150));
  }
  stop = true;
  for (std::thread& t : callers) t.join();

  EXPECT_GT(calls.load(), 100);
  EXPECT_EQ(alice_refused.load(), 0);
  EXPECT_EQ(wrong_owner.load(), 0);
  absl::StatusOr<Caller> farm = (*auth)->AuthenticateHeader(std::string("Bearer ") + kFarm);
  ASSERT_TRUE(farm.ok()) << farm.status();
  EXPECT_TRUE(farm->worker());
}

}  // namespace
}  // namespace pf
