// Tests of CONTEXT/TARGET assignment: the paper's protocol, all context, and
// alternating frames per camera.
#include "engine/importers/frame_roles.h"

#include <gtest/gtest.h>

#include <vector>

namespace pf {
namespace {

using pointforward::v1::Clip;
using pointforward::v1::Frame;

Clip MakeClip(const std::vector<std::pair<std::string, int64_t>>& frames) {
  Clip clip;
  for (const auto& [camera, t] : frames) {
    Frame* f = clip.add_frames();
    f->set_camera(camera);
    f->set_timestamp_us(t);
  }
  return clip;
}

std::vector<int> ContextIndices(const Clip& clip) {
  std::vector<int> out;
  for (int i = 0; i < clip.frames_size(); ++i) {
    if (clip.frames(i).role() == Frame::CONTEXT) {
      out.push_back(i);
    } else {
      EXPECT_EQ(clip.frames(i).role(), Frame::TARGET);
    }
  }
  return out;
}

TEST(FrameRoles, TenHertzTwoSecondsGivesContextAtZeroToOnePointFive) {
  std::vector<std::pair<std::string, int64_t>> frames;
  const int64_t start = 1'000'000'000;
  for (int i = 0; i < 20; ++i) frames.push_back({"FRONT", start + i * 100'000 + 1'000});
  Clip clip = MakeClip(frames);
  AssignRoles(RolePolicy::kPaper, &clip);
  EXPECT_EQ(ContextIndices(clip), (std::vector<int>{0, 5, 10, 15}));
}

TEST(FrameRoles, EachCameraGetsItsOwnNearestFrames) {
  // Camera B runs 30 ms behind camera A.
  std::vector<std::pair<std::string, int64_t>> frames;
  for (int i = 0; i < 20; ++i) {
    frames.push_back({"A", i * 100'000});
    frames.push_back({"B", i * 100'000 + 30'000});
  }
  Clip clip = MakeClip(frames);
  AssignRoles(RolePolicy::kPaper, &clip);
  // A at 0, 5, 10, 15 (indices 0, 10, 20, 30); B likewise (1, 11, 21, 31).
  EXPECT_EQ(ContextIndices(clip), (std::vector<int>{0, 1, 10, 11, 20, 21, 30, 31}));
}

TEST(FrameRoles, SparseClipTakesOnlyFramesNearTheInstants) {
  // Three frames about one second apart (the DGP sample): 0 s and 1 s are
  // context; nothing is near 0.5 s or 1.5 s, so the frame at 2 s is a target.
  Clip clip = MakeClip({{"C", 0}, {"C", 999'990}, {"C", 1'999'940}});
  AssignRoles(RolePolicy::kPaper, &clip);
  EXPECT_EQ(ContextIndices(clip), (std::vector<int>{0, 1}));
}

TEST(FrameRoles, CameraStartingLateGetsOneContextFrame) {
  // Camera L's frames are all 300 ms or more from the context instants.
  Clip clip = MakeClip({{"A", 0}, {"A", 500'000}, {"L", 800'000}, {"L", 2'300'000}});
  AssignRoles(RolePolicy::kPaper, &clip);
  EXPECT_EQ(ContextIndices(clip), (std::vector<int>{0, 1, 2}));
}

TEST(FrameRoles, SingleFrameIsContext) {
  Clip clip = MakeClip({{"FRONT", 42}});
  AssignRoles(RolePolicy::kPaper, &clip);
  EXPECT_EQ(ContextIndices(clip), (std::vector<int>{0}));
}

TEST(FrameRoles, AllContextPolicyAndParsing) {
  Clip clip = MakeClip({{"C", 0}, {"C", 3'000'000}, {"C", 9'000'000}});
  AssignRoles(RolePolicy::kAllContext, &clip);
  EXPECT_EQ(ContextIndices(clip), (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(*ParseRolePolicy("paper"), RolePolicy::kPaper);
  EXPECT_EQ(*ParseRolePolicy("all-context"), RolePolicy::kAllContext);
  EXPECT_EQ(*ParseRolePolicy("alternate"), RolePolicy::kAlternate);
  const auto bad = ParseRolePolicy("everything");
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(std::string(bad.status().message()).find("--roles"), std::string::npos);
}

TEST(FrameRoles, AlternatePolicyTakesEveryOtherFramePerCameraInTimeOrder) {
  // Frames listed out of time order; camera B has an odd count and runs 30 ms
  // behind A.
  Clip clip = MakeClip({{"A", 200'000},
                        {"A", 0},
                        {"B", 30'000},
                        {"A", 100'000},
                        {"B", 130'000},
                        {"A", 300'000},
                        {"B", 230'000}});
  AssignRoles(RolePolicy::kAlternate, &clip);
  // A in time order: 0 (index 1), 100k (3), 200k (0), 300k (5): context 1, 0.
  // B: 30k (2), 130k (4), 230k (6): context 2, 6.
  EXPECT_EQ(ContextIndices(clip), (std::vector<int>{0, 1, 2, 6}));
}

}  // namespace
}  // namespace pf
