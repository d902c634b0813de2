// End-to-end tests of the service's limits, path safety and integrity:
// real pf-server and pf-worker processes on loopback (tests/service_harness.h),
// a real SQLite store and blob directory. Each limit is exceeded once and
// its error must name the limit's flag; each way out of a clip's directory
// or a trusted root is tried and refused; a scene file corrupted on disk is
// detected, dropped and rebuilt, and the render still matches embedded mode.
// Hostile input (docs/RELIABILITY.md, "Hostile input"): manifests and
// results nested or sized to crash or stall the server, a worker that lies,
// a poisoned row in the store, render views too large for a worker.
#include <google/protobuf/util/json_util.h>
#include <grpcpp/grpcpp.h>
#include <signal.h>
#include <sqlite3.h>
#include <unistd.h>

#include <cctype>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "common/file_util.h"
#include "common/hash.h"
#include "google/longrunning/operations.grpc.pb.h"
#include "gtest/gtest.h"
#include "pointforward/v1/blobs.grpc.pb.h"
#include "pointforward/v1/resources.pb.h"
#include "pointforward/v1/service.grpc.pb.h"
#include "pointforward/v1/worker.grpc.pb.h"
#include "rpc/blob_transfer.h"
#include "rpc/grpc_status.h"
#include "tests/exr_compare.h"
#include "tests/service_checks.h"
#include "tests/service_harness.h"
#include "tests/test_util.h"

namespace pf {
namespace {

namespace fs = std::filesystem;
namespace v1 = pointforward::v1;
using google::longrunning::Operation;
using testing::BinPath;
using testing::CommandResult;
using testing::GetOperation;
using testing::Metadata;
using testing::RgbPsnr;
using testing::RunCommand;
using testing::ServerProcess;
using testing::SynthSmallClip;
using testing::ViewsOfFirstCamera;
using testing::WaitDone;
using testing::WaitFor;
using testing::WorkerProcess;

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// A synth clip (2 cameras x 6 frames of 192x144), four views of its first
// camera, and embedded-mode renders of them, made once for all tests.
class LimitsE2e : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new std::string(testing::MakeTempDir("limits_e2e"));
    const CommandResult synth = SynthSmallClip(*dir_ + "/clip");
    ASSERT_EQ(synth.exit_code, 0) << synth.err;
    std::ifstream in(*dir_ + "/clip/clip.json");
    manifest_ = new nlohmann::json(nlohmann::json::parse(in));
    // Views v00..v03 at the first camera's frames, each moved 0.1 m sideways.
    std::ofstream(*dir_ + "/views4.json") << ViewsOfFirstCamera(*manifest_, 4, 0.1).dump(2);
    const CommandResult recon =
        RunCommand({BinPath("pf"), "reconstruct", ClipPath(), "--out", *dir_ + "/embedded.pfs"});
    ASSERT_EQ(recon.exit_code, 0) << recon.err;
    const CommandResult render =
        RunCommand({BinPath("pf"), "render", *dir_ + "/embedded.pfs", "--cameras",
                    *dir_ + "/views4.json", "--out", *dir_ + "/embedded"});
    ASSERT_EQ(render.exit_code, 0) << render.err;
  }
  static void TearDownTestSuite() {
    delete manifest_;
    delete dir_;
  }

  static std::string ClipPath() { return *dir_ + "/clip/clip.json"; }

  static v1::RenderViews Views() {
    std::ifstream in(*dir_ + "/views4.json");
    const std::string json((std::istreambuf_iterator<char>(in)), {});
    v1::RenderViews views;
    EXPECT_TRUE(google::protobuf::util::JsonStringToMessage(json, &views).ok());
    return views;
  }

  void SetUp() override { test_dir_ = testing::MakeTempDir("limits_case"); }

  // Uploads every file `manifest` references, from `files_dir`, and the
  // manifest itself; `paths` maps a path as the manifest writes it to the
  // file to upload when that differs from files_dir/path.
  static v1::UploadedClip Upload(BlobClient& blobs, const nlohmann::json& manifest,
                                 const std::map<std::string, std::string>& paths = {}) {
    v1::UploadedClip clip;
    auto add = [&](const std::string& path) {
      const std::string local = paths.count(path) ? paths.at(path) : *dir_ + "/clip/" + path;
      absl::StatusOr<v1::Digest> digest = blobs.UploadFile(local);
      EXPECT_TRUE(digest.ok()) << local << ": " << digest.status();
      if (digest.ok()) (*clip.mutable_files())[path] = *digest;
    };
    for (const nlohmann::json& frame : manifest["frames"]) {
      for (const char* key : {"image", "depth"}) {
        if (frame.contains(key)) add(frame[key]);
      }
    }
    if (manifest.contains("lidar")) {
      for (const nlohmann::json& sweep : manifest["lidar"]) add(sweep["points"]);
    }
    absl::StatusOr<v1::Digest> digest = blobs.UploadBytes(manifest.dump());
    EXPECT_TRUE(digest.ok()) << digest.status();
    if (digest.ok()) *clip.mutable_manifest() = *digest;
    return clip;
  }

  static grpc::Status CreateScene(ServerProcess& server, const v1::ClipSource& clip,
                                  Operation* op) {
    auto stub = v1::SceneService::NewStub(MakeChannel(server.address()));
    v1::CreateSceneRequest request;
    *request.mutable_clip() = clip;
    grpc::ClientContext context;
    return stub->CreateScene(&context, request, op);
  }

  // CreateScene of the test clip uploaded with its first frame's image
  // under `path` (the real image's bytes).
  static grpc::Status CreateSceneWithImageAt(ServerProcess& server, BlobClient& blobs,
                                             const std::string& path) {
    const std::string image = (*manifest_)["frames"][0]["image"];
    nlohmann::json manifest = *manifest_;
    manifest["frames"][0]["image"] = path;
    v1::ClipSource clip;
    *clip.mutable_uploaded() = Upload(blobs, manifest, {{path, *dir_ + "/clip/" + image}});
    Operation op;
    return CreateScene(server, clip, &op);
  }

  static v1::ClipSource Uri(const std::string& path) {
    v1::ClipSource clip;
    clip.set_uri("file://" + path);
    return clip;
  }

  static grpc::Status CreateRender(ServerProcess& server, const v1::CreateRenderJobRequest& request,
                                   Operation* op) {
    auto stub = v1::RenderService::NewStub(MakeChannel(server.address()));
    grpc::ClientContext context;
    return stub->CreateRenderJob(&context, request, op);
  }

  static v1::Scene GetScene(ServerProcess& server, const std::string& name) {
    auto stub = v1::SceneService::NewStub(MakeChannel(server.address()));
    grpc::ClientContext context;
    v1::GetSceneRequest request;
    request.set_name(name);
    v1::Scene scene;
    EXPECT_TRUE(stub->GetScene(&context, request, &scene).ok());
    return scene;
  }

  // Creates the test clip's scene with a worker running and waits for it.
  v1::Scene BuildScene(ServerProcess& server) {
    Operation op;
    const grpc::Status created = CreateScene(server, Uri(ClipPath()), &op);
    EXPECT_TRUE(created.ok()) << created.error_message();
    const Operation done = WaitDone(server.address(), op.name());
    EXPECT_TRUE(done.done() && !done.has_error()) << done.error().message() << server.Log();
    v1::Scene scene;
    EXPECT_TRUE(done.response().UnpackTo(&scene));
    return scene;
  }

  // Renders views4.json of `scene` and downloads every file into `out`;
  // returns the finished operation.
  Operation RenderAndDownload(ServerProcess& server, const std::string& scene,
                              const std::string& out) {
    v1::CreateRenderJobRequest request;
    request.set_scene(scene);
    *request.mutable_views() = Views();
    Operation op;
    const grpc::Status status = CreateRender(server, request, &op);
    EXPECT_TRUE(status.ok()) << status.error_message();
    const Operation done = WaitDone(server.address(), op.name());
    v1::RenderJob job;
    if (!done.done() || done.has_error() || !done.response().UnpackTo(&job)) {
      ADD_FAILURE() << "render " << op.name() << " did not succeed: " << done.error().message()
                    << "\n"
                    << server.Log();
      return done;
    }
    BlobClient blobs(MakeChannel(server.address()));
    for (const v1::OutputFile& file : job.files()) {
      const absl::Status got =
          blobs.DownloadToFile(file.digest().sha256(), out + "/" + file.name());
      EXPECT_TRUE(got.ok()) << file.name() << ": " << got;
    }
    return done;
  }

  std::string BlobPath(const std::string& sha256) const {
    return test_dir_ + "/blobs/" + sha256.substr(0, 2) + "/" + sha256;
  }

  static std::string* dir_;
  static nlohmann::json* manifest_;
  std::string test_dir_;
};

std::string* LimitsE2e::dir_ = nullptr;
nlohmann::json* LimitsE2e::manifest_ = nullptr;

// -- Limits ------------------------------------------------------------------

TEST_F(LimitsE2e, ImagesPerClipAndPixelsPerImageAreCheckedBeforeAnythingIsQueued) {
  const int images = static_cast<int>((*manifest_)["frames"].size());
  ServerProcess server(test_dir_);
  ASSERT_TRUE(
      server.Start({"--trusted-root", *dir_, "--max-images-per-clip", std::to_string(images - 1)}))
      << server.Log();
  Operation op;
  grpc::Status status = CreateScene(server, Uri(ClipPath()), &op);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message(),
            "clip: " + std::to_string(images) + " images exceed the limit of " +
                std::to_string(images - 1) + " per clip (--max-images-per-clip)");
  // The same through an upload, and with the remote CLI.
  BlobClient blobs(MakeChannel(server.address()));
  v1::ClipSource uploaded;
  *uploaded.mutable_uploaded() = Upload(blobs, *manifest_);
  status = CreateScene(server, uploaded, &op);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_TRUE(Contains(status.error_message(), "(--max-images-per-clip)"))
      << status.error_message();
  const CommandResult cli =
      RunCommand({BinPath("pf"), "--server", server.address(), "scene", "create", ClipPath()});
  EXPECT_EQ(cli.exit_code, 2) << cli.out << cli.err;
  EXPECT_TRUE(Contains(cli.err, "--max-images-per-clip")) << cli.err;
  ASSERT_EQ(server.Kill(SIGTERM), 0);

  // 192 x 144 = 27648 pixels per image.
  ServerProcess small(test_dir_, "small");
  ASSERT_TRUE(small.Start({"--trusted-root", *dir_, "--max-pixels-per-image", "27647"}))
      << small.Log();
  status = CreateScene(small, Uri(ClipPath()), &op);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message(),
            "clip.cameras[0]: 192x144 = 27648 pixels per image exceed the limit of 27647 "
            "(--max-pixels-per-image)");
  ASSERT_EQ(small.Kill(SIGTERM), 0);

  // At the limits the clip is accepted.
  ServerProcess exact(test_dir_, "exact");
  ASSERT_TRUE(exact.Start({"--trusted-root", *dir_, "--max-pixels-per-image", "27648",
                           "--max-images-per-clip", std::to_string(images)}))
      << exact.Log();
  status = CreateScene(exact, Uri(ClipPath()), &op);
  EXPECT_TRUE(status.ok()) << status.error_message();
}

TEST_F(LimitsE2e, AReconstructionOverMaxGaussiansFailsNamingTheFlag) {
  ServerProcess server(test_dir_);
  ASSERT_TRUE(server.Start({"--trusted-root", *dir_, "--max-gaussians", "100"})) << server.Log();
  WorkerProcess worker(server.address(), test_dir_, "w1");
  ASSERT_TRUE(worker.Start());
  Operation op;
  ASSERT_TRUE(CreateScene(server, Uri(ClipPath()), &op).ok());
  const Operation done = WaitDone(server.address(), op.name());
  ASSERT_TRUE(done.done()) << server.Log();
  ASSERT_TRUE(done.has_error());
  EXPECT_EQ(done.error().code(), static_cast<int>(grpc::StatusCode::INVALID_ARGUMENT));
  EXPECT_TRUE(Contains(done.error().message(),
                       "Gaussians exceed the limit of 100 per scene (pf-server --max-gaussians)"))
      << done.error().message();
  // Bad input: one attempt, not retried.
  EXPECT_EQ(Metadata(done).attempts_size(), 1);
}

TEST_F(LimitsE2e, UploadSizeViewsPerJobAndRequestSizeAreLimited) {
  ServerProcess server(test_dir_);
  ASSERT_TRUE(server.Start({"--trusted-root", *dir_, "--max-views", "3", "--max-request-bytes",
                            "2097152", "--max-upload-bytes", "100000"}))
      << server.Log();
  // One blob over the upload limit (its chunks are each under the request
  // limit): refused, naming the limit.
  BlobClient blobs(MakeChannel(server.address()));
  absl::StatusOr<v1::Digest> big = blobs.UploadBytes(std::string(100001, 'x'));
  EXPECT_EQ(big.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_TRUE(
      Contains(std::string(big.status().message()),
               "100001 bytes exceeds the upload limit of 100000 bytes (--max-upload-bytes)"))
      << big.status();
  EXPECT_TRUE(blobs.UploadBytes(std::string(100000, 'x')).ok());

  v1::CreateRenderJobRequest request;
  request.mutable_create_scene()->mutable_clip()->set_uri("file://" + ClipPath());
  *request.mutable_views() = Views();  // Four views.
  Operation op;
  grpc::Status status = CreateRender(server, request, &op);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message(),
            "views.views: 4 views exceed the limit of 3 per render job (pf-server --max-views)");

  // About 3 MB of views: gRPC refuses the message before any handler runs;
  // its message gives the limit's value (it cannot name our flag).
  const v1::View first = request.views().views(0);
  request.mutable_views()->clear_views();
  for (int i = 0; i < 20000; ++i) {
    v1::View* view = request.mutable_views()->add_views();
    *view = first;
    view->set_name("view_with_a_long_name_" + std::to_string(i) + std::string(100, 'x'));
  }
  ASSERT_GT(request.ByteSizeLong(), 2097152u);
  status = CreateRender(server, request, &op);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_TRUE(Contains(status.error_message(), "2097152")) << status.error_message();

  // The server is unharmed and takes requests under both limits.
  request.mutable_views()->mutable_views()->DeleteSubrange(3, 20000 - 3);
  status = CreateRender(server, request, &op);
  EXPECT_TRUE(status.ok()) << status.error_message();
}

TEST_F(LimitsE2e, UnfinishedJobsPerOwnerAreLimited) {
  ServerProcess server(test_dir_);
  ASSERT_TRUE(server.Start({"--trusted-root", *dir_, "--max-jobs-per-owner", "2"})) << server.Log();
  // No worker: nothing finishes. The reconstruction is one job...
  Operation scene_op;
  ASSERT_TRUE(CreateScene(server, Uri(ClipPath()), &scene_op).ok());
  v1::OperationMetadata scene_metadata = Metadata(scene_op);
  const std::string scene = scene_metadata.target();
  v1::CreateRenderJobRequest request;
  request.set_scene(scene);
  *request.mutable_views() = Views();
  request.mutable_views()->mutable_views()->DeleteSubrange(1, 3);
  // ...a render job waiting for it the second...
  Operation first;
  grpc::Status status = CreateRender(server, request, &first);
  ASSERT_TRUE(status.ok()) << status.error_message();
  // ...and a third is refused.
  Operation op;
  status = CreateRender(server, request, &op);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_TRUE(Contains(status.error_message(),
                       "2 unfinished jobs, the limit of 2 per owner (--max-jobs-per-owner)"))
      << status.error_message();
  // The same clip again adds no job: a join, allowed.
  EXPECT_TRUE(CreateScene(server, Uri(ClipPath()), &op).ok());
  // Once one ends (cancelled), there is room again.
  {
    auto ops = google::longrunning::Operations::NewStub(MakeChannel(server.address()));
    grpc::ClientContext context;
    google::longrunning::CancelOperationRequest cancel;
    cancel.set_name(first.name());
    google::protobuf::Empty empty;
    ASSERT_TRUE(ops->CancelOperation(&context, cancel, &empty).ok());
  }
  status = CreateRender(server, request, &op);
  EXPECT_TRUE(status.ok()) << status.error_message();
}

// Bytes of every blob under `blobs` (the two-hex-digit directories).
int64_t BlobBytes(const std::string& blobs) {
  int64_t total = 0;
  for (const auto& dir : fs::directory_iterator(blobs)) {
    if (dir.path().filename().string().size() != 2) continue;
    for (const auto& file : fs::directory_iterator(dir.path())) total += file.file_size();
  }
  return total;
}

TEST_F(LimitsE2e, TheBlobStoreLimitEvictsLeastRecentlyUsedScenesNeverOnesInUse) {
  // Two scenes of the clip (two fusion settings), built without a limit.
  std::string scene_a, scene_b, file_a, file_b;
  {
    ServerProcess server(test_dir_);
    ASSERT_TRUE(server.Start({"--trusted-root", *dir_})) << server.Log();
    WorkerProcess worker(server.address(), test_dir_, "w1");
    ASSERT_TRUE(worker.Start());
    for (const char* fusion : {"softmax", "average"}) {
      auto stub = v1::SceneService::NewStub(MakeChannel(server.address()));
      v1::CreateSceneRequest request;
      request.mutable_clip()->set_uri("file://" + ClipPath());
      request.mutable_options()->set_fusion(fusion);
      grpc::ClientContext context;
      Operation op;
      ASSERT_TRUE(stub->CreateScene(&context, request, &op).ok());
      const Operation done = WaitDone(server.address(), op.name());
      v1::Scene scene;
      ASSERT_TRUE(done.done() && done.response().UnpackTo(&scene)) << server.Log();
      (scene_a.empty() ? scene_a : scene_b) = scene.name();
      (file_a.empty() ? file_a : file_b) = scene.scene_file().sha256();
    }
    ASSERT_EQ(worker.Kill(SIGTERM), 0);
    ASSERT_EQ(server.Kill(SIGTERM), 0);
  }
  ASSERT_NE(file_a, file_b);
  const int64_t total = BlobBytes(test_dir_ + "/blobs");
  const int64_t size_a = static_cast<int64_t>(fs::file_size(BlobPath(file_a)));
  ASSERT_GT(size_a, 100);

  // One byte over the limit: the next upload first evicts the least
  // recently used scene, A, and no more.
  ServerProcess server(test_dir_, "limited");
  ASSERT_TRUE(
      server.Start({"--trusted-root", *dir_, "--max-blob-bytes", std::to_string(total - 1)}))
      << server.Log();
  BlobClient blobs(MakeChannel(server.address()));
  ASSERT_TRUE(blobs.UploadBytes("a small upload").ok());
  auto scene_state = [&](const std::string& name) {
    auto stub = v1::SceneService::NewStub(MakeChannel(server.address()));
    grpc::ClientContext context;
    v1::GetSceneRequest request;
    request.set_name(name);
    v1::Scene scene;
    const grpc::Status status = stub->GetScene(&context, request, &scene);
    return status.ok() ? v1::Scene::State_Name(scene.state()) : "NOT_FOUND";
  };
  EXPECT_EQ(scene_state(scene_a), "NOT_FOUND");
  EXPECT_FALSE(fs::exists(BlobPath(file_a)));
  EXPECT_EQ(scene_state(scene_b), "READY");
  EXPECT_TRUE(fs::exists(BlobPath(file_b)));
  EXPECT_TRUE(Contains(server.Log(), "evicted " + scene_a)) << server.Log();
  EXPECT_LE(BlobBytes(test_dir_ + "/blobs"), total - 1);

  // B has an unfinished render job (no worker runs it): it is in use. An
  // upload that takes the store over the limit is stored, then nothing can
  // be evicted: the next upload is refused, naming the limit.
  v1::CreateRenderJobRequest render;
  render.set_scene(scene_b);
  *render.mutable_views() = Views();
  Operation job;
  ASSERT_TRUE(CreateRender(server, render, &job).ok());
  const int64_t room = total - 1 - BlobBytes(test_dir_ + "/blobs");
  ASSERT_TRUE(blobs.UploadBytes(std::string(room + 10, 'x')).ok());
  absl::StatusOr<v1::Digest> refused = blobs.UploadBytes("one more");
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kResourceExhausted) << refused.status();
  EXPECT_TRUE(Contains(std::string(refused.status().message()), "(--max-blob-bytes)"))
      << refused.status();
  EXPECT_EQ(scene_state(scene_b), "READY");
  EXPECT_TRUE(fs::exists(BlobPath(file_b)));

  // Once the job has ended, B may go and the upload is taken.
  {
    auto ops = google::longrunning::Operations::NewStub(MakeChannel(server.address()));
    grpc::ClientContext context;
    google::longrunning::CancelOperationRequest cancel;
    cancel.set_name(job.name());
    google::protobuf::Empty empty;
    ASSERT_TRUE(ops->CancelOperation(&context, cancel, &empty).ok());
  }
  EXPECT_TRUE(blobs.UploadBytes("one more").ok());
  EXPECT_EQ(scene_state(scene_b), "NOT_FOUND");
  // The cancelled job is still readable (its scene is gone).
  EXPECT_TRUE(GetOperation(server.address(), job.name()).ok());
}

// -- Path safety ----------------------------------------------------------------

TEST_F(LimitsE2e, UploadedClipPathsThatLeaveTheClipAreRefused) {
  ServerProcess server(test_dir_);
  ASSERT_TRUE(server.Start()) << server.Log();
  BlobClient blobs(MakeChannel(server.address()));
  for (const std::string& path : {std::string("../escape.png"), std::string("images/../../x.png"),
                                  std::string("/etc/escape.png")}) {
    const grpc::Status status = CreateSceneWithImageAt(server, blobs, path);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << path;
    EXPECT_TRUE(Contains(status.error_message(), "clip.uploaded.files[\"" + path + "\"]"))
        << path << ": " << status.error_message();
    EXPECT_TRUE(Contains(status.error_message(), path[0] == '/' ? "absolute" : "escapes"))
        << status.error_message();
  }
  // Nothing was written outside the staging area.
  EXPECT_FALSE(fs::exists("/etc/escape.png"));
  EXPECT_FALSE(fs::exists(test_dir_ + "/blobs/escape.png"));
}

TEST_F(LimitsE2e, FileUriClipsAndTheirPathsMustStayUnderTheTrustedRoot) {
  // root/clip is a copy of the clip; outside/ is next to the root.
  const std::string root = test_dir_ + "/root";
  const std::string outside = test_dir_ + "/outside";
  fs::create_directories(outside);
  fs::create_directories(root);
  fs::copy(*dir_ + "/clip", root + "/clip", fs::copy_options::recursive);
  fs::copy(*dir_ + "/clip", outside + "/clip", fs::copy_options::recursive);
  const std::string image = (*manifest_)["frames"][0]["image"];
  fs::copy_file(*dir_ + "/clip/" + image, outside + "/secret.png");

  ServerProcess server(test_dir_);
  ASSERT_TRUE(server.Start({"--trusted-root", root})) << server.Log();
  Operation op;
  ASSERT_TRUE(CreateScene(server, Uri(root + "/clip/clip.json"), &op).ok());

  // The URI itself: climbing out with "..", a path outside, a symlink in the
  // root to a clip outside it.
  fs::create_directory_symlink(outside + "/clip", root + "/link");
  for (const std::string& path : {root + "/../outside/clip/clip.json", outside + "/clip/clip.json",
                                  root + "/link/clip.json"}) {
    const grpc::Status status = CreateScene(server, Uri(path), &op);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << path;
    EXPECT_TRUE(Contains(status.error_message(), "is not under a trusted root"))
        << path << ": " << status.error_message();
  }

  // Paths in a manifest under the root: "..", absolute, a symlink out.
  fs::create_symlink(outside + "/secret.png", root + "/clip/link.png");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"../../outside/secret.png", "escapes"},
      {outside + "/secret.png", "absolute"},
      {"link.png", "escapes"}};
  for (const auto& [path, why] : cases) {
    nlohmann::json manifest = *manifest_;
    manifest["frames"][0]["image"] = path;
    std::ofstream(root + "/clip/bad.json") << manifest.dump();
    const grpc::Status status = CreateScene(server, Uri(root + "/clip/bad.json"), &op);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << path;
    EXPECT_TRUE(Contains(status.error_message(), "frames[0].image"))
        << path << ": " << status.error_message();
    EXPECT_TRUE(Contains(status.error_message(), why)) << path << ": " << status.error_message();
  }
}

TEST_F(LimitsE2e, OutputNamesThatAreNotPlainFileNamesAreRefused) {
  ServerProcess server(test_dir_);
  ASSERT_TRUE(server.Start({"--trusted-root", *dir_})) << server.Log();
  for (const std::string& name :
       {std::string("../x"), std::string("a/b"), std::string(".hidden"), std::string("/abs")}) {
    v1::CreateRenderJobRequest request;
    request.mutable_create_scene()->mutable_clip()->set_uri("file://" + ClipPath());
    *request.mutable_views() = Views();
    request.mutable_views()->mutable_views(1)->set_name(name);
    Operation op;
    const grpc::Status status = CreateRender(server, request, &op);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << name;
    EXPECT_TRUE(Contains(status.error_message(), "views.views[1].name")) << status.error_message();
  }
}

// A LiDAR sweep's rays count against the per-view pixel limit: one over it
// is refused before anything exists, naming the sweep and the flag.
TEST_F(LimitsE2e, ALidarSweepOverThePixelLimitIsRefusedBeforeAJobExists) {
  ServerProcess server(test_dir_);
  ASSERT_TRUE(server.Start({"--trusted-root", *dir_, "--max-pixels-per-image", "1000000"}))
      << server.Log();
  v1::CreateRenderJobRequest request;
  request.mutable_create_scene()->mutable_clip()->set_uri("file://" + ClipPath());
  *request.mutable_views() = Views();
  v1::LidarView* lidar = request.mutable_views()->add_lidars();
  for (int b = 0; b < 1024; ++b) lidar->mutable_spec()->add_beam_elevations_deg(-20 + 0.02 * b);
  lidar->mutable_spec()->set_azimuth_resolution_deg(0.1);
  for (double v : {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}) lidar->add_world_from_sensor(v);
  Operation op;
  grpc::Status status = CreateRender(server, request, &op);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message(),
            "views.lidars[0]: 1024 beams x 3600 columns = 3686400 rays per sweep exceed the "
            "limit of 1000000 (--max-pixels-per-image)");
  EXPECT_TRUE(testing::ListOperations(server.address(), "", 10).empty());
  // A bad spec is named the same way.
  lidar->mutable_spec()->set_azimuth_resolution_deg(1);
  lidar->mutable_spec()->set_rotation_hz(-1);
  status = CreateRender(server, request, &op);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message(), "views.lidars[0].spec.rotationHz: must be in (0, 100], got -1");
}

// -- Integrity ------------------------------------------------------------------

// A scene file corrupted on disk is never rendered: the server finds it
// when it first hands the scene out (its own hash check), or a worker finds
// it downloading (DATA_LOSS). Either way the corrupt blob is dropped, the
// scene rebuilt, and the render job waits for it and completes correctly.
TEST_F(LimitsE2e, ACorruptSceneFileIsDroppedAndRebuiltNotRendered) {
  ServerProcess server(test_dir_);
  ASSERT_TRUE(server.Start({"--trusted-root", *dir_})) << server.Log();
  auto worker = std::make_unique<WorkerProcess>(server.address(), test_dir_, "w1");
  ASSERT_TRUE(worker->Start());
  const v1::Scene scene = BuildScene(server);
  ASSERT_EQ(scene.state(), v1::Scene::READY);
  const std::string first_build = scene.operation();

  auto corrupt = [&](const std::string& sha256) {
    const std::string path = BlobPath(sha256);
    ASSERT_TRUE(fs::exists(path)) << path;
    fs::permissions(path, fs::perms::owner_write, fs::perm_options::add);
    std::fstream file(path, std::ios::in | std::ios::out | std::ios::binary);
    file.seekp(200);
    file.write("garbage garbage garbage", 23);
  };
  auto check_render = [&](const Operation& done, const std::string& out) {
    for (const char* name : {"v00", "v01", "v02", "v03"}) {
      EXPECT_GE(RgbPsnr(out + "/" + name + ".exr", *dir_ + "/embedded/" + name + ".exr"), 60.0)
          << name;
    }
    bool saw_corrupt = false;
    const v1::OperationMetadata metadata = Metadata(done);
    for (const v1::Attempt& attempt : metadata.attempts()) {
      if (Contains(attempt.outcome(), "scene file corrupt")) saw_corrupt = true;
    }
    EXPECT_TRUE(saw_corrupt) << metadata.DebugString();
  };

  // 1. The worker that built the scene (and holds it in memory) goes; the
  // file is corrupted; a fresh worker comes. The server's check at the
  // first lease finds it.
  ASSERT_EQ(worker->Kill(SIGTERM), 0);
  corrupt(scene.scene_file().sha256());
  worker = std::make_unique<WorkerProcess>(server.address(), test_dir_, "w2");
  ASSERT_TRUE(worker->Start());
  const Operation first = RenderAndDownload(server, scene.name(), test_dir_ + "/out1");
  check_render(first, test_dir_ + "/out1");
  const v1::Scene rebuilt = GetScene(server, scene.name());
  EXPECT_EQ(rebuilt.state(), v1::Scene::READY);
  EXPECT_NE(rebuilt.operation(), first_build);
  EXPECT_TRUE(Contains(server.Log(), "rebuilding it in " + rebuilt.operation())) << server.Log();
  // The corrupt bytes are gone: whatever is stored under the old name (the
  // rebuild may produce the same file again) matches its name.
  if (fs::exists(BlobPath(scene.scene_file().sha256()))) {
    EXPECT_EQ(Sha256File(BlobPath(scene.scene_file().sha256())).value(),
              scene.scene_file().sha256());
  }

  // 2. The server has now checked the rebuilt file once; it is corrupted
  // again and a fresh worker downloads it: DATA_LOSS, rebuilt again.
  ASSERT_EQ(worker->Kill(SIGTERM), 0);
  corrupt(rebuilt.scene_file().sha256());
  worker = std::make_unique<WorkerProcess>(server.address(), test_dir_, "w3");
  ASSERT_TRUE(worker->Start());
  const Operation second = RenderAndDownload(server, scene.name(), test_dir_ + "/out2");
  check_render(second, test_dir_ + "/out2");
  // This time the worker's download found it, and told the server.
  EXPECT_TRUE(Contains(worker->Log(), "DATA_LOSS")) << worker->Log();
  EXPECT_TRUE(Contains(server.Log(), "on worker w3 found " + scene.name() + " corrupt"))
      << server.Log();
  const v1::Scene again = GetScene(server, scene.name());
  EXPECT_EQ(again.state(), v1::Scene::READY);
  EXPECT_NE(again.operation(), rebuilt.operation());
  if (fs::exists(BlobPath(rebuilt.scene_file().sha256()))) {
    EXPECT_EQ(Sha256File(BlobPath(rebuilt.scene_file().sha256())).value(),
              rebuilt.scene_file().sha256());
  }
}

// -- Hostile input ------------------------------------------------------------

// `{"name": [[...]]}` nested `depth` levels deep.
std::string DeeplyNested(int depth) {
  return "{\"name\": " + std::string(depth - 1, '[') + std::string(depth - 1, ']') + "}";
}

TEST_F(LimitsE2e, ADeeplyNestedManifestIsRefusedAndTheServerStaysUp) {
  ServerProcess server(test_dir_);
  ASSERT_TRUE(server.Start()) << server.Log();
  // 100,000 levels in 200 KB: the parser once overflowed the server's stack.
  const std::string deep = DeeplyNested(100000);
  BlobClient blobs(MakeChannel(server.address()));
  absl::StatusOr<v1::Digest> manifest = blobs.UploadBytes(deep);
  ASSERT_TRUE(manifest.ok()) << manifest.status();
  v1::ClipSource clip;
  *clip.mutable_uploaded()->mutable_manifest() = *manifest;
  Operation op;
  const grpc::Status status = CreateScene(server, clip, &op);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message(), "clip.uploaded.manifest: JSON nested deeper than 64 levels");
  EXPECT_TRUE(testing::Serving(server.address())) << server.Log();

  // pf validate on the same file: a problem, not a crash.
  const std::string path = test_dir_ + "/deep.json";
  std::ofstream(path) << deep;
  const CommandResult validate = RunCommand({BinPath("pf"), "validate", path});
  EXPECT_EQ(validate.exit_code, 2) << validate.out << validate.err;
  EXPECT_TRUE(Contains(validate.out, "JSON nested deeper than 64 levels")) << validate.out;
}

TEST_F(LimitsE2e, SigtermStopsTheServerWithinFiveSecondsWhileItTakesAHugeManifest) {
  ServerProcess server(test_dir_);
  ASSERT_TRUE(server.Start()) << server.Log();
  // 300,000 frames (about 17 MB): parsing took about a minute (quadratic)
  // before the images-per-clip limit was looked at, and the server waited
  // for it after SIGTERM.
  std::string manifest = R"({"cameras": [{"id": "c", "width": 8, "height": 8}], "frames": [)";
  for (int i = 0; i < 300000; ++i) {
    if (i > 0) manifest += ",";
    manifest += R"({"camera": "c", "timestampUs": )" + std::to_string(i) + R"(, "image": "a.png"})";
  }
  manifest += "]}";
  BlobClient blobs(MakeChannel(server.address()));
  absl::StatusOr<v1::Digest> digest = blobs.UploadBytes(manifest);
  ASSERT_TRUE(digest.ok()) << digest.status();
  v1::ClipSource clip;
  *clip.mutable_uploaded()->mutable_manifest() = *digest;
  grpc::Status created;
  std::thread create([&] {
    Operation op;
    created = CreateScene(server, clip, &op);
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  // Stopped within the documented 5 s, cleanly, whatever the call was doing.
  EXPECT_EQ(server.Kill(SIGTERM, testing::Scaled(std::chrono::seconds(5))), 0) << server.Log();
  create.join();
  if (created.ok() || created.error_code() == grpc::StatusCode::INVALID_ARGUMENT) {
    EXPECT_EQ(created.error_message(),
              "clip: 300000 images exceed the limit of 1000 per clip (--max-images-per-clip)");
  }
}

// Talks to WorkerService as a worker would, to send what a real one never does.
class FakeWorker {
 public:
  explicit FakeWorker(const std::string& address)
      : stub_(v1::WorkerService::NewStub(MakeChannel(address))) {}

  // The next task for `worker_id` (empty when none came within 5 s).
  v1::Task Lease(const std::string& worker_id) {
    v1::LeaseTaskRequest request;
    request.set_worker_id(worker_id);
    request.mutable_wait()->set_seconds(5);
    grpc::ClientContext context;
    v1::LeaseTaskResponse response;
    const grpc::Status status = stub_->LeaseTask(&context, request, &response);
    EXPECT_TRUE(status.ok()) << status.error_message();
    return response.task();
  }

  grpc::Status Heartbeat(const std::string& worker_id, const v1::Task& task) {
    v1::HeartbeatRequest request;
    request.set_worker_id(worker_id);
    request.set_task_id(task.task_id());
    request.set_attempt(task.attempt());
    grpc::ClientContext context;
    v1::HeartbeatResponse response;
    return stub_->Heartbeat(&context, request, &response);
  }

  grpc::Status Complete(const std::string& worker_id, const v1::Task& task,
                        v1::CompleteTaskRequest request) {
    request.set_worker_id(worker_id);
    request.set_task_id(task.task_id());
    request.set_attempt(task.attempt());
    grpc::ClientContext context;
    v1::CompleteTaskResponse response;
    return stub_->CompleteTask(&context, request, &response);
  }

 private:
  std::unique_ptr<v1::WorkerService::Stub> stub_;
};

// Runs `sql` on the SQLite store at `path`; false (and a failure) if it fails.
bool RunSql(const std::string& path, const std::string& sql) {
  sqlite3* db = nullptr;
  if (sqlite3_open(path.c_str(), &db) != SQLITE_OK) {
    ADD_FAILURE() << path << ": " << sqlite3_errmsg(db);
    sqlite3_close(db);
    return false;
  }
  char* error = nullptr;
  const bool ok = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &error) == SQLITE_OK;
  if (!ok) ADD_FAILURE() << sql.substr(0, 200) << ": " << (error ? error : "?");
  sqlite3_free(error);
  sqlite3_close(db);
  return ok;
}

TEST_F(LimitsE2e, WorkerResultsAreCheckedAgainstTheTaskAndAPoisonedStoreStaysReadable) {
  ServerProcess server(test_dir_);
  ASSERT_TRUE(server.Start({"--trusted-root", *dir_, "--max-attempts", "10"})) << server.Log();
  FakeWorker worker(server.address());
  BlobClient blobs(MakeChannel(server.address()));

  // The scene, "built" by the fake worker: the server takes any uploaded
  // bytes for a scene file, the workers check them.
  Operation scene_op;
  ASSERT_TRUE(CreateScene(server, Uri(ClipPath()), &scene_op).ok());
  const v1::Task build = worker.Lease("w1");
  ASSERT_TRUE(build.has_reconstruct()) << build.DebugString();
  v1::CompleteTaskRequest built;
  v1::Scene* statistics = built.mutable_reconstruct()->mutable_scene();
  *statistics->mutable_scene_file() = blobs.UploadBytes("a scene file").value();
  statistics->set_gaussians(1);
  statistics->set_static_gaussians(1);
  statistics->set_num_channels(3);
  v1::CompleteTaskRequest negative = built;
  negative.mutable_reconstruct()->mutable_scene()->set_gaussians(-5);
  EXPECT_EQ(worker.Complete("w1", build, negative).error_code(),
            grpc::StatusCode::INVALID_ARGUMENT);
  const v1::Task rebuild = worker.Lease("w1");  // That attempt ended.
  ASSERT_TRUE(rebuild.has_reconstruct());
  ASSERT_TRUE(worker.Complete("w1", rebuild, built).ok());

  // A render job of two chunks of two views each.
  v1::CreateRenderJobRequest request;
  request.set_scene(Metadata(scene_op).target());
  *request.mutable_views() = Views();
  request.set_chunk_frames(2);
  Operation job;
  ASSERT_TRUE(CreateRender(server, request, &job).ok());

  // What an honest worker sends for `task`.
  auto honest = [&](const v1::Task& task) {
    v1::CompleteTaskRequest done;
    nlohmann::json entries = nlohmann::json::array();
    for (int i = 0; i < task.render().view_count(); ++i) {
      const std::string view = testing::ViewName(task.render().first_view() + i);
      for (const char* ext : {".exr", ".png"}) {
        v1::OutputFile* file = done.mutable_render()->add_files();
        file->set_name(view + ext);
        file->set_view(view);
        *file->mutable_digest() = blobs.UploadBytes(view + ext).value();
      }
      entries.push_back({{"name", view}, {"exr", view + ".exr"}, {"png", view + ".png"}});
    }
    done.mutable_render()->set_manifest_views_json(entries.dump());
    return done;
  };

  v1::Task chunk = worker.Lease("w1");
  ASSERT_TRUE(chunk.has_render()) << chunk.DebugString();
  // Under another worker's id: no heartbeat, no completion.
  grpc::Status status = worker.Heartbeat("w2", chunk);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_TRUE(Contains(status.error_message(), "is not leased to worker 'w2'"))
      << status.error_message();
  EXPECT_EQ(worker.Complete("w2", chunk, honest(chunk)).error_code(),
            grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_TRUE(worker.Heartbeat("w1", chunk).ok());

  // Results that do not fit their chunk: refused naming the field, and the
  // attempt ends (the chunk is leased again).
  struct Lie {
    std::string what;
    std::function<void(v1::RenderResult*)> edit;
    std::string error;
  };
  const std::vector<Lie> lies = {
      {"a file outside the views",
       [](v1::RenderResult* r) { r->mutable_files(0)->set_name("../../etc/passwd"); },
       "render.files[0].name: '../../etc/passwd' is not an output of the chunk's frames"},
      {"a view without its PNG",
       [](v1::RenderResult* r) { r->mutable_files()->DeleteSubrange(1, 1); }, ".png' for 'v"},
      {"a file never uploaded",
       [](v1::RenderResult* r) {
         r->mutable_files(2)->mutable_digest()->set_sha256(std::string(64, '0'));
       },
       "render.files[2].digest: blob '0000"},
      {"a wrong size",
       [](v1::RenderResult* r) { r->mutable_files(3)->mutable_digest()->set_size_bytes(1); },
       "render.files[3].digest.size_bytes: 1, but the blob has"},
      {"manifest views nested 100000 deep",
       [](v1::RenderResult* r) {
         r->set_manifest_views_json(std::string(100000, '[') + std::string(100000, ']'));
       },
       "render.manifest_views_json: JSON of 200000 bytes exceeds the limit"},
      {"manifest views nested 30000 deep",
       [](v1::RenderResult* r) {
         r->set_manifest_views_json(std::string(30000, '[') + std::string(30000, ']'));
       },
       "render.manifest_views_json: JSON nested deeper than 64 levels"},
  };
  for (const Lie& lie : lies) {
    v1::CompleteTaskRequest result = honest(chunk);
    lie.edit(result.mutable_render());
    status = worker.Complete("w1", chunk, result);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << lie.what;
    EXPECT_TRUE(Contains(status.error_message(), lie.error))
        << lie.what << ": " << status.error_message();
    chunk = worker.Lease("w1");  // This or the other chunk: the attempt ended.
    ASSERT_TRUE(chunk.has_render()) << lie.what << "\n" << server.Log();
  }
  // Honest results finish the job.
  ASSERT_TRUE(worker.Complete("w1", chunk, honest(chunk)).ok());
  chunk = worker.Lease("w1");
  ASSERT_TRUE(chunk.has_render());
  ASSERT_TRUE(worker.Complete("w1", chunk, honest(chunk)).ok());
  Operation done = WaitDone(server.address(), job.name(), 10);
  ASSERT_TRUE(done.done() && !done.has_error()) << done.DebugString();
  v1::RenderJob rendered;
  ASSERT_TRUE(done.response().UnpackTo(&rendered));
  EXPECT_EQ(rendered.files_size(), 9);  // 4 views x (EXR, PNG) + manifest.json.
  int refused = 0;
  const v1::OperationMetadata metadata = Metadata(done);
  for (const v1::Attempt& attempt : metadata.attempts()) {
    refused += Contains(attempt.outcome(), "result refused: ") ? 1 : 0;
  }
  EXPECT_EQ(refused, static_cast<int>(lies.size()));

  // A row poisoned before these checks existed (a chunk's result nested
  // 100,000 deep, a scene description 100,000 deep): every read of them
  // answers, the job and scene show as failed with DATA_LOSS.
  ASSERT_EQ(server.Kill(SIGTERM), 0);
  const std::string job_id = job.name().substr(std::string("operations/").size());
  const std::string scene_id = request.scene().substr(std::string("scenes/").size());
  ASSERT_TRUE(RunSql(test_dir_ + "/jobs.db",
                     "UPDATE tasks SET result = '{\"manifestViewsJson\": \"" +
                         std::string(100000, '[') + std::string(100000, ']') +
                         "\"}' WHERE job_id = '" + job_id + "' AND task_index = 0;" +
                         "UPDATE scenes SET description = '" + DeeplyNested(100000) +
                         "' WHERE id = '" + scene_id + "';"));
  ASSERT_TRUE(server.Restart()) << server.Log();
  absl::StatusOr<Operation> poisoned = GetOperation(server.address(), job.name());
  ASSERT_TRUE(poisoned.ok()) << poisoned.status() << server.Log();
  EXPECT_TRUE(poisoned->done());
  EXPECT_EQ(poisoned->error().code(), static_cast<int>(grpc::StatusCode::DATA_LOSS));
  EXPECT_TRUE(Contains(poisoned->error().message(), "manifest views of chunk 0"))
      << poisoned->error().message();
  EXPECT_EQ(testing::ListOperations(server.address(), "", 10).size(), 2u);
  {
    auto ops = google::longrunning::Operations::NewStub(MakeChannel(server.address()));
    grpc::ClientContext context;
    google::longrunning::WaitOperationRequest wait;
    wait.set_name(job.name());
    Operation waited;
    EXPECT_TRUE(ops->WaitOperation(&context, wait, &waited).ok());
    EXPECT_EQ(waited.error().code(), static_cast<int>(grpc::StatusCode::DATA_LOSS));
  }
  const v1::Scene scene = GetScene(server, request.scene());
  EXPECT_EQ(scene.state(), v1::Scene::FAILED);
  EXPECT_EQ(scene.error().code(), static_cast<int>(grpc::StatusCode::DATA_LOSS));
  const CommandResult jobs =
      RunCommand({BinPath("pf"), "--server", server.address(), "jobs", "list"});
  EXPECT_EQ(jobs.exit_code, 0) << jobs.err;
  EXPECT_TRUE(testing::Serving(server.address())) << server.Log();
}

TEST_F(LimitsE2e, RenderViewsOverThePixelOrMemoryLimitAreRefusedBeforeAJobExists) {
  ServerProcess server(test_dir_);
  ASSERT_TRUE(server.Start({"--trusted-root", *dir_, "--max-render-bytes", "100000000"}))
      << server.Log();
  auto render_with_camera = [&](int width, int height) {
    v1::CreateRenderJobRequest request;
    request.mutable_create_scene()->mutable_clip()->set_uri("file://" + ClipPath());
    *request.mutable_views() = Views();
    request.mutable_views()->mutable_cameras(0)->set_width(width);
    request.mutable_views()->mutable_cameras(0)->set_height(height);
    Operation op;
    return CreateRender(server, request, &op);
  };
  // 1e9 x 1e9 aborted a worker per attempt; 12000 x 12000 grew one past 6 GB.
  grpc::Status status = render_with_camera(1000000000, 1000000000);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message(),
            "views.cameras[0]: 1000000000x1000000000 = 1000000000000000000 pixels per view "
            "exceed the limit of 50000000 (--max-pixels-per-image)");
  status = render_with_camera(12000, 12000);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_TRUE(Contains(status.error_message(), "(--max-pixels-per-image)"))
      << status.error_message();
  // Under the pixel limit, over the memory one (4000 x 4000 at 44 bytes a
  // pixel with the smallest scene).
  status = render_with_camera(4000, 4000);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_TRUE(Contains(status.error_message(), "views.cameras[0]: rendering a 4000x4000 view"))
      << status.error_message();
  EXPECT_TRUE(Contains(status.error_message(), "(--max-render-bytes)")) << status.error_message();
  // Nothing was created: not even the scene the request would have built.
  EXPECT_TRUE(testing::ListOperations(server.address(), "", 10).empty());
}

TEST_F(LimitsE2e, BadPathsAndSizesInAClipAreInvalidArgumentsWithoutServerPaths) {
  ServerProcess server(test_dir_);
  ASSERT_TRUE(server.Start()) << server.Log();
  BlobClient blobs(MakeChannel(server.address()));
  const std::string image = (*manifest_)["frames"][0]["image"];
  for (const std::string& path : {std::string("."), std::string("images/")}) {
    const grpc::Status status = CreateSceneWithImageAt(server, blobs, path);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << path;
    EXPECT_EQ(status.error_message(),
              "clip.uploaded.files[\"" + path +
                  "\"]: names the clip directory or its manifest, not a file in it");
    EXPECT_FALSE(Contains(status.error_message(), test_dir_)) << status.error_message();
  }
  // A size_bytes that is not the blob's.
  v1::ClipSource clip;
  *clip.mutable_uploaded() = Upload(blobs, *manifest_);
  v1::Digest& first = clip.mutable_uploaded()->mutable_files()->at(image);
  first.set_size_bytes(first.size_bytes() + 1);
  Operation op;
  grpc::Status status = CreateScene(server, clip, &op);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_TRUE(Contains(
      status.error_message(),
      "clip.uploaded.files[\"" + image + "\"].size_bytes: " + std::to_string(first.size_bytes())))
      << status.error_message();
  // A file the validator refuses (not an image): named by its path in the
  // clip, not by where the server staged it.
  nlohmann::json manifest = *manifest_;
  v1::ClipSource broken;
  *broken.mutable_uploaded() = Upload(blobs, manifest, {{image, ClipPath()}});
  status = CreateScene(server, broken, &op);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_TRUE(Contains(status.error_message(), "frames[0].image")) << status.error_message();
  EXPECT_FALSE(Contains(status.error_message(), test_dir_)) << status.error_message();
}

TEST_F(LimitsE2e, FileUrisAnswerAlikeForAbsentAndOutsideAndHideLinkTargets) {
  const std::string root = test_dir_ + "/root";
  const std::string outside = test_dir_ + "/outside";
  fs::create_directories(root);
  fs::create_directories(outside);
  fs::copy(*dir_ + "/clip", outside + "/clip", fs::copy_options::recursive);
  fs::create_directory_symlink(outside + "/clip", root + "/link");
  ServerProcess server(test_dir_);
  ASSERT_TRUE(server.Start({"--trusted-root", root})) << server.Log();
  auto answer = [&](const std::string& path) {
    Operation op;
    const grpc::Status status = CreateScene(server, Uri(path), &op);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << path;
    return status.error_message();
  };
  // Absent, outside, through a link out, a directory: one answer each,
  // the same words, naming only the path given.
  const std::vector<std::string> paths = {root + "/absent.json", outside + "/clip/clip.json",
                                          "/etc/hostname", root + "/link/clip.json", root};
  for (const std::string& path : paths) {
    EXPECT_EQ(answer(path),
              "clip.uri: " + path + " is not under a trusted root or is not a file there");
  }
}

TEST_F(LimitsE2e, StagingDirectoriesOfAServerThatEndedAreRemovedAtStart) {
  const std::string scratch = test_dir_ + "/blobs/scratch";
  fs::create_directories(scratch);
  // This machine's name as a server writes it in a staging directory.
  char host[256] = {};
  ::gethostname(host, sizeof(host) - 1);
  std::string name;
  for (const char* c = host; *c != '\0' && name.size() < 32; ++c) {
    name += std::isalnum(static_cast<unsigned char>(*c)) ? *c : '_';
  }
  // A process that ended (no pid is that large), another machine's fresh
  // one, and another machine's from two hours ago.
  const std::string ended = scratch + "/clip-" + name + "-2147483647-0000abcd-3";
  const std::string elsewhere = scratch + "/clip-otherhost-12-0000abcd-0";
  const std::string old = scratch + "/clip-otherhost-13-0000abcd-0";
  for (const std::string& dir : {ended, elsewhere, old}) {
    fs::create_directories(dir + "/images");
    std::ofstream(dir + "/clip.json") << "{}";
  }
  fs::last_write_time(old, fs::file_time_type::clock::now() - std::chrono::hours(2));
  ServerProcess server(test_dir_);
  ASSERT_TRUE(server.Start()) << server.Log();
  EXPECT_FALSE(fs::exists(ended));
  EXPECT_FALSE(fs::exists(old));
  EXPECT_TRUE(fs::exists(elsewhere));
  EXPECT_TRUE(Contains(server.Log(), "removed 2 staging directories")) << server.Log();
}

}  // namespace
}  // namespace pf
