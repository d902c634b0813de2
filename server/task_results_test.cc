// Tests of the checks on workers' results: a render chunk's files must be
// exactly its views' EXR and PNG, its manifest entries theirs, and nothing a
// worker sends may be nested or sized to hurt whoever reads it back.
#include "server/task_results.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "absl/strings/str_cat.h"

namespace pf {
namespace {

namespace v1 = pointforward::v1;

const std::string kSha(64, 'a');

// A correct result for views `names`.
v1::RenderResult GoodResult(const std::vector<std::string>& names) {
  v1::RenderResult result;
  nlohmann::ordered_json entries = nlohmann::ordered_json::array();
  for (const std::string& name : names) {
    for (const char* ext : {".exr", ".png"}) {
      v1::OutputFile* file = result.add_files();
      file->set_name(name + ext);
      file->set_view(name);
      file->mutable_digest()->set_sha256(kSha);
      file->mutable_digest()->set_size_bytes(10);
    }
    entries.push_back({{"name", name}, {"exr", name + ".exr"}, {"png", name + ".png"}});
  }
  result.set_manifest_views_json(entries.dump());
  return result;
}

std::string Message(const absl::Status& status) { return std::string(status.message()); }

TEST(RenderChunkViewNames, NamesViewsAsTheWorkerDoes) {
  v1::RenderViews views;
  views.add_views()->set_name("front");
  v1::View* unnamed = views.add_views();
  unnamed->set_camera("cam/1");
  unnamed->set_timestamp_us(42);
  absl::StatusOr<std::vector<std::string>> names = RenderChunkViewNames(views, 0, 2);
  ASSERT_TRUE(names.ok()) << names.status();
  EXPECT_EQ(*names, (std::vector<std::string>{"front", "cam_1_42"}));
  EXPECT_EQ(RenderChunkViewNames(views, 1, 2).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_FALSE(RenderChunkViewNames(views, -1, 1).ok());
  EXPECT_FALSE(RenderChunkViewNames(views, 0, 0).ok());
}

TEST(RenderChunkViews, CarriesTheChunksViewsWithEveryCameraAndEdit) {
  v1::RenderViews views;
  for (const char* id : {"front", "side"}) views.add_cameras()->set_id(id);
  for (int i = 0; i < 5; ++i) views.add_views()->set_name(absl::StrCat("v", i));
  views.add_edits()->set_instance("car1");
  absl::StatusOr<v1::RenderViews> chunk = RenderChunkViews(views, 2, 2);
  ASSERT_TRUE(chunk.ok()) << chunk.status();
  ASSERT_EQ(chunk->views_size(), 2);
  EXPECT_EQ(chunk->views(0).name(), "v2");
  EXPECT_EQ(chunk->views(1).name(), "v3");
  ASSERT_EQ(chunk->cameras_size(), 2);
  EXPECT_EQ(chunk->cameras(1).id(), "side");
  ASSERT_EQ(chunk->edits_size(), 1);
  EXPECT_EQ(chunk->edits(0).instance(), "car1");
  EXPECT_EQ(RenderChunkViews(views, 4, 2).status().message(),
            "views [4, 6) are not views of the job (it has 5)");
  EXPECT_FALSE(RenderChunkViews(views, -1, 1).ok());
}

TEST(CheckRenderResult, AcceptsExactlyTheChunksFiles) {
  EXPECT_TRUE(CheckRenderResult(GoodResult({"v00", "v01"}), {"v00", "v01"}).ok());
}

TEST(CheckRenderResult, RefusesAFileOutsideTheViews) {
  v1::RenderResult result = GoodResult({"v00"});
  result.mutable_files(0)->set_name("../../etc/passwd");
  const absl::Status status = CheckRenderResult(result, {"v00"});
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(Message(status),
            "render.files[0].name: '../../etc/passwd' is not an output of the chunk's views");
}

TEST(CheckRenderResult, RefusesAViewWithoutItsExrOrPng) {
  v1::RenderResult result = GoodResult({"v00", "v01"});
  result.mutable_files()->DeleteSubrange(3, 1);  // v01.png
  EXPECT_EQ(Message(CheckRenderResult(result, {"v00", "v01"})),
            "render.files: no 'v01.png' for view 'v01'");
  result = GoodResult({"v00"});
  *result.add_files() = result.files(0);
  EXPECT_EQ(Message(CheckRenderResult(result, {"v00"})),
            "render.files[2].name: 'v00.exr' given twice");
}

TEST(CheckRenderResult, RefusesMalformedDigestsAndViewsOfTheWrongFile) {
  v1::RenderResult result = GoodResult({"v00"});
  result.mutable_files(1)->mutable_digest()->set_sha256("ABC");
  EXPECT_EQ(Message(CheckRenderResult(result, {"v00"})),
            "render.files[1].digest.sha256: not 64 lowercase hex digits");
  result = GoodResult({"v00", "v01"});
  result.mutable_files(0)->set_view("v01");
  EXPECT_EQ(Message(CheckRenderResult(result, {"v00", "v01"})),
            "render.files[0].view: 'v01', expected 'v00'");
}

TEST(CheckRenderResult, RefusesManifestEntriesThatAreNotTheViews) {
  v1::RenderResult result = GoodResult({"v00", "v01"});
  result.set_manifest_views_json(R"([{"name": "v00", "exr": "v00.exr", "png": "v00.png"}])");
  EXPECT_EQ(Message(CheckRenderResult(result, {"v00", "v01"})),
            "render.manifest_views_json: 1 entries for the chunk's 2 views");
  result.set_manifest_views_json(
      R"([{"name": "v01", "exr": "v01.exr", "png": "v01.png"},
          {"name": "v00", "exr": "v00.exr", "png": "v00.png"}])");
  EXPECT_EQ(Message(CheckRenderResult(result, {"v00", "v01"})),
            "render.manifest_views_json[0]: does not describe view 'v00' (v00.exr, v00.png)");
  result.set_manifest_views_json(R"({"views": []})");
  EXPECT_EQ(Message(CheckRenderResult(result, {"v00", "v01"})),
            "render.manifest_views_json: not a JSON array");
}

TEST(CheckRenderResult, RefusesDeeplyNestedOrOversizedManifestViews) {
  // The result that made every later read of its job crash the server
  // (100,000 levels), and one small enough to reach the depth check.
  v1::RenderResult result = GoodResult({"v00"});
  result.set_manifest_views_json(std::string(100000, '[') + std::string(100000, ']'));
  EXPECT_EQ(Message(CheckRenderResult(result, {"v00"})),
            "render.manifest_views_json: JSON of 200000 bytes exceeds the limit of 65536 bytes");
  result.set_manifest_views_json(std::string(30000, '[') + std::string(30000, ']'));
  EXPECT_EQ(Message(CheckRenderResult(result, {"v00"})),
            "render.manifest_views_json: JSON nested deeper than 64 levels");
  EXPECT_EQ(ParseManifestViews(result.manifest_views_json(), 1).status().code(),
            absl::StatusCode::kInvalidArgument);
  result.set_manifest_views_json(
      R"([{"name": "v00", "exr": "v00.exr", "png": "v00.png", "pad": ")" +
      std::string(kMaxManifestBytesPerView, 'x') + "\"}]");
  EXPECT_NE(Message(CheckRenderResult(result, {"v00"})).find("exceeds the limit of 65536 bytes"),
            std::string::npos);
}

TEST(CheckReconstructResult, ChecksTheStatisticsAWorkerSends) {
  v1::ReconstructResult result;
  v1::Scene* scene = result.mutable_scene();
  scene->mutable_scene_file()->set_sha256(kSha);
  scene->set_gaussians(10);
  scene->set_static_gaussians(8);
  scene->set_dynamic_gaussians(2);
  scene->add_instances("car1");
  for (int i = 0; i < 3; ++i) {
    scene->add_bounds_min(-1);
    scene->add_bounds_max(1);
  }
  EXPECT_TRUE(CheckReconstructResult(result).ok());

  v1::ReconstructResult bad = result;
  bad.mutable_scene()->set_gaussians(-1);
  EXPECT_EQ(Message(CheckReconstructResult(bad)), "reconstruct.scene.gaussians: negative");
  bad = result;
  bad.mutable_scene()->add_instances("");
  EXPECT_EQ(Message(CheckReconstructResult(bad)),
            "reconstruct.scene.instances[1]: must be 1 to 1024 characters");
  bad = result;
  bad.mutable_scene()->add_bounds_max(2);
  EXPECT_EQ(Message(CheckReconstructResult(bad)),
            "reconstruct.scene.bounds_max: expected 3 numbers or none");
  bad = result;
  bad.mutable_scene()->mutable_scene_file()->set_sha256("");
  EXPECT_EQ(Message(CheckReconstructResult(bad)),
            "reconstruct.scene.scene_file.sha256: not 64 lowercase hex digits");
}

}  // namespace
}  // namespace pf
