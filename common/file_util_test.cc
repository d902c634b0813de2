// Tests for file helpers: atomic writes and path resolution under a root.
#include "common/file_util.h"

#include <gtest/gtest.h>

#include <filesystem>

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
