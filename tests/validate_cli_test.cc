// End-to-end tests of `pf validate`: the real binary on a valid clip (one
// summary line, exit 0) and on broken ones (every problem with its field
// path, exit 2).
#include <filesystem>
#include <string>
#include <vector>

#include "absl/strings/str_split.h"
#include "common/file_util.h"
#include "engine/clip/clip_test_util.h"
#include "gtest/gtest.h"
#include "pointforward/v1/clip.pb.h"
#include "tests/test_util.h"

namespace pf {
namespace {

namespace fs = std::filesystem;
using testing::BinPath;
using testing::CommandResult;
using testing::MakeTempDir;
using testing::RunCommand;

// Returns the path of the pf binary.
std::string Pf() { return BinPath("pf"); }

std::vector<std::string> Lines(const std::string& text) {
  return absl::StrSplit(text, '\n', absl::SkipEmpty());
}

TEST(ValidateCli, ValidClipPrintsOneSummaryLine) {
  const std::string dir = MakeTempDir("validate_cli_ok");
  const std::string manifest = testing::WriteTestClip(dir, testing::MakeTestClip(dir));
  const CommandResult result = RunCommand({Pf(), "validate", manifest});
  EXPECT_EQ(result.exit_code, 0) << result.out << result.err;
  EXPECT_EQ(result.out,
            "valid: 2 cameras, 6 frames (2 CONTEXT, 4 TARGET), timestamps 0..200000 us, "
            "1 instance, 2 LiDAR sweeps\n");
}

TEST(ValidateCli, BrokenClipListsEveryProblemAndExits2) {
  const std::string dir = MakeTempDir("validate_cli_bad");
  pointforward::v1::Clip clip = testing::MakeTestClip(dir);
  clip.mutable_frames(1)->set_camera("rear");
  clip.mutable_frames(4)->set_world_from_camera(0, 0.7);  // det = 0.7.
  clip.mutable_instances(0)->mutable_boxes(1)->set_size(0, 0);
  fs::remove(dir + "/images/front_1.png");
  const std::string manifest = testing::WriteTestClip(dir, clip);

  const CommandResult result = RunCommand({Pf(), "validate", manifest});
  EXPECT_EQ(result.exit_code, 2) << result.out << result.err;
  const std::vector<std::string> lines = Lines(result.out);
  ASSERT_EQ(lines.size(), 4u) << result.out;
  EXPECT_EQ(lines[0], "frames[1].camera: unknown camera id 'rear' (known: front, left)");
  EXPECT_EQ(lines[1].rfind("frames[2].image: ", 0), 0u) << lines[1];
  EXPECT_NE(lines[1].find("file not found"), std::string::npos) << lines[1];
  EXPECT_EQ(lines[2].rfind("frames[4].worldFromCamera: not a rigid transform (det = 0.7,", 0), 0u)
      << lines[2];
  EXPECT_EQ(lines[3], "instances[0].boxes[1].size[0]: box size must be positive, got 0");
  EXPECT_NE(result.err.find("4 problems"), std::string::npos) << result.err;
}

TEST(ValidateCli, SchemaProblemsNameTheField) {
  const std::string dir = MakeTempDir("validate_cli_schema");
  const std::string manifest = dir + "/clip.json";
  ASSERT_TRUE(WriteFileAtomic(manifest, R"({"cameras": [{"id": "a", "width": "640"}],
      "frames": [{"camera": "a", "imag": "x.png"}]})")
                  .ok());
  const CommandResult result = RunCommand({Pf(), "validate", manifest});
  EXPECT_EQ(result.exit_code, 2);
  // "640" as a string is a valid proto3 JSON integer; "imag" is not a field.
  EXPECT_EQ(result.out, "frames[0].imag: unknown field (did you mean 'image'?)\n");
}

TEST(ValidateCli, MalformedJsonNamesFileLineAndColumn) {
  const std::string dir = MakeTempDir("validate_cli_json");
  const std::string manifest = dir + "/clip.json";
  ASSERT_TRUE(WriteFileAtomic(manifest, "{\n  \"cameras\": [\n").ok());
  const CommandResult result = RunCommand({Pf(), "validate", manifest});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_EQ(result.out.rfind(manifest + ": malformed JSON: parse error at line 3", 0), 0u)
      << result.out;
}

TEST(ValidateCli, OutsidePathsNeedTheFlag) {
  const std::string dir = MakeTempDir("validate_cli_outside");
  const std::string other = MakeTempDir("validate_cli_outside_files");
  pointforward::v1::Clip clip = testing::MakeTestClip(dir);
  testing::WriteTestImage(other + "/far.png", testing::kTestWidth, testing::kTestHeight);
  clip.mutable_frames(0)->set_image(other + "/far.png");
  const std::string manifest = testing::WriteTestClip(dir, clip);

  const CommandResult strict = RunCommand({Pf(), "validate", manifest});
  EXPECT_EQ(strict.exit_code, 2);
  EXPECT_NE(strict.out.find("frames[0].image: '" + other + "/far.png' is absolute"),
            std::string::npos)
      << strict.out;

  const CommandResult relaxed = RunCommand({Pf(), "validate", manifest, "--allow-outside-paths"});
  EXPECT_EQ(relaxed.exit_code, 0) << relaxed.out;
  EXPECT_EQ(relaxed.out.rfind("valid: 2 cameras", 0), 0u) << relaxed.out;
}

TEST(ValidateCli, MissingManifestAndBadUsage) {
  const CommandResult missing = RunCommand({Pf(), "validate", "/nonexistent/clip.json"});
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_EQ(missing.out, "/nonexistent/clip.json: file not found\n");

  const CommandResult no_args = RunCommand({Pf(), "validate"});
  EXPECT_EQ(no_args.exit_code, 2);
  EXPECT_NE(no_args.err.find("usage: pf validate"), std::string::npos) << no_args.err;

  const CommandResult bad_flag = RunCommand({Pf(), "validate", "x.json", "--bogus"});
  EXPECT_EQ(bad_flag.exit_code, 2);
  EXPECT_NE(bad_flag.err.find("bogus"), std::string::npos) << bad_flag.err;
}

}  // namespace
}  // namespace pf
