// Tests of the clip upload plan: which files, keyed how, and the errors for
// missing or misplaced files.
#include "client/remote/clip_upload.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <map>

#include "engine/clip/clip_test_util.h"
#include "tests/test_util.h"

namespace pf {
namespace {

TEST(PlanClipUpload, ListsEveryReferencedFileKeyedAsWritten) {
  const std::string dir = testing::MakeTempDir("clip_upload");
  const std::string manifest = testing::WriteTestClip(dir, testing::MakeTestClip(dir));
  const absl::StatusOr<ClipUploadPlan> plan = PlanClipUpload(manifest);
  ASSERT_TRUE(plan.ok()) << plan.status();
  EXPECT_EQ(plan->manifest_path, manifest);
  // 6 images, 3 depth maps ("front" frames) and 2 LiDAR sweeps.
  ASSERT_EQ(plan->files.size(), 11u);
  std::map<std::string, ClipFileUpload> by_key;
  for (const ClipFileUpload& file : plan->files) {
    EXPECT_TRUE(std::filesystem::is_regular_file(file.local_path)) << file.local_path;
    by_key[file.key] = file;
  }
  EXPECT_EQ(by_key.size(), 11u);
  ASSERT_EQ(by_key.count("images/front_1.png"), 1u);
  EXPECT_EQ(by_key["images/front_1.png"].field, "frames[2].image");
  EXPECT_EQ(std::filesystem::path(by_key["images/front_1.png"].local_path),
            std::filesystem::path(dir) / "images/front_1.png");
  EXPECT_EQ(plan->files.front().key, "images/front_0.png");
  EXPECT_EQ(plan->files.front().field, "frames[0].image");
}

TEST(PlanClipUpload, MissingFileNamesFieldAndPath) {
  const std::string dir = testing::MakeTempDir("clip_upload");
  const std::string manifest = testing::WriteTestClip(dir, testing::MakeTestClip(dir));
  std::filesystem::remove(dir + "/images/front_1.png");
  const absl::StatusOr<ClipUploadPlan> plan = PlanClipUpload(manifest);
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.status().code(), absl::StatusCode::kNotFound);
  const std::string message(plan.status().message());
  EXPECT_NE(message.find("frames[2].image: file not found: "), std::string::npos) << message;
  EXPECT_NE(message.find("images/front_1.png"), std::string::npos) << message;
}

TEST(PlanClipUpload, RefusesPathsOutsideTheManifestDirectory) {
  const std::string dir = testing::MakeTempDir("clip_upload");
  pointforward::v1::Clip clip = testing::MakeTestClip(dir);
  clip.mutable_frames(1)->set_image("../elsewhere.png");
  const absl::StatusOr<ClipUploadPlan> plan = PlanClipUpload(testing::WriteTestClip(dir, clip));
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(std::string(plan.status().message()).find("frames[1].image: '../elsewhere.png'"),
            std::string::npos)
      << plan.status();
}

TEST(PlanClipUpload, MissingManifestIsNotFound) {
  const std::string dir = testing::MakeTempDir("clip_upload");
  const absl::StatusOr<ClipUploadPlan> plan = PlanClipUpload(dir + "/nope.json");
  EXPECT_EQ(plan.status().code(), absl::StatusCode::kNotFound);
}

TEST(PrepareClipInput, FileUriIsSentAsIsAndMustBeAbsolute) {
  const absl::StatusOr<ClipInput> input = PrepareClipInput("file:///shared/clips/a/clip.json");
  ASSERT_TRUE(input.ok()) << input.status();
  EXPECT_EQ(input->uri, "file:///shared/clips/a/clip.json");
  EXPECT_TRUE(input->plan.files.empty());
  EXPECT_EQ(PrepareClipInput("file://relative/clip.json").status().code(),
            absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace pf
