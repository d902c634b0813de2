// pf synth and pf synth render as processes: a small clip, its files, pf
// validate on it, views at new poses, and errors that name the flag or field.
#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "pointforward/v1/clip.pb.h"
#include "tests/test_util.h"

namespace pf {
namespace {

namespace fs = std::filesystem;
using testing::BinPath;
using testing::RunCommand;

std::string ReadAll(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Writes a small clip once for all tests of this file.
const std::string& SmallClip() {
  static const std::string* dir = [] {
    auto* path = new std::string(testing::MakeTempDir("synth_cli") + "/clip");
    const auto result = RunCommand({BinPath("pf"), "synth", "--out", *path, "--seed", "4",
                                    "--width", "192", "--height", "144", "--frames", "6"});
    EXPECT_EQ(result.exit_code, 0) << result.err;
    return path;
  }();
  return *dir;
}

TEST(SynthCli, WritesAClipDirectory) {
  const std::string& dir = SmallClip();
  pointforward::v1::Clip clip;
  ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(ReadAll(dir + "/clip.json"), &clip).ok());
  EXPECT_EQ(clip.cameras_size(), 3);
  ASSERT_EQ(clip.frames_size(), 18);
  int context = 0;
  for (const auto& frame : clip.frames()) {
    EXPECT_TRUE(fs::exists(dir + "/" + frame.image())) << frame.image();
    EXPECT_TRUE(fs::exists(dir + "/" + frame.depth())) << frame.depth();
    context += frame.role() == pointforward::v1::Frame::CONTEXT;
  }
  EXPECT_EQ(context, 6);  // 0 and 0.5 s, three cameras.
  ASSERT_EQ(clip.lidar_size(), 6);
  EXPECT_GT(fs::file_size(dir + "/" + clip.lidar(0).points()), 16u * 1000);
  EXPECT_GE(clip.instances_size(), 3);
  EXPECT_TRUE(fs::exists(dir + "/synth.json"));
}

TEST(SynthCli, ValidateAcceptsTheClip) {
  const auto result = RunCommand({BinPath("pf"), "validate", SmallClip() + "/clip.json"});
  EXPECT_EQ(result.exit_code, 0) << result.out << result.err;
  // 3 cameras x 6 frames at 192x144; CONTEXT at 0 and 0.5 s.
  EXPECT_EQ(result.out.rfind("valid: 3 cameras, 18 frames (6 CONTEXT, 12 TARGET)", 0), 0u)
      << result.out;
}

TEST(SynthCli, RendersRequestedViews) {
  const std::string& dir = SmallClip();
  pointforward::v1::Clip clip;
  ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(ReadAll(dir + "/clip.json"), &clip).ok());
  // The front camera at t = 0.5 s, shifted 3.5 m to the left (world +y).
  std::vector<double> pose;
  for (const auto& frame : clip.frames()) {
    if (frame.camera() == "cam_front" && frame.timestamp_us() == 500000) {
      pose.assign(frame.world_from_camera().begin(), frame.world_from_camera().end());
    }
  }
  ASSERT_EQ(pose.size(), 16u);
  pose[7] += 3.5;
  std::string pose_json;
  for (double v : pose) pose_json += (pose_json.empty() ? "" : ", ") + std::to_string(v);
  const std::string views = testing::MakeTempDir("synth_cli_views");
  std::ofstream(views + "/views.json")
      << R"({"views": [{"camera": "cam_front", "timestampUs": "500000", "worldFromCamera": [)"
      << pose_json << R"(]}], "edits": [{"instance": "vehicle_2", "kind": "REMOVE"}]})";
  const auto result = RunCommand({BinPath("pf"), "synth", "render", "--clip", dir, "--cameras",
                                  views + "/views.json", "--out", views + "/out"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_TRUE(fs::exists(views + "/out/cam_front_500000.png"));
  EXPECT_TRUE(fs::exists(views + "/out/cam_front_500000.exr"));

  std::ofstream(views + "/bad.json")
      << R"({"views": [{"camera": "nope", "worldFromCamera": [)" << pose_json << "]}]}";
  const auto bad = RunCommand({BinPath("pf"), "synth", "render", "--clip", dir, "--cameras",
                               views + "/bad.json", "--out", views + "/out2"});
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("views[0].camera: unknown camera 'nope'"), std::string::npos) << bad.err;
}

TEST(SynthCli, BadFlagsAreBadInput) {
  auto result = RunCommand({BinPath("pf"), "synth"});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("--out: required"), std::string::npos) << result.err;
  const std::string out = testing::MakeTempDir("synth_cli_bad");
  result = RunCommand({BinPath("pf"), "synth", "--out", out, "--width", "4", "--height", "48"});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("--width: must be in [16, 8192], got 4"), std::string::npos)
      << result.err;
  result = RunCommand({BinPath("pf"), "synth", "--out", out + "/w", "--width", "64"});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("--height: required with --width"), std::string::npos) << result.err;
  result = RunCommand({BinPath("pf"), "synth", "--out", out + "/w", "--height", "48"});
  EXPECT_NE(result.err.find("--width: required with --height"), std::string::npos) << result.err;
  const std::string file = out + "/a_file";
  std::ofstream(file) << "x";
  result = RunCommand({BinPath("pf"), "synth", "--out", file});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("--out: '" + file + "' is a file"), std::string::npos) << result.err;
  result = RunCommand({BinPath("pf"), "synth", "--out", out, "--seed", "abc"});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("seed"), std::string::npos) << result.err;
  result = RunCommand({BinPath("pf"), "synth", "render", "--clip", out});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("--cameras: required"), std::string::npos) << result.err;
}

}  // namespace
}  // namespace pf
