// Tests of the checks on workers' results: a render chunk's files must be
// exactly its views' EXR and PNG and its sweeps' range EXR and point record,
// its manifest entries theirs, and nothing a worker sends may be nested or
// sized to hurt whoever reads it back.
#include "server/task_results.h"

#include <gtest/gtest.h>

#include <initializer_list>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"

namespace pf {
namespace {

namespace v1 = pointforward::v1;

const std::string kSha(64, 'a');

// Adds <name><suffix> for each suffix to `result`, as the output of `name`.
void AddFiles(const std::string& name, std::initializer_list<const char*> suffixes,
              v1::RenderResult* result) {
  for (const char* suffix : suffixes) {
    v1::OutputFile* file = result->add_files();
    file->set_name(name + suffix);
    file->set_view(name);
    file->mutable_digest()->set_sha256(kSha);
    file->mutable_digest()->set_size_bytes(10);
  }
}

// A correct result for views `views` and sweeps `lidars`.
v1::RenderResult GoodResult(const std::vector<std::string>& views,
                            const std::vector<std::string>& lidars = {}) {
  v1::RenderResult result;
  nlohmann::ordered_json view_entries = nlohmann::ordered_json::array();
  for (const std::string& name : views) {
    AddFiles(name, {".exr", ".png"}, &result);
    view_entries.push_back({{"name", name}, {"exr", name + ".exr"}, {"png", name + ".png"}});
  }
  result.set_manifest_views_json(view_entries.dump());
  if (lidars.empty()) return result;
  nlohmann::ordered_json lidar_entries = nlohmann::ordered_json::array();
  for (const std::string& name : lidars) {
    AddFiles(name, {".range.exr", ".lidar.bin"}, &result);
    lidar_entries.push_back(
        {{"name", name}, {"rangeExr", name + ".range.exr"}, {"points", name + ".lidar.bin"}});
  }
  result.set_manifest_lidars_json(lidar_entries.dump());
  return result;
}

RenderChunkNames Views(std::vector<std::string> views) { return {std::move(views), {}}; }

std::string Message(const absl::Status& status) { return std::string(status.message()); }

TEST(ChunkOutputNames, NamesViewsThenSweepsAsTheWorkerDoes) {
  v1::RenderViews views;
  views.add_views()->set_name("front");
  v1::View* unnamed = views.add_views();
  unnamed->set_camera("cam/1");
  unnamed->set_timestamp_us(42);
  views.add_lidars()->set_name("top");
  views.add_lidars()->set_timestamp_us(7);
  absl::StatusOr<RenderChunkNames> names = ChunkOutputNames(views, 0, 2);
  ASSERT_TRUE(names.ok()) << names.status();
  EXPECT_EQ(names->views, (std::vector<std::string>{"front", "cam_1_42"}));
  EXPECT_TRUE(names->lidars.empty());
  // Frames 1-3: a view, then both sweeps.
  names = ChunkOutputNames(views, 1, 3);
  ASSERT_TRUE(names.ok()) << names.status();
  EXPECT_EQ(names->views, (std::vector<std::string>{"cam_1_42"}));
  EXPECT_EQ(names->lidars, (std::vector<std::string>{"top", "lidar_7"}));
  EXPECT_EQ(ChunkOutputNames(views, 3, 2).status().message(),
            "frames [3, 5) are not frames of the job (it has 2 views and 2 lidars)");
  EXPECT_FALSE(ChunkOutputNames(views, -1, 1).ok());
  EXPECT_FALSE(ChunkOutputNames(views, 0, 0).ok());
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
            "frames [4, 6) are not frames of the job (it has 5 views and 0 lidars)");
  EXPECT_FALSE(RenderChunkViews(views, -1, 1).ok());

  // Sweeps follow the views: frames 4-6 are v4 and both sweeps.
  for (const char* name : {"s0", "s1"}) views.add_lidars()->set_name(name);
  chunk = RenderChunkViews(views, 4, 3);
  ASSERT_TRUE(chunk.ok()) << chunk.status();
  ASSERT_EQ(chunk->views_size(), 1);
  EXPECT_EQ(chunk->views(0).name(), "v4");
  ASSERT_EQ(chunk->lidars_size(), 2);
  EXPECT_EQ(chunk->lidars(1).name(), "s1");
  chunk = RenderChunkViews(views, 6, 1);
  ASSERT_TRUE(chunk.ok()) << chunk.status();
  EXPECT_EQ(chunk->views_size(), 0);
  ASSERT_EQ(chunk->lidars_size(), 1);
  EXPECT_EQ(chunk->lidars(0).name(), "s1");
  EXPECT_FALSE(RenderChunkViews(views, 6, 2).ok());
}

TEST(CheckRenderResult, AcceptsExactlyTheChunksFiles) {
  EXPECT_TRUE(CheckRenderResult(GoodResult({"v00", "v01"}), Views({"v00", "v01"})).ok());
}

TEST(CheckRenderResult, AcceptsExactlyTheSweepsFilesBesideTheViews) {
  const RenderChunkNames names{{"v00"}, {"top"}};
  EXPECT_TRUE(CheckRenderResult(GoodResult({"v00"}, {"top"}), names).ok());
  EXPECT_TRUE(CheckRenderResult(GoodResult({}, {"top"}), RenderChunkNames{{}, {"top"}}).ok());
  // A sweep without its point record, or its record named as a view's file.
  v1::RenderResult result = GoodResult({"v00"}, {"top"});
  result.mutable_files()->DeleteSubrange(3, 1);
  EXPECT_EQ(Message(CheckRenderResult(result, names)),
            "render.files: no 'top.lidar.bin' for 'top'");
  result = GoodResult({"v00"}, {"top"});
  result.mutable_files(3)->set_name("top.png");
  EXPECT_EQ(Message(CheckRenderResult(result, names)),
            "render.files[3].name: 'top.png' is not an output of the chunk's frames");
  // The sweeps' manifest entries: one per sweep, naming its files.
  result = GoodResult({"v00"}, {"top"});
  result.clear_manifest_lidars_json();
  EXPECT_EQ(Message(CheckRenderResult(result, names)).rfind("render.manifest_lidars_json: ", 0),
            0u);
  result.set_manifest_lidars_json(
      R"([{"name": "top", "rangeExr": "top.exr", "points": "top.lidar.bin"}])");
  EXPECT_EQ(Message(CheckRenderResult(result, names)),
            "render.manifest_lidars_json[0]: does not describe 'top' (top.range.exr, "
            "top.lidar.bin)");
  // Without sweeps the field is empty (older workers) or an empty array.
  result = GoodResult({"v00"});
  EXPECT_TRUE(CheckRenderResult(result, Views({"v00"})).ok());
  result.set_manifest_lidars_json("[]");
  EXPECT_TRUE(CheckRenderResult(result, Views({"v00"})).ok());
  result.set_manifest_lidars_json(R"([{"name": "top"}])");
  EXPECT_EQ(Message(CheckRenderResult(result, Views({"v00"}))),
            "render.manifest_lidars_json: 1 entries for the chunk's 0 frames");
}

TEST(CheckRenderResult, RefusesAFileOutsideTheViews) {
  v1::RenderResult result = GoodResult({"v00"});
  result.mutable_files(0)->set_name("../../etc/passwd");
  const absl::Status status = CheckRenderResult(result, Views({"v00"}));
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(Message(status),
            "render.files[0].name: '../../etc/passwd' is not an output of the chunk's frames");
}

TEST(CheckRenderResult, RefusesAViewWithoutItsExrOrPng) {
  v1::RenderResult result = GoodResult({"v00", "v01"});
  result.mutable_files()->DeleteSubrange(3, 1);  // v01.png
  EXPECT_EQ(Message(CheckRenderResult(result, Views({"v00", "v01"}))),
            "render.files: no 'v01.png' for 'v01'");
  result = GoodResult({"v00"});
  *result.add_files() = result.files(0);
  EXPECT_EQ(Message(CheckRenderResult(result, Views({"v00"}))),
            "render.files[2].name: 'v00.exr' given twice");
}

TEST(CheckRenderResult, RefusesMalformedDigestsAndViewsOfTheWrongFile) {
  v1::RenderResult result = GoodResult({"v00"});
  result.mutable_files(1)->mutable_digest()->set_sha256("ABC");
  EXPECT_EQ(Message(CheckRenderResult(result, Views({"v00"}))),
            "render.files[1].digest.sha256: not 64 lowercase hex digits");
  result = GoodResult({"v00", "v01"});
  result.mutable_files(0)->set_view("v01");
  EXPECT_EQ(Message(CheckRenderResult(result, Views({"v00", "v01"}))),
            "render.files[0].view: 'v01', expected 'v00'");
}

TEST(CheckRenderResult, RefusesManifestEntriesThatAreNotTheViews) {
  v1::RenderResult result = GoodResult({"v00", "v01"});
  result.set_manifest_views_json(R"([{"name": "v00", "exr": "v00.exr", "png": "v00.png"}])");
  EXPECT_EQ(Message(CheckRenderResult(result, Views({"v00", "v01"}))),
            "render.manifest_views_json: 1 entries for the chunk's 2 frames");
  result.set_manifest_views_json(
      R"([{"name": "v01", "exr": "v01.exr", "png": "v01.png"},
          {"name": "v00", "exr": "v00.exr", "png": "v00.png"}])");
  EXPECT_EQ(Message(CheckRenderResult(result, Views({"v00", "v01"}))),
            "render.manifest_views_json[0]: does not describe 'v00' (v00.exr, v00.png)");
  result.set_manifest_views_json(R"({"views": []})");
  EXPECT_EQ(Message(CheckRenderResult(result, Views({"v00", "v01"}))),
            "render.manifest_views_json: not a JSON array");
}

TEST(CheckRenderResult, RefusesDeeplyNestedOrOversizedManifestViews) {
  // The result that made every later read of its job crash the server
  // (100,000 levels), and one small enough to reach the depth check.
  v1::RenderResult result = GoodResult({"v00"});
  result.set_manifest_views_json(std::string(100000, '[') + std::string(100000, ']'));
  EXPECT_EQ(Message(CheckRenderResult(result, Views({"v00"}))),
            "render.manifest_views_json: JSON of 200000 bytes exceeds the limit of 65536 bytes");
  result.set_manifest_views_json(std::string(30000, '[') + std::string(30000, ']'));
  EXPECT_EQ(Message(CheckRenderResult(result, Views({"v00"}))),
            "render.manifest_views_json: JSON nested deeper than 64 levels");
  EXPECT_EQ(ParseManifestViews(result.manifest_views_json(), 1).status().code(),
            absl::StatusCode::kInvalidArgument);
  result.set_manifest_views_json(
      R"([{"name": "v00", "exr": "v00.exr", "png": "v00.png", "pad": ")" +
      std::string(kMaxManifestBytesPerView, 'x') + "\"}]");
  EXPECT_NE(
      Message(CheckRenderResult(result, Views({"v00"}))).find("exceeds the limit of 65536 bytes"),
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
