// pf --server run as a process against a loopback gRPC server made of the
// real BlobService (over a real BlobStore directory) and a scripted stand-in
// for the scene, render and operations services, whose answers each test
// sets. It pins what the client sends (uploaded files keyed as the manifest
// writes them, options, views), what it prints, what it downloads and its
// exit codes. The real pf-server is exercised by the end-to-end tests.
#include <gtest/gtest.h>

#include <deque>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "common/file_util.h"
#include "common/hash.h"
#include "google/longrunning/operations.grpc.pb.h"
#include "google/protobuf/empty.pb.h"
#include "grpcpp/security/server_credentials.h"
#include "grpcpp/server.h"
#include "grpcpp/server_builder.h"
#include "pointforward/v1/service.grpc.pb.h"
#include "server/blobs/blob_service.h"
#include "server/blobs/blob_store.h"
#include "tests/test_util.h"
#include "worker/engine/clip/clip_test_util.h"

namespace pf {
namespace {

namespace v1 = pointforward::v1;
namespace lro = google::longrunning;
using testing::BinPath;
using testing::CommandResult;
using testing::RunCommand;

// The scene, render and operations services, answering from a script.
class ScriptedServer final : public v1::SceneService::Service,
                             public v1::RenderService::Service,
                             public lro::Operations::Service {
 public:
  // What the test sets before running pf.
  lro::Operation create_response;                   // CreateScene / CreateRenderJob.
  std::deque<lro::Operation> wait_script;           // WaitOperation, in turn; the last repeats.
  std::vector<v1::ListScenesResponse> scene_pages;  // Page i answers token "p<i>".
  std::vector<v1::ExportSceneChunk> export_chunks;
  grpc::Status get_scene_status;
  lro::ListOperationsResponse operations;
  bool wait_unimplemented = false;  // Answer WaitOperation with UNIMPLEMENTED.

  // What pf sent.
  v1::CreateSceneRequest scene_request;
  v1::CreateRenderJobRequest render_request;
  std::vector<std::string> waited;  // WaitOperation and GetOperation names.
  std::vector<std::string> cancelled;
  std::vector<int> page_sizes;

  std::mutex mu;

 private:
  // Answers with the next operation of wait_script (the last one repeats).
  grpc::Status NextInScript(const std::string& name, lro::Operation* response) {
    waited.push_back(name);
    if (wait_script.empty()) return {grpc::StatusCode::NOT_FOUND, name + " not found"};
    *response = wait_script.front();
    if (wait_script.size() > 1) wait_script.pop_front();
    return grpc::Status::OK;
  }

 public:
  grpc::Status CreateScene(grpc::ServerContext*, const v1::CreateSceneRequest* request,
                           lro::Operation* response) override {
    std::lock_guard<std::mutex> lock(mu);
    scene_request = *request;
    *response = create_response;
    return grpc::Status::OK;
  }
  grpc::Status GetScene(grpc::ServerContext*, const v1::GetSceneRequest*, v1::Scene*) override {
    std::lock_guard<std::mutex> lock(mu);
    return get_scene_status;
  }
  grpc::Status ListScenes(grpc::ServerContext*, const v1::ListScenesRequest* request,
                          v1::ListScenesResponse* response) override {
    std::lock_guard<std::mutex> lock(mu);
    page_sizes.push_back(request->page_size());
    const size_t page =
        request->page_token().empty() ? 0 : std::stoul(request->page_token().substr(1));
    if (page >= scene_pages.size()) return {grpc::StatusCode::INVALID_ARGUMENT, "page_token: bad"};
    *response = scene_pages[page];
    return grpc::Status::OK;
  }
  grpc::Status ExportScene(grpc::ServerContext*, const v1::ExportSceneRequest*,
                           grpc::ServerWriter<v1::ExportSceneChunk>* writer) override {
    std::lock_guard<std::mutex> lock(mu);
    for (const v1::ExportSceneChunk& chunk : export_chunks) writer->Write(chunk);
    return grpc::Status::OK;
  }
  grpc::Status CreateRenderJob(grpc::ServerContext*, const v1::CreateRenderJobRequest* request,
                               lro::Operation* response) override {
    std::lock_guard<std::mutex> lock(mu);
    render_request = *request;
    *response = create_response;
    return grpc::Status::OK;
  }
  grpc::Status WaitOperation(grpc::ServerContext*, const lro::WaitOperationRequest* request,
                             lro::Operation* response) override {
    std::lock_guard<std::mutex> lock(mu);
    if (wait_unimplemented) return {grpc::StatusCode::UNIMPLEMENTED, "no WaitOperation"};
    return NextInScript(request->name(), response);
  }
  grpc::Status GetOperation(grpc::ServerContext*, const lro::GetOperationRequest* request,
                            lro::Operation* response) override {
    std::lock_guard<std::mutex> lock(mu);
    return NextInScript(request->name(), response);
  }
  grpc::Status CancelOperation(grpc::ServerContext*, const lro::CancelOperationRequest* request,
                               google::protobuf::Empty*) override {
    std::lock_guard<std::mutex> lock(mu);
    cancelled.push_back(request->name());
    return grpc::Status::OK;
  }
  grpc::Status ListOperations(grpc::ServerContext*, const lro::ListOperationsRequest*,
                              lro::ListOperationsResponse* response) override {
    std::lock_guard<std::mutex> lock(mu);
    *response = operations;
    return grpc::Status::OK;
  }
};

// Operation `name` with metadata for `target`.
lro::Operation MakeOperation(const std::string& name, const std::string& kind,
                             const std::string& target, const std::string& state) {
  lro::Operation operation;
  operation.set_name(name);
  v1::OperationMetadata metadata;
  metadata.set_kind(kind);
  metadata.set_target(target);
  metadata.set_state(state);
  operation.mutable_metadata()->PackFrom(metadata);
  operation.set_done(state == "SUCCEEDED" || state == "FAILED" || state == "CANCELLED");
  return operation;
}

v1::OperationMetadata MetadataOf(const lro::Operation& operation) {
  v1::OperationMetadata metadata;
  operation.metadata().UnpackTo(&metadata);
  return metadata;
}

std::string ReadAll(const std::string& path) {
  absl::StatusOr<std::string> text = ReadFileToString(path);
  return text.ok() ? *text : "<" + std::string(text.status().message()) + ">";
}

class RemoteLoopbackTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::MakeTempDir("remote_loopback");
    store_ = std::make_unique<BlobStore>(dir_ + "/blobs");
    blob_service_ = std::make_unique<BlobServiceImpl>(store_.get(), 0);
    grpc::ServerBuilder builder;
    int port = 0;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
    builder.RegisterService(blob_service_.get());
    builder.RegisterService(static_cast<v1::SceneService::Service*>(&scripted_));
    builder.RegisterService(static_cast<v1::RenderService::Service*>(&scripted_));
    builder.RegisterService(static_cast<lro::Operations::Service*>(&scripted_));
    server_ = builder.BuildAndStart();
    ASSERT_NE(server_, nullptr);
    address_ = absl::StrCat("127.0.0.1:", port);
  }
  void TearDown() override { server_->Shutdown(); }

  // Runs pf --server ADDRESS `args`.
  CommandResult Pf(const std::vector<std::string>& args) {
    std::vector<std::string> argv = {BinPath("pf"), "--server", address_};
    argv.insert(argv.end(), args.begin(), args.end());
    return RunCommand(argv);
  }

  // Writes a RenderViews JSON with two views and returns its path.
  std::string WriteViews() {
    const std::string path = dir_ + "/views.json";
    std::ofstream(path) << R"({"views": [
        {"camera": "front", "timestampUs": "0", "name": "a"},
        {"camera": "front", "timestampUs": "100000", "name": "b"}]})";
    return path;
  }

  // A successful render operation whose RenderJob lists `names` with the
  // digests of `contents`, stored in the blob store.
  lro::Operation RenderDone(const std::vector<std::string>& names,
                            const std::vector<std::string>& contents) {
    lro::Operation operation =
        MakeOperation("operations/r1", "render", "renderJobs/r1", "SUCCEEDED");
    v1::RenderJob job;
    job.set_name("renderJobs/r1");
    job.set_state(v1::RenderJob::SUCCEEDED);
    for (size_t i = 0; i < names.size(); ++i) {
      const absl::StatusOr<BlobDigest> digest = store_->Put(contents[i]);
      EXPECT_TRUE(digest.ok()) << digest.status();
      v1::OutputFile* file = job.add_files();
      file->set_name(names[i]);
      file->mutable_digest()->set_sha256(digest->sha256);
      file->mutable_digest()->set_size_bytes(digest->size_bytes);
    }
    operation.mutable_response()->PackFrom(job);
    return operation;
  }

  std::string dir_;
  std::unique_ptr<BlobStore> store_;
  std::unique_ptr<BlobServiceImpl> blob_service_;
  ScriptedServer scripted_;
  std::unique_ptr<grpc::Server> server_;
  std::string address_;
};

TEST_F(RemoteLoopbackTest, SceneCreateUploadsEveryFileKeyedAsWritten) {
  const std::string clip_dir = dir_ + "/clip";
  const std::string manifest = testing::WriteTestClip(clip_dir, testing::MakeTestClip(clip_dir));
  scripted_.create_response = MakeOperation("operations/j1", "reconstruct", "scenes/s1", "QUEUED");

  const CommandResult result = Pf({"scene", "create", manifest, "--model", "pixel-aligned", "--ns",
                                   "7", "--no-lifespan", "--request-id", "req-1"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(result.out, "operations/j1\n");

  const v1::CreateSceneRequest& request = scripted_.scene_request;
  EXPECT_EQ(request.request_id(), "req-1");
  EXPECT_EQ(request.options().model(), "pixel-aligned");
  EXPECT_EQ(request.options().ns(), 7);
  EXPECT_TRUE(request.options().no_lifespan());
  ASSERT_TRUE(request.clip().has_uploaded());
  const v1::UploadedClip& uploaded = request.clip().uploaded();
  EXPECT_EQ(uploaded.manifest().sha256(), *Sha256File(manifest));
  EXPECT_TRUE(store_->Contains(uploaded.manifest().sha256()));
  // 6 images, 3 depth maps, 2 LiDAR sweeps; keys as the manifest writes them.
  ASSERT_EQ(uploaded.files_size(), 11);
  ASSERT_EQ(uploaded.files().count("images/front_1.png"), 1u);
  ASSERT_EQ(uploaded.files().count("lidar/1.bin"), 1u);
  for (const auto& [key, digest] : uploaded.files()) {
    EXPECT_EQ(digest.sha256(), *Sha256File(clip_dir + "/" + key)) << key;
    EXPECT_EQ(digest.size_bytes(),
              static_cast<int64_t>(std::filesystem::file_size(clip_dir + "/" + key)));
    EXPECT_EQ(*store_->Get(digest.sha256()), ReadAll(clip_dir + "/" + key)) << key;
  }
}

TEST_F(RemoteLoopbackTest, FileUriIsSentWithoutUpload) {
  scripted_.create_response = MakeOperation("operations/j1", "reconstruct", "scenes/s1", "QUEUED");
  const CommandResult result = Pf({"scene", "create", "file:///shared/clip.json"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(scripted_.scene_request.clip().uri(), "file:///shared/clip.json");
}

TEST_F(RemoteLoopbackTest, SceneCreateWaitShowsProgressLinesThenTheScene) {
  scripted_.create_response = MakeOperation("operations/j1", "reconstruct", "scenes/s1", "QUEUED");
  lro::Operation running = MakeOperation("operations/j1", "reconstruct", "scenes/s1", "RUNNING");
  v1::OperationMetadata metadata = MetadataOf(running);
  metadata.set_stage("sampling");
  metadata.set_fraction(0.5);
  running.mutable_metadata()->PackFrom(metadata);
  lro::Operation done = MakeOperation("operations/j1", "reconstruct", "scenes/s1", "SUCCEEDED");
  v1::Scene scene;
  scene.set_name("scenes/s1");
  scene.set_state(v1::Scene::READY);
  scene.set_gaussians(1234);
  scene.set_static_gaussians(1000);
  scene.set_dynamic_gaussians(234);
  done.mutable_response()->PackFrom(scene);
  scripted_.wait_script = {running, running, done};

  const std::string clip_dir = dir_ + "/clip";
  const std::string manifest = testing::WriteTestClip(clip_dir, testing::MakeTestClip(clip_dir));
  const CommandResult result = Pf({"scene", "create", manifest, "--wait"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  // stderr is a pipe: plain lines, each once.
  EXPECT_NE(result.err.find("scenes/s1: RUNNING (50%) sampling\nscenes/s1: SUCCEEDED (0%)"),
            std::string::npos)
      << result.err;
  EXPECT_NE(result.out.find("scene:      scenes/s1\nstate:      READY\n"), std::string::npos)
      << result.out;
  EXPECT_NE(result.out.find("gaussians:  1234 (static 1000, dynamic 234, far 0)"),
            std::string::npos)
      << result.out;
  EXPECT_EQ(scripted_.waited, std::vector<std::string>(3, "operations/j1"));
}

TEST_F(RemoteLoopbackTest, CacheHitIsReportedWithoutWaiting) {
  lro::Operation done = MakeOperation("operations/j0", "reconstruct", "scenes/s1", "SUCCEEDED");
  v1::OperationMetadata metadata = MetadataOf(done);
  metadata.set_cache_hit(true);
  done.mutable_metadata()->PackFrom(metadata);
  v1::Scene scene;
  scene.set_name("scenes/s1");
  scene.set_state(v1::Scene::READY);
  done.mutable_response()->PackFrom(scene);
  scripted_.create_response = done;
  const CommandResult result = Pf({"scene", "create", "file:///shared/clip.json", "--wait"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(result.out.rfind("operations/j0\ncache hit: scenes/s1\nscene:      scenes/s1\n", 0), 0u)
      << result.out;
  EXPECT_TRUE(scripted_.waited.empty());
}

TEST_F(RemoteLoopbackTest, RenderWaitDownloadsEveryOutput) {
  scripted_.create_response = MakeOperation("operations/r1", "render", "renderJobs/r1", "QUEUED");
  scripted_.wait_script = {RenderDone({"a.exr", "a.png", "manifest.json"},
                                      {"exr bytes", "png bytes", "{\"views\": []}"})};
  const std::string out = dir_ + "/out";
  const CommandResult result = Pf({"render", "s1", "--cameras", WriteViews(), "--out", out,
                                   "--wait", "--outputs", "rgb,depth", "--chunk-frames", "2"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(result.out, absl::StrCat("operations/r1\ndownloaded 3 files to ", out, "\n"));
  EXPECT_EQ(ReadAll(out + "/a.exr"), "exr bytes");
  EXPECT_EQ(ReadAll(out + "/a.png"), "png bytes");
  EXPECT_EQ(ReadAll(out + "/manifest.json"), "{\"views\": []}");

  const v1::CreateRenderJobRequest& request = scripted_.render_request;
  EXPECT_EQ(request.scene(), "scenes/s1");
  ASSERT_EQ(request.views().views_size(), 2);
  EXPECT_EQ(request.views().views(1).timestamp_us(), 100000);
  EXPECT_EQ(request.outputs_size(), 2);
  EXPECT_EQ(request.chunk_frames(), 2);
}

TEST_F(RemoteLoopbackTest, RenderOfAClipSendsCreateScene) {
  scripted_.create_response = MakeOperation("operations/r1", "render", "renderJobs/r1", "QUEUED");
  const std::string clip_dir = dir_ + "/clip";
  const std::string manifest = testing::WriteTestClip(clip_dir, testing::MakeTestClip(clip_dir));
  const CommandResult result =
      Pf({"render", "--clip", manifest, "--fusion", "average", "--cameras", WriteViews()});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(result.out, "operations/r1\n");
  const v1::CreateRenderJobRequest& request = scripted_.render_request;
  ASSERT_TRUE(request.has_create_scene());
  EXPECT_EQ(request.create_scene().options().fusion(), "average");
  EXPECT_EQ(request.create_scene().clip().uploaded().files_size(), 11);
}

TEST_F(RemoteLoopbackTest, OutputNamesLeavingTheDirectoryAreRefused) {
  scripted_.create_response = MakeOperation("operations/r1", "render", "renderJobs/r1", "QUEUED");
  scripted_.wait_script = {RenderDone({"a.exr", "../evil.exr"}, {"exr bytes", "evil"})};
  const std::string out = dir_ + "/out";
  const CommandResult result =
      Pf({"render", "scenes/s1", "--cameras", WriteViews(), "--out", out, "--wait"});
  EXPECT_EQ(result.exit_code, 2) << result.err;
  EXPECT_NE(result.err.find("renderJobs/r1 files[1]: output file name '../evil.exr'"),
            std::string::npos)
      << result.err;
  EXPECT_FALSE(std::filesystem::exists(dir_ + "/evil.exr"));
  EXPECT_FALSE(std::filesystem::exists(out + "/a.exr"));
}

TEST_F(RemoteLoopbackTest, FailedAndCancelledJobsAreExitOne) {
  lro::Operation failed = MakeOperation("operations/r2", "render", "renderJobs/r2", "FAILED");
  failed.mutable_error()->set_code(13);
  failed.mutable_error()->set_message("chunk 1 (views 2-3): 3 attempts failed");
  scripted_.wait_script = {failed};
  const CommandResult result = Pf({"jobs", "wait", "renderJobs/r2", "--out", dir_ + "/o"});
  EXPECT_EQ(result.exit_code, 1) << result.err;
  EXPECT_NE(result.err.find("pf: renderJobs/r2 FAILED: chunk 1 (views 2-3): 3 attempts failed"),
            std::string::npos)
      << result.err;
  EXPECT_EQ(scripted_.waited.back(), "operations/r2");
  EXPECT_FALSE(std::filesystem::exists(dir_ + "/o"));

  lro::Operation cancelled = MakeOperation("operations/r3", "render", "renderJobs/r3", "CANCELLED");
  cancelled.mutable_error()->set_code(1);
  cancelled.mutable_error()->set_message("cancelled by the user");
  scripted_.wait_script = {cancelled};
  const CommandResult again = Pf({"jobs", "wait", "r3"});
  EXPECT_EQ(again.exit_code, 1) << again.err;
  EXPECT_NE(again.err.find("pf: renderJobs/r3 CANCELLED: cancelled by the user"), std::string::npos)
      << again.err;
}

TEST_F(RemoteLoopbackTest, ExportWritesThePlyAndChecksItsHash) {
  v1::ExportSceneChunk first, last;
  first.set_data("ply\nformat binary");
  last.set_data("_little_endian 1.0\n");
  last.set_sha256(Sha256Hex("ply\nformat binary_little_endian 1.0\n"));
  scripted_.export_chunks = {first, last};
  const std::string ply = dir_ + "/out/s.ply";
  const CommandResult result = Pf({"scene", "export", "s1", "--ply", ply});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(ReadAll(ply), "ply\nformat binary_little_endian 1.0\n");

  last.set_sha256(std::string(64, '0'));
  scripted_.export_chunks = {first, last};
  const std::string bad = dir_ + "/out/bad.ply";
  const CommandResult corrupt = Pf({"scene", "export", "s1", "--ply", bad});
  EXPECT_EQ(corrupt.exit_code, 1) << corrupt.err;
  EXPECT_NE(corrupt.err.find("the server sent 0000"), std::string::npos) << corrupt.err;
  EXPECT_FALSE(std::filesystem::exists(bad));
  // No temporary file left behind either: only s.ply.
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir_ + "/out"),
                          std::filesystem::directory_iterator()),
            1);
}

TEST_F(RemoteLoopbackTest, SceneListFollowsEveryPage) {
  v1::ListScenesResponse page0, page1;
  v1::Scene* a = page0.add_scenes();
  a->set_name("scenes/a");
  a->set_state(v1::Scene::READY);
  a->set_model("analytic");
  a->set_gaussians(10);
  page0.set_next_page_token("p1");
  v1::Scene* b = page1.add_scenes();
  b->set_name("scenes/b");
  b->set_state(v1::Scene::CREATING);
  scripted_.scene_pages = {page0, page1};
  const CommandResult result = Pf({"scene", "list", "--page-size", "1"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(result.out,
            "scenes/a                         READY    analytic       10 gaussians\n"
            "scenes/b                         CREATING -              0 gaussians\n");
  EXPECT_EQ(scripted_.page_sizes, (std::vector<int>{1, 1}));
}

TEST_F(RemoteLoopbackTest, ServerErrorsKeepTheirMessageAndExitCode) {
  scripted_.get_scene_status = {grpc::StatusCode::NOT_FOUND, "scenes/zz: no such scene"};
  const CommandResult result = Pf({"scene", "get", "zz"});
  EXPECT_EQ(result.exit_code, 2) << result.err;
  EXPECT_EQ(result.err, "pf scene get: scenes/zz: no such scene\n");
}

TEST_F(RemoteLoopbackTest, JobsListShowsKindStateFramesAndFilters) {
  lro::Operation render = MakeOperation("operations/r1", "render", "renderJobs/r1", "RUNNING");
  v1::OperationMetadata metadata = MetadataOf(render);
  metadata.set_frames_done(13);
  metadata.set_frames_total(25);
  render.mutable_metadata()->PackFrom(metadata);
  lro::Operation recon = MakeOperation("operations/j1", "reconstruct", "scenes/s1", "SUCCEEDED");
  metadata = MetadataOf(recon);
  metadata.set_cache_hit(true);
  recon.mutable_metadata()->PackFrom(metadata);
  *scripted_.operations.add_operations() = render;
  *scripted_.operations.add_operations() = recon;

  const CommandResult all = Pf({"jobs", "list"});
  ASSERT_EQ(all.exit_code, 0) << all.err;
  EXPECT_EQ(all.out,
            "operations/r1                    render      RUNNING           13/25 frames    \n"
            "operations/j1                    reconstruct SUCCEEDED         -                cache "
            "hit\n");
  const CommandResult renders = Pf({"jobs", "list", "--kind", "render"});
  ASSERT_EQ(renders.exit_code, 0) << renders.err;
  EXPECT_EQ(renders.out.find("operations/j1"), std::string::npos) << renders.out;
  EXPECT_NE(renders.out.find("operations/r1"), std::string::npos) << renders.out;
}

TEST_F(RemoteLoopbackTest, WaitPollsGetOperationWhenWaitIsUnimplemented) {
  scripted_.wait_unimplemented = true;
  lro::Operation running = MakeOperation("operations/r1", "render", "renderJobs/r1", "RUNNING");
  v1::OperationMetadata metadata = MetadataOf(running);
  metadata.set_frames_done(1);
  metadata.set_frames_total(2);
  metadata.set_stage("rendering");
  running.mutable_metadata()->PackFrom(metadata);
  scripted_.wait_script = {running, RenderDone({"a.exr"}, {"exr bytes"})};
  const CommandResult result = Pf({"jobs", "wait", "operations/r1", "--out", dir_ + "/o"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.err.find("renderJobs/r1: RUNNING 1/2 frames (50%) rendering\n"),
            std::string::npos)
      << result.err;
  EXPECT_EQ(result.out, absl::StrCat("downloaded 1 files to ", dir_, "/o\n"));
  EXPECT_EQ(ReadAll(dir_ + "/o/a.exr"), "exr bytes");
  EXPECT_EQ(scripted_.waited, (std::vector<std::string>{"operations/r1", "operations/r1"}));
}

TEST_F(RemoteLoopbackTest, JobsGetPrintsJsonWithMetadataUnpacked) {
  lro::Operation running = MakeOperation("operations/r1", "render", "renderJobs/r1", "RUNNING");
  v1::OperationMetadata metadata = MetadataOf(running);
  metadata.set_frames_done(13);
  running.mutable_metadata()->PackFrom(metadata);
  scripted_.wait_script = {running};
  const CommandResult result = Pf({"jobs", "get", "renderJobs/r1"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("\"@type\": \"type.googleapis.com/pointforward.v1.OperationMetadata\""),
            std::string::npos)
      << result.out;
  EXPECT_NE(result.out.find("\"framesDone\": 13"), std::string::npos) << result.out;
  EXPECT_EQ(scripted_.waited, std::vector<std::string>{"operations/r1"});
}

TEST_F(RemoteLoopbackTest, JobsCancelSendsTheOperationName) {
  const CommandResult result = Pf({"jobs", "cancel", "renderJobs/r7"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(result.out, "cancel requested: operations/r7\n");
  EXPECT_EQ(scripted_.cancelled, std::vector<std::string>{"operations/r7"});
}

}  // namespace
}  // namespace pf
