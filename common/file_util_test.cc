// Tests for file helpers: atomic writes and path resolution under a root.
#include "common/file_util.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>

namespace pf {
namespace {

namespace fs = std::filesystem;

std::string FreshDir(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir.string();
}

TEST(WriteFileAtomic, WritesWholeFileAndLeavesNoTemporary) {
  const std::string dir = FreshDir("atomic");
  const std::string path = dir + "/sub/out.txt";
  ASSERT_TRUE(WriteFileAtomic(path, "hello").ok());
  EXPECT_EQ(*ReadFileToString(path), "hello");
  ASSERT_TRUE(WriteFileAtomic(path, "second").ok());
  EXPECT_EQ(*ReadFileToString(path), "second");
  int entries = 0;
  for (const auto& e : fs::directory_iterator(dir + "/sub")) {
    (void)e;
    ++entries;
  }
  EXPECT_EQ(entries, 1);
}

// Writing a file where a directory is: the error says so (the rename's
// errno, not the clean-up's "Success"), and nothing is left behind.
TEST(WriteFileAtomic, ADirectoryInTheWayIsNamed) {
  const std::string dir = FreshDir("atomic_dir");
  fs::create_directories(dir + "/scene.pfscene");
  const absl::Status status = WriteFileAtomic(dir + "/scene.pfscene", "x");
  EXPECT_EQ(status.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(status.message().find("scene.pfscene: is a directory"), std::string::npos) << status;
  int entries = 0;
  for (const auto& e : fs::directory_iterator(dir))
    entries += e.path().filename() != "scene.pfscene";
  EXPECT_EQ(entries, 0);
}

TEST(ReadFileToString, ADirectoryIsNotAFile) {
  const std::string dir = FreshDir("read_dir");
  const absl::StatusOr<std::string> read = ReadFileToString(dir);
  EXPECT_EQ(read.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(read.status().message(), dir + ": is a directory, not a file");
  EXPECT_EQ(ReadFileToString(dir + "/missing").status().code(), absl::StatusCode::kNotFound);
}

TEST(CheckOutputPath, NamesTheFlagWhenAFileOrDirectoryIsInTheWay) {
  const std::string dir = FreshDir("out_check");
  ASSERT_TRUE(WriteFileAtomic(dir + "/file.json", "{}").ok());
  EXPECT_TRUE(CheckOutputFilePath("--out", dir + "/new.pfscene").ok());
  EXPECT_TRUE(CheckOutputFilePath("--out", dir + "/file.json").ok());  // Replaced.
  const absl::Status on_dir = CheckOutputFilePath("--out", dir);
  EXPECT_EQ(on_dir.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(on_dir.message(),
            "--out: '" + dir + "' is a directory; give the path of the file to write");
  EXPECT_TRUE(CheckOutputDirPath("--out", dir).ok());
  EXPECT_TRUE(CheckOutputDirPath("--out", dir + "/new_dir").ok());  // Created later.
  const absl::Status on_file = CheckOutputDirPath("--out", dir + "/file.json");
  EXPECT_EQ(on_file.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(on_file.message().find("--out: '" + dir + "/file.json' is a file"), std::string::npos);
}

TEST(ProcessToken, EndedOnlyForThisMachinesProcessesThatAreGone) {
  EXPECT_FALSE(ProcessTokenEnded(ProcessToken()));
  const std::string host = ProcessToken().substr(0, ProcessToken().find('-'));
  // Our pid under another random part: an earlier process with our pid.
  EXPECT_TRUE(ProcessTokenEnded(host + "-" + std::to_string(::getpid()) + "-00000000"));
  // pid 1 is always running; a pid above the kernel's maximum never is.
  EXPECT_FALSE(ProcessTokenEnded(host + "-1-00000000"));
  EXPECT_TRUE(ProcessTokenEnded(host + "-2147483647-00000000"));
  EXPECT_FALSE(ProcessTokenEnded("another_host-2147483647-00000000"));
  EXPECT_FALSE(ProcessTokenEnded("garbage"));
}

TEST(HideDirectory, TakesAPrivateDirectoryOutOfAMessage) {
  EXPECT_EQ(HideDirectory("/srv/scratch/clip-1/images/a.png: cannot decode; /srv/scratch/clip-1",
                          "/srv/scratch/clip-1"),
            "images/a.png: cannot decode; ");
  EXPECT_EQ(HideDirectory("staging /srv/blobs/ab/abcd: Is a directory", "/srv/blobs/", "<blobs>"),
            "staging <blobs>/ab/abcd: Is a directory");
  EXPECT_EQ(HideDirectory("nothing to hide", "/srv"), "nothing to hide");
  EXPECT_EQ(HideDirectory("/srv/x", ""), "/srv/x");
}

TEST(CheckWritableDir, RefusesADirectoryThatCannotBeMadeOrWrittenAndCreatesNothing) {
  const std::string dir = FreshDir("writable");
  EXPECT_TRUE(CheckWritableDir("--out", dir + "/a/b").ok());
  EXPECT_FALSE(fs::exists(dir + "/a"));
  EXPECT_TRUE(fs::is_empty(dir));  // The probe is gone.
  fs::create_directories(dir + "/c");
  EXPECT_TRUE(CheckWritableDir("--out", dir + "/c").ok());
  EXPECT_TRUE(fs::is_empty(dir + "/c"));
  ASSERT_TRUE(WriteFileAtomic(dir + "/file", "x").ok());
  EXPECT_EQ(CheckWritableDir("--out", dir + "/file").code(), absl::StatusCode::kInvalidArgument);
  const absl::Status under_file = CheckWritableDir("--out", dir + "/file/sub");
  EXPECT_EQ(under_file.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(std::string(under_file.message()).rfind("--out: '" + dir + "/file/sub'", 0), 0u)
      << under_file;
  if (::geteuid() != 0) {  // root writes anywhere.
    fs::create_directories(dir + "/locked");
    fs::permissions(dir + "/locked", fs::perms::owner_read | fs::perms::owner_exec);
    const absl::Status locked = CheckWritableDir("--out", dir + "/locked");
    EXPECT_NE(std::string(locked.message()).find("is not writable"), std::string::npos) << locked;
    const absl::Status below = CheckWritableDir("--out", dir + "/locked/new/sub");
    EXPECT_NE(std::string(below.message()).find("is not writable"), std::string::npos) << below;
    fs::permissions(dir + "/locked", fs::perms::owner_all);
  }
}

TEST(ResolvePath, AcceptsPathsInsideTheRoot) {
  const std::string root = FreshDir("resolve_ok");
  auto p = ResolvePath(root, "images/../images/a.png", PathPolicy::kUnderRootOnly);
  ASSERT_TRUE(p.ok()) << p.status();
  EXPECT_EQ(*p, (fs::path(root) / "images/a.png").string());
}

TEST(ResolvePath, RejectsParentEscapeAbsoluteAndSymlinkOut) {
  const std::string root = FreshDir("resolve_bad");
  auto up = ResolvePath(root, "../x.png", PathPolicy::kUnderRootOnly);
  ASSERT_FALSE(up.ok());
  EXPECT_NE(up.status().message().find("escapes the clip directory"), std::string::npos);
  auto abs = ResolvePath(root, "/etc/passwd", PathPolicy::kUnderRootOnly);
  ASSERT_FALSE(abs.ok());
  EXPECT_NE(abs.status().message().find("absolute"), std::string::npos);
  fs::create_directory_symlink("/etc", fs::path(root) / "link");
  auto link = ResolvePath(root, "link/passwd", PathPolicy::kUnderRootOnly);
  ASSERT_FALSE(link.ok());
  EXPECT_NE(link.status().message().find("symbolic link"), std::string::npos);
  // Allowed explicitly by the caller.
  EXPECT_TRUE(ResolvePath(root, "/etc/passwd", PathPolicy::kAllowOutside).ok());
  EXPECT_TRUE(ResolvePath(root, "../x.png", PathPolicy::kAllowOutside).ok());
}

}  // namespace
}  // namespace pf
