// `pf import` run as a process on the real samples: both import into clips
// that `pf validate` accepts, with one summary line; user errors give clear
// messages and the bad-input exit code.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>

#include "common/file_util.h"
#include "tests/test_util.h"

namespace pf {
namespace {

namespace fs = std::filesystem;
using testing::BinPath;
using testing::RunCommand;

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(ImportCli, WaymoSegmentImportsIntoAValidClip) {
  PF_REQUIRE_DATA(dir, "waymo_one_frame");
  const std::string out = testing::MakeTempDir("import_cli_waymo") + "/clip";
  const auto run = RunCommand(
      {BinPath("pf"), "import", "waymo", dir + "/pvps_data_one_frame.tfrecord", "--out", out});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(Contains(run.out, out + "/clip.json: 5 cameras, 5 frames (5 context, 0 target)"))
      << run.out;
  EXPECT_TRUE(Contains(run.out, "75 instances (75 boxes), 0 LiDAR sweeps")) << run.out;
  EXPECT_EQ(std::count(run.out.begin(), run.out.end(), '\n'), 1) << run.out;
  EXPECT_TRUE(fs::exists(out + "/images/FRONT_1553735853514621.jpg"));

  const auto validate = RunCommand({BinPath("pf"), "validate", out + "/clip.json"});
  EXPECT_EQ(validate.exit_code, 0) << validate.out << validate.err;
}

TEST(ImportCli, DgpSceneImportsIntoAValidClip) {
  PF_REQUIRE_DATA(dir, "dgp_test_scene/scene_02");
  const std::string out = testing::MakeTempDir("import_cli_dgp") + "/clip";
  const auto run = RunCommand({BinPath("pf"), "import", "dgp", dir, "--out", out});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(Contains(run.out, "6 cameras, 18 frames (12 context, 6 target)")) << run.out;
  EXPECT_TRUE(Contains(run.out, "3 LiDAR sweeps")) << run.out;
  EXPECT_TRUE(fs::exists(out + "/lidar/LIDAR_15616458250027900.bin"));

  const auto validate = RunCommand({BinPath("pf"), "validate", out + "/clip.json"});
  EXPECT_EQ(validate.exit_code, 0) << validate.out << validate.err;
}

TEST(ImportCli, DgpCameraSubsetAndAllContextRoles) {
  PF_REQUIRE_DATA(dir, "dgp_test_scene/scene_02");
  const std::string out = testing::MakeTempDir("import_cli_dgp_subset");
  const auto run = RunCommand({BinPath("pf"), "import", "dgp", dir, "--out", out, "--cameras",
                               "CAMERA_01,CAMERA_05", "--roles", "all-context"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(Contains(run.out, "2 cameras, 6 frames (6 context, 0 target)")) << run.out;
}

TEST(ImportCli, UnknownCameraIsBadInputListingTheCameras) {
  PF_REQUIRE_DATA(dir, "waymo_one_frame");
  const auto run =
      RunCommand({BinPath("pf"), "import", "waymo", dir + "/pvps_data_one_frame.tfrecord", "--out",
                  testing::MakeTempDir("import_cli_frnt"), "--cameras", "FRNT"});
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_TRUE(Contains(run.err,
                       "pf import: --cameras FRNT: no such camera in the segment (have "
                       "FRONT, FRONT_LEFT, FRONT_RIGHT, SIDE_LEFT, SIDE_RIGHT)"))
      << run.err;
}

TEST(ImportCli, CorruptAndTruncatedSegmentsNameTheRecordOffset) {
  PF_REQUIRE_DATA(dir, "waymo_one_frame");
  const std::string bytes = *ReadFileToString(dir + "/pvps_data_one_frame.tfrecord");
  const std::string tmp = testing::MakeTempDir("import_cli_corrupt");
  std::string flipped = bytes;
  flipped[flipped.size() - 1000] ^= 0x10;
  std::ofstream(tmp + "/flipped.tfrecord", std::ios::binary) << flipped;
  std::ofstream(tmp + "/cut.tfrecord", std::ios::binary) << bytes.substr(0, 5000);

  const auto corrupt = RunCommand(
      {BinPath("pf"), "import", "waymo", tmp + "/flipped.tfrecord", "--out", tmp + "/a"});
  EXPECT_EQ(corrupt.exit_code, 2);  // Bad input: the log is damaged.
  EXPECT_TRUE(Contains(corrupt.err, "record 0 at byte offset 0: corrupt")) << corrupt.err;

  const auto cut =
      RunCommand({BinPath("pf"), "import", "waymo", tmp + "/cut.tfrecord", "--out", tmp + "/b"});
  EXPECT_EQ(cut.exit_code, 2);
  EXPECT_TRUE(Contains(cut.err, "record 0 at byte offset 0: truncated")) << cut.err;
  EXPECT_FALSE(fs::exists(tmp + "/b/clip.json"));
}

TEST(ImportCli, UsageErrors) {
  const auto no_out = RunCommand({BinPath("pf"), "import", "dgp", "/some/scene"});
  EXPECT_EQ(no_out.exit_code, 2);
  EXPECT_TRUE(Contains(no_out.err, "--out DIR is required")) << no_out.err;
  const auto bad_format =
      RunCommand({BinPath("pf"), "import", "nuscenes", "/x", "--out", "/tmp/never"});
  EXPECT_EQ(bad_format.exit_code, 2);
  EXPECT_TRUE(Contains(bad_format.err, "unknown format 'nuscenes'")) << bad_format.err;
  const auto missing = RunCommand({BinPath("pf"), "import", "dgp", "/nonexistent/scene", "--out",
                                   testing::MakeTempDir("import_cli_missing")});
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_TRUE(Contains(missing.err, "/nonexistent/scene: no such scene directory")) << missing.err;
}

}  // namespace
}  // namespace pf
