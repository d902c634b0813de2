// Tests of the worker's engine work without a server: a small synth clip
// (written by `pf synth`) behind a fetch function that copies from a map of
// SHA-256 -> local file, reconstructed with RunReconstruction; RenderChunk
// compared byte for byte with `pf render` on the same scene and views.
#include "worker/task_runner.h"

#include <google/protobuf/util/json_util.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "common/file_util.h"
#include "common/hash.h"
#include "engine/clip/clip_io.h"
#include "engine/render/scene_file.h"
#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "tests/test_util.h"

namespace pf {
namespace {

namespace fs = std::filesystem;
namespace pb = ::pointforward::v1;
using testing::BinPath;
using testing::CommandResult;
using testing::RunCommand;

// Blobs by SHA-256, as the blob store would hold them; Fetch copies one to
// the path asked for and counts the calls.
struct FakeBlobs {
  std::map<std::string, std::string> files;  // sha256 -> local path.
  int fetches = 0;

  absl::StatusOr<pb::Digest> Add(const std::string& path) {
    absl::StatusOr<std::string> sha = Sha256File(path);
    if (!sha.ok()) return sha.status();
    files[*sha] = path;
    pb::Digest digest;
    digest.set_sha256(*sha);
    digest.set_size_bytes(static_cast<int64_t>(fs::file_size(path)));
    return digest;
  }

  FetchBlobFn Fetch() {
    return [this](const std::string& sha256, const std::string& local) -> absl::Status {
      ++fetches;
      const auto it = files.find(sha256);
      if (it == files.end()) return absl::NotFoundError(absl::StrCat("no blob ", sha256));
      std::error_code error;
      fs::copy_file(it->second, local, fs::copy_options::overwrite_existing, error);
      if (error) return absl::InternalError(error.message());
      return absl::OkStatus();
    };
  }
};

using testing::WithoutDateTime;

class TaskRunner : public ::testing::Test {
 protected:
  // One synth clip, uploaded to the fake blobs and reconstructed once.
  static void SetUpTestSuite() {
    dir_ = new std::string(testing::MakeTempDir("task_runner"));
    blobs_ = new FakeBlobs;
    work_ = new pb::ReconstructWork;
    stages_ = new std::vector<std::pair<std::string, double>>;
    const CommandResult synth = RunCommand({BinPath("pf"), "synth", "--out", *dir_ + "/clip",
                                            "--width", "128", "--height", "96", "--frames", "6"});
    ASSERT_EQ(synth.exit_code, 0) << synth.err;
    absl::StatusOr<LoadedClip> loaded = LoadClip(*dir_ + "/clip/clip.json");
    ASSERT_TRUE(loaded.ok()) << loaded.status();
    clip_ = new pb::Clip(loaded->clip);

    work_->set_scene("scenes/test");
    work_->mutable_options()->set_ns(1500);
    work_->mutable_options()->set_nd(200);
    absl::StatusOr<pb::Digest> manifest = blobs_->Add(*dir_ + "/clip/clip.json");
    ASSERT_TRUE(manifest.ok()) << manifest.status();
    *work_->mutable_clip()->mutable_manifest() = *manifest;
    for (const ClipFileRef& ref : ReferencedFiles(*clip_)) {
      absl::StatusOr<pb::Digest> digest = blobs_->Add(*dir_ + "/clip/" + ref.path);
      ASSERT_TRUE(digest.ok()) << digest.status();
      (*work_->mutable_clip()->mutable_files())[ref.path] = *digest;
    }

    absl::StatusOr<ReconstructOutput> out = RunReconstruction(
        *work_, blobs_->Fetch(), *dir_ + "/recon",
        [](const std::string& stage, double fraction) { stages_->emplace_back(stage, fraction); },
        [] { return false; });
    ASSERT_TRUE(out.ok()) << out.status();
    recon_ = new ReconstructOutput(*out);
  }

  void SetUp() override { ASSERT_NE(recon_, nullptr) << "the shared reconstruction failed"; }

  static absl::Status Reconstruct(
      const pb::ReconstructWork& work, const std::string& name,
      const CancelledFn& cancelled = [] { return false; }) {
    return RunReconstruction(work, blobs_->Fetch(), *dir_ + "/" + name, nullptr, cancelled)
        .status();
  }

  // Four views through the clip's cameras at its first frames' poses, named v0..v3.
  static pb::RenderViews FourViews() {
    pb::RenderViews views;
    *views.mutable_cameras() = clip_->cameras();
    for (int i = 0; i < 4; ++i) {
      const pb::Frame& frame = clip_->frames(i % clip_->frames_size());
      pb::View* view = views.add_views();
      view->set_camera(frame.camera());
      view->set_timestamp_us(frame.timestamp_us());
      *view->mutable_world_from_camera() = frame.world_from_camera();
      view->set_name(absl::StrCat("v", i));
    }
    return views;
  }

  // Views [first, first + count) of FourViews() as the server sends them
  // (the chunk's views only), or with all four as older servers did.
  static pb::RenderWork ChunkOf(int first, int count, bool whole_job = false) {
    pb::RenderWork work;
    work.set_scene("scenes/test");
    *work.mutable_views() = FourViews();
    if (!whole_job) {
      work.mutable_views()->clear_views();
      for (int i = std::max(first, 0); i < std::min(first + count, 4); ++i) {
        *work.mutable_views()->add_views() = FourViews().views(i);
      }
    }
    work.set_first_view(first);
    work.set_view_count(count);
    return work;
  }

  // `pf render` of the reconstructed scene at `views`, into `out_dir`.
  static CommandResult PfRender(const pb::RenderViews& views, const std::string& out_dir) {
    std::string views_json;
    EXPECT_TRUE(google::protobuf::util::MessageToJsonString(views, &views_json).ok());
    const std::string views_path = out_dir + ".views.json";
    EXPECT_TRUE(WriteFileAtomic(views_path, views_json).ok());
    return RunCommand(
        {BinPath("pf"), "render", recon_->scene_path, "--cameras", views_path, "--out", out_dir});
  }

  static std::set<std::string> FilesIn(const std::string& dir) {
    std::set<std::string> names;
    for (const auto& entry : fs::directory_iterator(dir)) names.insert(entry.path().filename());
    return names;
  }

  static std::string* dir_;
  static FakeBlobs* blobs_;
  static pb::Clip* clip_;
  static pb::ReconstructWork* work_;
  static ReconstructOutput* recon_;
  static std::vector<std::pair<std::string, double>>* stages_;
};

std::string* TaskRunner::dir_ = nullptr;
FakeBlobs* TaskRunner::blobs_ = nullptr;
pb::Clip* TaskRunner::clip_ = nullptr;
pb::ReconstructWork* TaskRunner::work_ = nullptr;
ReconstructOutput* TaskRunner::recon_ = nullptr;
std::vector<std::pair<std::string, double>>* TaskRunner::stages_ = nullptr;

TEST_F(TaskRunner, ReconstructionWritesTheSceneAndItsStatistics) {
  const pb::Scene& scene = recon_->scene;
  absl::StatusOr<SceneFile> file = ReadSceneFile(recon_->scene_path);
  ASSERT_TRUE(file.ok()) << file.status();
  EXPECT_EQ(scene.gaussians(), static_cast<int64_t>(file->scene.size()));
  EXPECT_GT(scene.gaussians(), 1000);
  EXPECT_EQ(scene.gaussians(), scene.static_gaussians() + scene.dynamic_gaussians());
  EXPECT_GT(scene.dynamic_gaussians(), 0);
  EXPECT_GT(scene.far_gaussians(), 0);
  EXPECT_LT(scene.far_gaussians(), scene.static_gaussians());
  EXPECT_EQ(scene.model(), "analytic");
  EXPECT_EQ(file->metadata.at("model"), "analytic");
  EXPECT_EQ(file->metadata.at("ns"), "1500");
  EXPECT_EQ(file->metadata.at("source_clip"),
            absl::StrCat("sha256:", work_->clip().manifest().sha256()));
  // The metadata `pf reconstruct` writes, key for key (SceneMetadata).
  EXPECT_EQ(file->metadata.at("ground_fill"), "true");
  EXPECT_EQ(file->metadata.at("facades"), "true");
  EXPECT_EQ(file->metadata.at("lifespan"), "false");
  EXPECT_EQ(file->metadata.at("fusion"), "softmax");
  EXPECT_EQ(scene.num_channels(), file->scene.num_channels);
  EXPECT_EQ(scene.options().ns(), 1500);

  // Instances: those of the clip with boxes, in order.
  std::vector<std::string> expected_instances;
  for (const pb::Instance& instance : clip_->instances())
    if (instance.boxes_size() > 0) expected_instances.push_back(instance.id());
  ASSERT_FALSE(expected_instances.empty());
  EXPECT_EQ(std::vector<std::string>(scene.instances().begin(), scene.instances().end()),
            expected_instances);

  int64_t start = clip_->frames(0).timestamp_us(), end = start;
  for (const pb::Frame& frame : clip_->frames()) {
    start = std::min(start, frame.timestamp_us());
    end = std::max(end, frame.timestamp_us());
  }
  EXPECT_EQ(scene.start_time_us(), start);
  EXPECT_EQ(scene.end_time_us(), end);
  EXPECT_LT(scene.start_time_us(), scene.end_time_us());

  // Bounds of the static surfaces: ordered, finite, around the cameras, and
  // without the far layer: the sky sits on it (radius >= 200 m around the
  // cameras), so the bounds of all static means reach far higher.
  ASSERT_EQ(scene.bounds_min_size(), 3);
  ASSERT_EQ(scene.bounds_max_size(), 3);
  for (int a = 0; a < 3; ++a) {
    EXPECT_TRUE(std::isfinite(scene.bounds_min(a)) && std::isfinite(scene.bounds_max(a)));
    EXPECT_LT(scene.bounds_min(a), scene.bounds_max(a)) << "axis " << a;
  }
  float top_of_all_static = -1e30f;
  for (size_t i = 0; i < file->scene.size(); ++i)
    if (file->scene.owners[i] == 0)
      top_of_all_static = std::max(top_of_all_static, file->scene.means[3 * i + 2]);
  EXPECT_GT(top_of_all_static, 150.f);
  EXPECT_LT(scene.bounds_max(2), 60.0);
  EXPECT_GT(scene.bounds_min(2), -1.0);  // The ground is z = 0.
  for (const pb::Frame& frame : clip_->frames()) {
    for (int a = 0; a < 3; ++a) {
      const double c = frame.world_from_camera(4 * a + 3);
      EXPECT_GT(c, scene.bounds_min(a) - 5.0) << "axis " << a;
      EXPECT_LT(c, scene.bounds_max(a) + 5.0) << "axis " << a;
    }
  }
}

TEST_F(TaskRunner, ReconstructionReportsStagesInOrder) {
  ASSERT_GE(stages_->size(), 8u);
  EXPECT_EQ(stages_->front().first, "download");
  EXPECT_EQ(stages_->front().second, 0.0);
  EXPECT_EQ(stages_->back().first, "done");
  EXPECT_EQ(stages_->back().second, 1.0);
  std::vector<std::string> names;
  for (size_t i = 0; i < stages_->size(); ++i) {
    if (i > 0) EXPECT_GE((*stages_)[i].second, (*stages_)[i - 1].second) << (*stages_)[i].first;
    if (names.empty() || names.back() != (*stages_)[i].first) names.push_back((*stages_)[i].first);
  }
  const std::vector<std::string> expected = {"download",    "load",   "depth", "lift",
                                             "scene_graph", "sample", "fuse",  "decode",
                                             "refine",      "save",   "done"};
  EXPECT_EQ(names, expected);
}

TEST_F(TaskRunner, PathsOutsideTheClipAreRefusedBeforeAnyDownload) {
  for (const std::string& path :
       {std::string("../x"), std::string("/etc/passwd"), std::string("images/../../x")}) {
    pb::ReconstructWork work = *work_;
    (*work.mutable_clip()->mutable_files())[path] = work.clip().manifest();
    const int fetches = blobs_->fetches;
    const absl::Status status = Reconstruct(work, "escape");
    EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument) << status;
    EXPECT_NE(status.message().find(absl::StrCat("clip.files[\"", path, "\"]")),
              absl::string_view::npos)
        << status;
    EXPECT_EQ(blobs_->fetches, fetches) << path;
  }
  EXPECT_FALSE(fs::exists(*dir_ + "/x"));
}

TEST_F(TaskRunner, FileMissingFromTheUploadIsNamed) {
  pb::ReconstructWork work = *work_;
  const std::string first = ReferencedFiles(*clip_).front().path;
  work.mutable_clip()->mutable_files()->erase(first);
  const absl::Status status = Reconstruct(work, "missing");
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument) << status;
  EXPECT_NE(status.message().find(absl::StrCat("clip.files: the manifest's ",
                                               ReferencedFiles(*clip_).front().field, " '", first,
                                               "' was not uploaded")),
            absl::string_view::npos)
      << status;
}

TEST_F(TaskRunner, BadOptionsNameTheField) {
  pb::ReconstructWork work = *work_;
  work.mutable_options()->set_model("nerf");
  absl::Status status = Reconstruct(work, "bad_model");
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("options.model: unknown model 'nerf'"), absl::string_view::npos)
      << status;

  work = *work_;
  work.mutable_options()->set_device("cuda:0");
  status = Reconstruct(work, "bad_device");
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("options.device: 'cuda:0'"), absl::string_view::npos) << status;

  work = *work_;
  work.mutable_options()->set_fusion("max");
  status = Reconstruct(work, "bad_fusion");
  EXPECT_NE(status.message().find("options.fusion: unknown weighting 'max'"),
            absl::string_view::npos)
      << status;
}

// The tuning fields reach the reconstruction's options; unset ones keep the
// defaults; out of range ones are refused naming the field.
TEST(ReconOptionsFromProto, TuningFieldsMapOntoTheOptions) {
  pb::ReconstructionOptions proto;
  absl::StatusOr<ReconOptions> options = ReconOptionsFromProto(proto);
  ASSERT_TRUE(options.ok()) << options.status();
  const ReconOptions defaults;
  EXPECT_EQ(options->refinement.iterations, defaults.refinement.iterations);
  EXPECT_EQ(options->decoder.tangent_sigma, defaults.decoder.tangent_sigma);
  EXPECT_EQ(options->decoder.low_pass, defaults.decoder.low_pass);
  EXPECT_EQ(options->hidden_band_px, defaults.hidden_band_px);
  EXPECT_TRUE(options->completion.ground_fill);
  EXPECT_TRUE(options->completion.facades);
  EXPECT_TRUE(options->ego_layer);
  EXPECT_FALSE(options->colour_gradients.has_value());  // The model's default.
  EXPECT_TRUE(ColourGradientsFor(*options));
  EXPECT_FALSE(options->fusion.lifespan);  // Off unless asked for.

  proto.set_lifespan(true);
  options = ReconOptionsFromProto(proto);
  ASSERT_TRUE(options.ok()) << options.status();
  EXPECT_TRUE(options->fusion.lifespan);
  proto.set_no_lifespan(true);
  EXPECT_EQ(ReconOptionsFromProto(proto).status().code(), absl::StatusCode::kInvalidArgument);
  proto.set_lifespan(false);
  options = ReconOptionsFromProto(proto);
  ASSERT_TRUE(options.ok()) << options.status();
  EXPECT_FALSE(options->fusion.lifespan);
  proto.set_no_lifespan(false);

  proto.set_colour("flat");
  options = ReconOptionsFromProto(proto);
  ASSERT_TRUE(options.ok()) << options.status();
  EXPECT_EQ(options->colour_gradients, std::optional<bool>(false));
  proto.set_colour("gradients");
  proto.set_model("pixel-aligned");
  options = ReconOptionsFromProto(proto);
  ASSERT_TRUE(options.ok()) << options.status();
  EXPECT_TRUE(ColourGradientsFor(*options));
  proto.set_colour("");
  options = ReconOptionsFromProto(proto);
  ASSERT_TRUE(options.ok()) << options.status();
  EXPECT_FALSE(ColourGradientsFor(*options));  // Pixel-aligned's default.
  proto.set_model("");
  proto.set_colour("stripes");
  EXPECT_EQ(ReconOptionsFromProto(proto).status().message(),
            "options.colour: unknown colour model 'stripes' (expected gradients or flat)");
  proto.set_colour("");

  EXPECT_EQ(options->colour_encoding, ColourEncoding::kSrgb);
  EXPECT_EQ(options->completion.method, CompletionOptions::Method::kNearest);
  proto.set_working_space("linear");
  proto.set_completion("ip-basic");
  options = ReconOptionsFromProto(proto);
  ASSERT_TRUE(options.ok()) << options.status();
  EXPECT_EQ(options->colour_encoding, ColourEncoding::kLinear);
  EXPECT_EQ(options->completion.method, CompletionOptions::Method::kIpBasic);
  proto.clear_working_space();
  proto.clear_completion();

  proto.set_refine(0);  // Set to 0 is not unset: no fit.
  proto.set_splat_sigma(0.5);
  proto.set_low_pass(0.3);
  proto.set_hidden_band(0);
  proto.set_no_ground_fill(true);
  proto.set_no_facades(true);
  proto.set_no_ego_layer(true);
  options = ReconOptionsFromProto(proto);
  ASSERT_TRUE(options.ok()) << options.status();
  EXPECT_EQ(options->refinement.iterations, 0);
  EXPECT_EQ(options->decoder.tangent_sigma, 0.5);
  ASSERT_TRUE(options->decoder.low_pass.has_value());
  EXPECT_FLOAT_EQ(*options->decoder.low_pass, 0.3f);
  EXPECT_EQ(options->hidden_band_px, 0);
  EXPECT_FALSE(options->completion.ground_fill);
  EXPECT_FALSE(options->completion.facades);
  EXPECT_FALSE(options->ego_layer);

  proto.set_refine(65);
  EXPECT_EQ(ReconOptionsFromProto(proto).status().message(),
            "options.refine: must be in [0, 64] iterations, got 65");
  proto.set_refine(4);
  proto.set_splat_sigma(0.05);
  EXPECT_EQ(ReconOptionsFromProto(proto).status().message(),
            "options.splat_sigma: must be in (0.05, 4], got 0.05");
}

TEST_F(TaskRunner, ReconstructionStopsWhenCancelled) {
  const absl::Status status = Reconstruct(*work_, "cancelled", [] { return true; });
  EXPECT_EQ(status.code(), absl::StatusCode::kCancelled) << status;
  EXPECT_FALSE(fs::exists(*dir_ + "/cancelled/scene.pfs"));
}

TEST(WithoutDateTime, BlanksOnlyTheAttributeValue) {
  const std::string header =
      std::string("v/1\1name\0capDate\0string\0\x13\0\0\0", 28) + "2026:11:21 08:15:31" + "rest";
  EXPECT_EQ(WithoutDateTime(header), std::string("v/1\1name\0capDate\0string\0\x13\0\0\0", 28) +
                                         std::string(19, '-') + "rest");
  EXPECT_EQ(WithoutDateTime("no such attribute"), "no such attribute");
}

TEST_F(TaskRunner, RenderChunkMatchesPfRenderByteForByte) {
  // The whole job rendered by `pf render`.
  const std::string embedded = *dir_ + "/embedded";
  const CommandResult render = PfRender(FourViews(), embedded);
  ASSERT_EQ(render.exit_code, 0) << render.err;

  // Views 1-2 of 4 as a chunk.
  absl::StatusOr<OpenedScene> opened = OpenScene(recon_->scene_path);
  ASSERT_TRUE(opened.ok()) << opened.status();
  std::vector<int> frames;
  const std::string out = *dir_ + "/chunk";
  absl::StatusOr<RenderChunkOutput> chunk = RenderChunk(
      ChunkOf(1, 2), *opened, out, [&](int done) { frames.push_back(done); }, [] { return false; });
  ASSERT_TRUE(chunk.ok()) << chunk.status();
  EXPECT_EQ(frames, (std::vector<int>{1, 2}));
  ASSERT_EQ(ChunkOf(1, 2).views().views_size(), 2);
  // The same chunk carrying all of the job's views (older servers).
  const std::string whole = *dir_ + "/whole_job_chunk";
  absl::StatusOr<RenderChunkOutput> from_whole =
      RenderChunk(ChunkOf(1, 2, true), *opened, whole, nullptr, nullptr);
  ASSERT_TRUE(from_whole.ok()) << from_whole.status();
  EXPECT_EQ(FilesIn(whole), FilesIn(out));

  EXPECT_EQ(FilesIn(out), (std::set<std::string>{"v1.exr", "v1.png", "v2.exr", "v2.png"}));
  ASSERT_EQ(chunk->files.size(), 4u);
  EXPECT_EQ(chunk->files[0].name, "v1.exr");
  EXPECT_EQ(chunk->files[0].view, "v1");
  EXPECT_EQ(chunk->files[3].name, "v2.png");
  EXPECT_EQ(chunk->files[3].path, out + "/v2.png");
  for (const RenderedFile& file : chunk->files) {
    absl::StatusOr<std::string> ours = ReadFileToString(file.path);
    absl::StatusOr<std::string> theirs = ReadFileToString(embedded + "/" + file.name);
    ASSERT_TRUE(ours.ok() && theirs.ok()) << file.name;
    EXPECT_GT(ours->size(), 1000u) << file.name;
    // Byte for byte but for the second the file was written at.
    if (file.name.ends_with(".exr")) {
      EXPECT_NE(WithoutDateTime(*ours), *ours) << file.name << ": capDate not blanked";
    }
    EXPECT_TRUE(WithoutDateTime(*ours) == WithoutDateTime(*theirs))
        << file.name << " differs from pf render's";
    absl::StatusOr<std::string> older = ReadFileToString(whole + "/" + file.name);
    ASSERT_TRUE(older.ok()) << file.name;
    EXPECT_TRUE(WithoutDateTime(*ours) == WithoutDateTime(*older))
        << file.name << " differs between the chunk's views and the whole job's";
  }

  // The chunk's manifest entries equal pf render's for those views, but for
  // the render time.
  const nlohmann::json views = nlohmann::json::parse(chunk->manifest_views_json);
  absl::StatusOr<std::string> manifest_text = ReadFileToString(embedded + "/manifest.json");
  ASSERT_TRUE(manifest_text.ok());
  const nlohmann::json manifest = nlohmann::json::parse(*manifest_text);
  ASSERT_TRUE(views.is_array());
  ASSERT_EQ(views.size(), 2u);
  for (int i = 0; i < 2; ++i) {
    nlohmann::json ours = views[i], theirs = manifest["views"][i + 1];
    ours.erase("renderMs");
    theirs.erase("renderMs");
    EXPECT_EQ(ours, theirs) << "view " << i + 1;
  }
  EXPECT_EQ(views[0]["exr"], "v1.exr");
}

// A job's sweeps follow its views: a chunk of the last view and both sweeps
// writes what `pf render` writes for them.
TEST_F(TaskRunner, RenderChunkRendersSweepsAfterTheViewsAsPfRenderDoes) {
  ASSERT_GE(clip_->lidar_size(), 2);
  pb::RenderViews views = FourViews();
  for (int i = 0; i < 2; ++i) {
    pb::LidarView* lidar = views.add_lidars();
    lidar->set_name(absl::StrCat("s", i));
    for (int b = 0; b < 8; ++b) lidar->mutable_spec()->add_beam_elevations_deg(-14 + 2 * b);
    lidar->mutable_spec()->set_azimuth_resolution_deg(1);
    lidar->set_timestamp_us(clip_->lidar(i).timestamp_us());
    *lidar->mutable_world_from_sensor() = clip_->lidar(i).world_from_sensor();
  }
  const std::string embedded = *dir_ + "/embedded_lidars";
  const CommandResult render = PfRender(views, embedded);
  ASSERT_EQ(render.exit_code, 0) << render.err;

  // Frames 3-5 (v3, s0, s1) as the server sends them.
  pb::RenderWork work;
  work.set_scene("scenes/test");
  *work.mutable_views()->mutable_cameras() = views.cameras();
  *work.mutable_views()->add_views() = views.views(3);
  *work.mutable_views()->mutable_lidars() = views.lidars();
  work.set_first_view(3);
  work.set_view_count(3);
  absl::StatusOr<OpenedScene> opened = OpenScene(recon_->scene_path);
  ASSERT_TRUE(opened.ok()) << opened.status();
  std::vector<int> frames;
  const std::string out = *dir_ + "/chunk_lidars";
  absl::StatusOr<RenderChunkOutput> chunk = RenderChunk(
      work, *opened, out, [&](int done) { frames.push_back(done); }, nullptr);
  ASSERT_TRUE(chunk.ok()) << chunk.status();
  EXPECT_EQ(frames, (std::vector<int>{1, 2, 3}));
  std::vector<std::string> names;
  for (const RenderedFile& file : chunk->files) names.push_back(file.name + "@" + file.view);
  EXPECT_EQ(names,
            (std::vector<std::string>{"v3.exr@v3", "v3.png@v3", "s0.range.exr@s0",
                                      "s0.lidar.bin@s0", "s1.range.exr@s1", "s1.lidar.bin@s1"}));
  for (const RenderedFile& file : chunk->files) {
    absl::StatusOr<std::string> ours = ReadFileToString(file.path);
    absl::StatusOr<std::string> theirs = ReadFileToString(embedded + "/" + file.name);
    ASSERT_TRUE(ours.ok() && theirs.ok()) << file.name;
    EXPECT_TRUE(WithoutDateTime(*ours) == WithoutDateTime(*theirs))
        << file.name << " differs from pf render's";
  }

  // Manifest entries: the view's and the sweeps' as pf render's but for the
  // render time; the sweeps hit the scene.
  const nlohmann::json ours_views = nlohmann::json::parse(chunk->manifest_views_json);
  const nlohmann::json ours_lidars = nlohmann::json::parse(chunk->manifest_lidars_json);
  absl::StatusOr<std::string> manifest_text = ReadFileToString(embedded + "/manifest.json");
  ASSERT_TRUE(manifest_text.ok());
  const nlohmann::json manifest = nlohmann::json::parse(*manifest_text);
  ASSERT_EQ(ours_views.size(), 1u);
  ASSERT_EQ(ours_lidars.size(), 2u);
  auto without_time = [](nlohmann::json entry) {
    entry.erase("renderMs");
    return entry;
  };
  EXPECT_EQ(without_time(ours_views[0]), without_time(manifest["views"][3]));
  for (int i = 0; i < 2; ++i) {
    EXPECT_EQ(without_time(ours_lidars[i]), without_time(manifest["lidars"][i])) << "sweep " << i;
    EXPECT_EQ(ours_lidars[i]["beams"], 8);
    EXPECT_EQ(ours_lidars[i]["columns"], 360);
    EXPECT_GT(ours_lidars[i]["returns"].get<int>(), 100) << "sweep " << i;
  }
}

TEST_F(TaskRunner, RenderChunkStopsBeforeTheNextViewWhenCancelled) {
  absl::StatusOr<OpenedScene> opened = OpenScene(recon_->scene_path);
  ASSERT_TRUE(opened.ok()) << opened.status();
  int done = 0;
  const std::string out = *dir_ + "/cancelled_chunk";
  absl::StatusOr<RenderChunkOutput> chunk = RenderChunk(
      ChunkOf(0, 4), *opened, out, [&](int frames_done) { done = frames_done; },
      [&] { return done >= 1; });
  EXPECT_EQ(chunk.status().code(), absl::StatusCode::kCancelled) << chunk.status();
  EXPECT_NE(chunk.status().message().find("before frame 1"), absl::string_view::npos);
  EXPECT_EQ(FilesIn(out), (std::set<std::string>{"v0.exr", "v0.png"}));
}

TEST_F(TaskRunner, RenderChunkRefusesBadInput) {
  absl::StatusOr<OpenedScene> opened = OpenScene(recon_->scene_path);
  ASSERT_TRUE(opened.ok()) << opened.status();
  const auto run = [&](const pb::RenderWork& work) {
    return RenderChunk(work, *opened, *dir_ + "/bad_chunk", nullptr, nullptr).status();
  };
  absl::Status status = run(ChunkOf(3, 2, true));
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("views.views: the task carries 4 frames, neither the chunk's 2 "
                                  "nor the job's up to frame 5"),
            absl::string_view::npos)
      << status;
  // One view carried for a chunk of two.
  status = run(ChunkOf(3, 2));
  EXPECT_NE(status.message().find("views.views: the task carries 1 frames, neither the chunk's 2"),
            absl::string_view::npos)
      << status;
  status = run(ChunkOf(-1, 1));
  EXPECT_NE(status.message().find("first_view: must be >= 0, got -1"), absl::string_view::npos)
      << status;
  status = run(ChunkOf(0, 0));
  EXPECT_NE(status.message().find("view_count: must be >= 1, got 0"), absl::string_view::npos)
      << status;

  pb::RenderWork work = ChunkOf(0, 1);
  work.add_outputs("normals");
  status = run(work);
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(status.message().rfind("outputs: ", 0), 0u) << status;

  work = ChunkOf(0, 1);
  work.mutable_views()->mutable_views(0)->set_camera("rear");
  status = run(work);
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("views[0].camera: unknown camera 'rear'"),
            absl::string_view::npos)
      << status;
  EXPECT_FALSE(fs::exists(*dir_ + "/bad_chunk/v0.exr"));
}

TEST_F(TaskRunner, RenderChunkChecksTheServersLimitsOnAViewBeforeRendering) {
  absl::StatusOr<OpenedScene> opened = OpenScene(recon_->scene_path);
  ASSERT_TRUE(opened.ok()) << opened.status();
  // 1e9 x 1e9 once aborted the worker (std::length_error), every attempt.
  pb::RenderWork work = ChunkOf(0, 1);
  work.mutable_views()->mutable_cameras(0)->set_width(1000000000);
  work.mutable_views()->mutable_cameras(0)->set_height(1000000000);
  work.set_max_pixels_per_view(50000000);
  absl::Status status = RenderChunk(work, *opened, *dir_ + "/huge", nullptr, nullptr).status();
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(status.message().rfind("views.cameras[0]: 1000000000x1000000000 = ", 0), 0u) << status;
  // No limits from the server: the rasterizer's own bound still holds.
  work.set_max_pixels_per_view(0);
  status = RenderChunk(work, *opened, *dir_ + "/huge", nullptr, nullptr).status();
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument) << status;
  // The memory estimate with the scene's real channel count.
  work = ChunkOf(0, 1);
  work.set_max_render_bytes(1000);
  status = RenderChunk(work, *opened, *dir_ + "/huge", nullptr, nullptr).status();
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("over the limit of 1000 per view (--max-render-bytes)"),
            absl::string_view::npos)
      << status;
  EXPECT_FALSE(fs::exists(*dir_ + "/huge/v0.exr"));
}

}  // namespace
}  // namespace pf
