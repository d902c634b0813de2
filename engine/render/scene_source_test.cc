// Tests of OpenScene: our scene file and PLY recognised by content.
#include "engine/render/scene_source.h"

#include <gtest/gtest.h>

#include "common/file_util.h"
#include "common/hash.h"
#include "engine/render/ply_io.h"
#include "engine/render/scene_file.h"
#include "tests/test_util.h"

namespace pf {
namespace {

GaussianScene TwoGaussians() {
  GaussianScene scene;
  scene.Resize(2);
  scene.means = {0, 0, 5, 1, 0, 6};
  scene.features = {0.2f, 0.4f, 0.6f, 0.8f, 0.1f, 0.3f};
  return scene;
}

TEST(OpenScene, RecognisesOurSceneFileWhateverItsName) {
  const std::string path = testing::MakeTempDir("scene_source") + "/scene.ply";  // Misnamed.
  ASSERT_TRUE(SaveScene(TwoGaussians(), path, {{"model", "analytic"}}).ok());
  absl::StatusOr<OpenedScene> opened = OpenScene(path);
  ASSERT_TRUE(opened.ok()) << opened.status();
  EXPECT_EQ(opened->format, "pointforward scene v11");
  EXPECT_EQ(opened->model, "analytic");
  EXPECT_EQ(opened->scene_id, ReadSceneFile(path)->checksum_hex);
  EXPECT_EQ(opened->scene.means, TwoGaussians().means);
}

TEST(OpenScene, RecognisesPlyAndNamesItsHash) {
  const std::string path = testing::MakeTempDir("scene_source") + "/scene.bin";
  ASSERT_TRUE(ExportPly(TwoGaussians(), path).ok());
  absl::StatusOr<OpenedScene> opened = OpenScene(path);
  ASSERT_TRUE(opened.ok()) << opened.status();
  EXPECT_EQ(opened->format, "3dgs ply");
  EXPECT_EQ(opened->model, "3dgs-ply");
  EXPECT_EQ(opened->scene_id, *Sha256File(path));
  EXPECT_EQ(opened->scene.size(), 2u);
}

TEST(OpenScene, RejectsOtherFiles) {
  const std::string dir = testing::MakeTempDir("scene_source");
  ASSERT_TRUE(WriteFileAtomic(dir + "/notes.txt", "hello").ok());
  absl::Status status = OpenScene(dir + "/notes.txt").status();
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("neither a PointForward scene file nor a PLY file"),
            absl::string_view::npos)
      << status;
  EXPECT_EQ(OpenScene(dir + "/missing").status().code(), absl::StatusCode::kNotFound);
}

}  // namespace
}  // namespace pf
