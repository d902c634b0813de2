// Tests of the long-poll caps: per caller, in all, and places given back.
#include "server/long_polls.h"

#include <gtest/gtest.h>

#include <optional>
#include <utility>
#include <vector>

namespace pf {
namespace {

TEST(LongPollLimiter, CapsEachCallerAndAllCallers) {
  LongPollLimiter limiter(/*max_total=*/3, /*max_per_caller=*/2);
  std::vector<LongPollLimiter::Slot> held;
  for (int i = 0; i < 2; ++i) {
    absl::StatusOr<LongPollLimiter::Slot> slot = limiter.Acquire("alice");
    ASSERT_TRUE(slot.ok()) << slot.status();
    held.push_back(*std::move(slot));
  }
  const absl::StatusOr<LongPollLimiter::Slot> third = limiter.Acquire("alice");
  EXPECT_EQ(third.status().code(), absl::StatusCode::kResourceExhausted);
  EXPECT_NE(third.status().message().find("--max-long-polls-per-caller"), std::string::npos)
      << third.status();
  // Bob is not held back by Alice's polls, up to the cap of all.
  absl::StatusOr<LongPollLimiter::Slot> bob = limiter.Acquire("bob");
  ASSERT_TRUE(bob.ok()) << bob.status();
  const absl::StatusOr<LongPollLimiter::Slot> carol = limiter.Acquire("carol");
  EXPECT_EQ(carol.status().code(), absl::StatusCode::kResourceExhausted);
  EXPECT_NE(carol.status().message().find("(pf-server --max-long-polls)"), std::string::npos)
      << carol.status();
  EXPECT_EQ(limiter.InFlight(), 3);
  EXPECT_EQ(limiter.InFlight("alice"), 2);
  EXPECT_EQ(limiter.InFlight("carol"), 0);

  // A poll that ends gives its place back.
  held.pop_back();
  EXPECT_EQ(limiter.InFlight("alice"), 1);
  EXPECT_TRUE(limiter.Acquire("carol").ok());  // Taken and given back at once.
  EXPECT_EQ(limiter.InFlight(), 2);
}

TEST(LongPollLimiter, ZeroMeansNoCap) {
  LongPollLimiter limiter(0, 0);
  std::vector<LongPollLimiter::Slot> held;
  for (int i = 0; i < 100; ++i) held.push_back(*limiter.Acquire("alice"));
  EXPECT_EQ(limiter.InFlight(), 100);
  held.clear();
  EXPECT_EQ(limiter.InFlight(), 0);
}

}  // namespace
}  // namespace pf
