// Tests of OperationNameFor and SceneNameFor.
#include "client/remote/resource_names.h"

#include <gtest/gtest.h>

#include <fstream>

namespace pf {
namespace {

TEST(OperationNameFor, AcceptsOperationRenderJobAndBareIds) {
  EXPECT_EQ(*OperationNameFor("operations/r42"), "operations/r42");
  EXPECT_EQ(*OperationNameFor("renderJobs/r42"), "operations/r42");
  EXPECT_EQ(*OperationNameFor("r42"), "operations/r42");
}

TEST(OperationNameFor, RefusesSceneNamesPointingToSceneGet) {
  const absl::StatusOr<std::string> name = OperationNameFor("scenes/s1");
  ASSERT_FALSE(name.ok());
  EXPECT_EQ(name.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(std::string(name.status().message()).find("pf scene get scenes/s1"), std::string::npos)
      << name.status();
}

TEST(OperationNameFor, RefusesEmptyAndNestedIds) {
  EXPECT_EQ(OperationNameFor("").status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(OperationNameFor("operations/").status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(OperationNameFor("operations/a/b").status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(OperationNameFor("operations/renderJobs/a").status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(OperationNameFor("renderJobs/a b").status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(SceneNameFor, AddsThePrefixOnce) {
  EXPECT_EQ(*SceneNameFor("s1"), "scenes/s1");
  EXPECT_EQ(*SceneNameFor("scenes/s1"), "scenes/s1");
  EXPECT_FALSE(SceneNameFor("renderJobs/r1").ok());
  EXPECT_FALSE(SceneNameFor("scenes/").ok());
}

// A local scene file given to a remote command: say what SCENE means there.
TEST(SceneNameFor, ALocalFileIsNotTakenForAServerScene) {
  const std::string path = ::testing::TempDir() + "/local.pfscene";
  std::ofstream(path) << "x";
  const absl::StatusOr<std::string> name = SceneNameFor(path);
  EXPECT_EQ(name.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(std::string(name.status().message()).find("is a file on this machine"),
            std::string::npos)
      << name.status();
  EXPECT_NE(std::string(name.status().message()).find("run the command without --server"),
            std::string::npos);
  EXPECT_EQ(*SceneNameFor("scenes/local.pfscene"), "scenes/local.pfscene");  // Explicit.
}

}  // namespace
}  // namespace pf
