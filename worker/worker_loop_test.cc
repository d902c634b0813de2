// Tests of pf-worker's loop against a stand-in for pf-server's
// WorkerService (a small in-process service that hands out tasks and
// records the calls; the real server is tested on its own) and the real
// BlobService over loopback gRPC.
#include "worker/worker_loop.h"

#include <google/protobuf/util/json_util.h>
#include <grpcpp/grpcpp.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <functional>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "common/file_util.h"
#include "engine/clip/clip_io.h"
#include "engine/render/scene_file.h"
#include "engine/render/scene_source.h"
#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "pointforward/v1/worker.grpc.pb.h"
#include "server/blobs/blob_service.h"
#include "server/blobs/blob_store.h"
#include "tests/test_util.h"
#include "worker/task_runner.h"

namespace pf {
namespace {

namespace fs = std::filesystem;
namespace pb = ::pointforward::v1;
using std::chrono::milliseconds;

// Hands out queued tasks and records every call; answers heartbeats of
// tasks marked cancelled or lost accordingly.
class FakeWorkerService final : public pb::WorkerService::Service {
 public:
  void Add(const pb::Task& task) {
    std::lock_guard<std::mutex> lock(mu_);
    queue_.push_back(task);
  }
  void Cancel(const std::string& task_id) {
    std::lock_guard<std::mutex> lock(mu_);
    cancelled_.insert(task_id);
  }
  void LoseLease(const std::string& task_id) {
    std::lock_guard<std::mutex> lock(mu_);
    lost_.insert(task_id);
  }

  // Waits until `done()` (called under the lock) or Scaled(20 s); returns
  // done().
  bool WaitFor(const std::function<bool()>& done) {
    std::unique_lock<std::mutex> lock(mu_);
    return cv_.wait_for(lock, testing::Scaled(std::chrono::seconds(20)), done);
  }

  grpc::Status LeaseTask(grpc::ServerContext*, const pb::LeaseTaskRequest* request,
                         pb::LeaseTaskResponse* response) override {
    std::unique_lock<std::mutex> lock(mu_);
    leases.push_back(*request);
    cv_.notify_all();
    if (queue_.empty()) {
      lock.unlock();
      std::this_thread::sleep_for(milliseconds(20));
      return grpc::Status::OK;
    }
    *response->mutable_task() = queue_.front();
    queue_.pop_front();
    return grpc::Status::OK;
  }

  grpc::Status Heartbeat(grpc::ServerContext*, const pb::HeartbeatRequest* request,
                         pb::HeartbeatResponse* response) override {
    std::lock_guard<std::mutex> lock(mu_);
    heartbeats.push_back(*request);
    cv_.notify_all();
    if (lost_.count(request->task_id()) > 0) {
      return grpc::Status(grpc::StatusCode::FAILED_PRECONDITION, "lease expired");
    }
    response->set_cancelled(cancelled_.count(request->task_id()) > 0);
    return grpc::Status::OK;
  }

  grpc::Status CompleteTask(grpc::ServerContext*, const pb::CompleteTaskRequest* request,
                            pb::CompleteTaskResponse*) override {
    std::lock_guard<std::mutex> lock(mu_);
    completed.push_back(*request);
    cv_.notify_all();
    return grpc::Status::OK;
  }

  grpc::Status FailTask(grpc::ServerContext*, const pb::FailTaskRequest* request,
                        pb::FailTaskResponse*) override {
    std::lock_guard<std::mutex> lock(mu_);
    failed.push_back(*request);
    cv_.notify_all();
    return grpc::Status::OK;
  }

  // Read under WaitFor's lock or once the worker stopped.
  std::vector<pb::LeaseTaskRequest> leases;
  std::vector<pb::HeartbeatRequest> heartbeats;
  std::vector<pb::CompleteTaskRequest> completed;
  std::vector<pb::FailTaskRequest> failed;

 private:
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<pb::Task> queue_;
  std::set<std::string> cancelled_, lost_;
};

// Two Gaussians in front of a 64 x 48 pinhole at the origin.
GaussianScene TwoGaussians() {
  GaussianScene scene;
  scene.Resize(2);
  const float z[2] = {10.f, 5.f};
  for (int i = 0; i < 2; ++i) {
    scene.means[3 * i + 2] = z[i];
    for (int a = 0; a < 3; ++a) scene.log_scales[3 * i + a] = std::log(0.5f);
    scene.opacity_logits[i] = 4.f;
    scene.features[3 * i + i] = 0.8f;
  }
  return scene;
}

constexpr char kViewsJson[] = R"({
  "cameras": [{"id": "cam", "width": 64, "height": 48,
               "intrinsics": {"fx": 50, "fy": 50, "cx": 32.5, "cy": 24.5}}],
  "views": [
    {"camera": "cam", "timestampUs": 0, "worldFromCamera": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1], "name": "a"},
    {"camera": "cam", "timestampUs": 0, "worldFromCamera": [1,0,0,0.5, 0,1,0,0, 0,0,1,0, 0,0,0,1], "name": "b"},
    {"camera": "cam", "timestampUs": 0, "worldFromCamera": [1,0,0,1, 0,1,0,0, 0,0,1,0, 0,0,0,1], "name": "c"}
  ]})";

class WorkerLoop : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::MakeTempDir("worker_loop");
    store_ = std::make_unique<BlobStore>(dir_ + "/blobs");
    blob_service_ = std::make_unique<BlobServiceImpl>(store_.get(), 0);
    StartServer(0);
    ASSERT_TRUE(SaveScene(TwoGaussians(), dir_ + "/scene.pfs").ok());
    absl::StatusOr<BlobDigest> digest = store_->PutFile(dir_ + "/scene.pfs");
    ASSERT_TRUE(digest.ok()) << digest.status();
    scene_sha_ = digest->sha256;
    ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(kViewsJson, &views_).ok());
    options_.work_dir = dir_ + "/work";
    options_.worker_id = "test-worker";
    options_.heartbeat_ms = 50;
    options_.lease_wait_ms = 100;
  }

  void TearDown() override {
    StopWorker();
    if (server_) server_->Shutdown();
  }

  void StartServer(int port) {
    grpc::ServerBuilder builder;
    builder.AddListeningPort(absl::StrCat("127.0.0.1:", port), grpc::InsecureServerCredentials(),
                             &port_);
    builder.RegisterService(&service_);
    builder.RegisterService(blob_service_.get());
    server_ = builder.BuildAndStart();
    ASSERT_NE(server_, nullptr);
  }

  void StartWorker() {
    options_.server = absl::StrCat("127.0.0.1:", port_);
    worker_ = std::thread([this] { exit_code_ = RunWorker(options_, &stop_); });
  }

  void StopWorker() {
    stop_ = true;
    if (worker_.joinable()) worker_.join();
  }

  pb::Task RenderTask(const std::string& id, int first, int count) const {
    pb::Task task;
    task.set_task_id(id);
    task.set_attempt(1);
    task.set_operation("operations/job1");
    pb::RenderWork* work = task.mutable_render();
    work->set_scene("scenes/s1");
    work->mutable_scene_file()->set_sha256(scene_sha_);
    *work->mutable_views() = views_;
    work->set_first_view(first);
    work->set_view_count(count);
    return task;
  }

  std::vector<std::string> WorkDirEntries() const {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(options_.work_dir))
      names.push_back(entry.path().filename());
    return names;
  }

  std::string dir_;
  std::unique_ptr<BlobStore> store_;
  std::unique_ptr<BlobServiceImpl> blob_service_;
  FakeWorkerService service_;
  std::unique_ptr<grpc::Server> server_;
  int port_ = 0;
  std::string scene_sha_;
  pb::RenderViews views_;
  WorkerOptions options_;
  std::atomic<bool> stop_{false};
  std::thread worker_;
  int exit_code_ = -1;
};

TEST_F(WorkerLoop, RendersChunksUploadsTheFilesAndCachesTheScene) {
  // A leftover of an earlier run goes at start.
  ASSERT_TRUE(WriteFileAtomic(options_.work_dir + "/old-1/x.exr", "stale").ok());
  service_.Add(RenderTask("t1", 0, 2));
  StartWorker();
  ASSERT_TRUE(service_.WaitFor([&] { return service_.completed.size() == 1; }));
  EXPECT_FALSE(fs::exists(options_.work_dir + "/old-1"));

  const pb::CompleteTaskRequest done = service_.completed[0];
  EXPECT_EQ(done.worker_id(), "test-worker");
  EXPECT_EQ(done.task_id(), "t1");
  EXPECT_EQ(done.attempt(), 1);
  ASSERT_TRUE(done.has_render());
  ASSERT_EQ(done.render().files_size(), 4);
  // The uploaded files are what RenderChunk writes for those views.
  absl::StatusOr<OpenedScene> scene = OpenScene(dir_ + "/scene.pfs");
  ASSERT_TRUE(scene.ok());
  absl::StatusOr<RenderChunkOutput> local =
      RenderChunk(RenderTask("t1", 0, 2).render(), *scene, dir_ + "/local", nullptr, nullptr);
  ASSERT_TRUE(local.ok()) << local.status();
  for (int i = 0; i < 4; ++i) {
    const pb::OutputFile& file = done.render().files(i);
    EXPECT_EQ(file.name(), local->files[i].name);
    EXPECT_EQ(file.view(), local->files[i].view);
    absl::StatusOr<std::string> stored = store_->Get(file.digest().sha256());
    ASSERT_TRUE(stored.ok()) << file.name();
    // The same bytes but the time of writing (to the second).
    EXPECT_TRUE(testing::WithoutDateTime(*stored) ==
                testing::WithoutDateTime(*ReadFileToString(local->files[i].path)))
        << file.name();
  }
  EXPECT_EQ(nlohmann::json::parse(done.render().manifest_views_json()).size(), 2u);

  // The next lease offers the cached scene; a chunk of it needs no download.
  service_.Add(RenderTask("t2", 2, 1));
  ASSERT_TRUE(service_.WaitFor([&] { return service_.completed.size() == 2; }));
  ASSERT_TRUE(service_.WaitFor([&] {
    return service_.leases.back().cached_scenes_size() == 1 &&
           service_.leases.back().cached_scenes(0) == "scenes/s1";
  }));
  EXPECT_EQ(service_.completed[1].render().files(0).name(), "c.exr");
  EXPECT_EQ(service_.leases.front().cached_scenes_size(), 0);
  EXPECT_EQ(service_.leases.front().device(), "cpu");
  StopWorker();
  EXPECT_EQ(exit_code_, 0);
  EXPECT_TRUE(WorkDirEntries().empty());
  EXPECT_TRUE(service_.failed.empty());
}

TEST_F(WorkerLoop, BadInputFailsTheTaskWithItsCode) {
  pb::Task task = RenderTask("bad", 0, 1);
  task.mutable_render()->mutable_views()->mutable_views(0)->set_camera("rear");
  service_.Add(task);
  pb::Task missing = RenderTask("missing", 0, 1);
  missing.mutable_render()->set_scene("scenes/other");
  missing.mutable_render()->mutable_scene_file()->set_sha256(std::string(64, 'a'));
  service_.Add(missing);
  StartWorker();
  ASSERT_TRUE(service_.WaitFor([&] { return service_.failed.size() == 2; }));
  EXPECT_EQ(service_.failed[0].task_id(), "bad");
  EXPECT_EQ(service_.failed[0].error().code(), int(absl::StatusCode::kInvalidArgument));
  EXPECT_NE(service_.failed[0].error().message().find("views[0].camera: unknown camera 'rear'"),
            std::string::npos)
      << service_.failed[0].error().message();
  EXPECT_EQ(service_.failed[1].task_id(), "missing");
  EXPECT_EQ(service_.failed[1].error().code(), int(absl::StatusCode::kNotFound))
      << service_.failed[1].error().message();
  EXPECT_TRUE(service_.completed.empty());
}

TEST_F(WorkerLoop, CancelledTaskIsDroppedAndReportsNothing) {
  options_.stage_delay_ms = 300;  // Each view takes at least 0.3 s.
  service_.Add(RenderTask("slow", 0, 3));
  service_.Cancel("slow");
  StartWorker();
  // The first heartbeat says cancelled; the worker stops before the next view.
  ASSERT_TRUE(service_.WaitFor([&] { return !service_.heartbeats.empty(); }));
  const size_t leases = [&] {
    size_t n = 0;
    service_.WaitFor([&] { return (n = service_.leases.size()) >= 2; });
    return n;
  }();
  EXPECT_GE(leases, 2u) << "the worker did not come back for more work";
  StopWorker();
  EXPECT_TRUE(service_.completed.empty());
  EXPECT_TRUE(service_.failed.empty());
  EXPECT_EQ(service_.heartbeats.size(), 1u) << "heartbeats after cancellation";
  EXPECT_TRUE(WorkDirEntries().empty());
}

TEST_F(WorkerLoop, LostLeaseDropsTheWork) {
  options_.stage_delay_ms = 300;
  service_.Add(RenderTask("lost", 0, 3));
  service_.LoseLease("lost");
  StartWorker();
  ASSERT_TRUE(service_.WaitFor([&] { return service_.leases.size() >= 2; }));
  StopWorker();
  EXPECT_EQ(service_.heartbeats.size(), 1u);
  EXPECT_TRUE(service_.completed.empty());
  EXPECT_TRUE(service_.failed.empty());
  EXPECT_TRUE(WorkDirEntries().empty());
}

TEST_F(WorkerLoop, SurvivesAServerRestart) {
  StartWorker();
  ASSERT_TRUE(service_.WaitFor([&] { return !service_.leases.empty(); }));
  server_->Shutdown();
  server_.reset();
  std::this_thread::sleep_for(milliseconds(2500));  // The worker sees UNAVAILABLE.
  const int port = port_;
  StartServer(port);
  ASSERT_EQ(port_, port);
  service_.Add(RenderTask("after", 1, 1));
  ASSERT_TRUE(service_.WaitFor([&] { return service_.completed.size() == 1; }));
  EXPECT_EQ(service_.completed[0].task_id(), "after");
}

TEST_F(WorkerLoop, StopLetsTheRunningTaskFinish) {
  options_.stage_delay_ms = 200;
  service_.Add(RenderTask("last", 0, 3));
  StartWorker();
  ASSERT_TRUE(service_.WaitFor([&] { return !service_.heartbeats.empty(); }));
  const auto start = std::chrono::steady_clock::now();
  StopWorker();
  EXPECT_EQ(exit_code_, 0);
  ASSERT_EQ(service_.completed.size(), 1u);
  EXPECT_EQ(service_.completed[0].render().files_size(), 6);
  EXPECT_LT(std::chrono::steady_clock::now() - start, testing::Scaled(std::chrono::seconds(10)));
}

TEST_F(WorkerLoop, ReconstructsAnUploadedClipAndKeepsTheScene) {
  // A small synth clip in the blob store, as a client would upload it.
  const std::string clip_dir = dir_ + "/clip";
  const testing::CommandResult synth =
      testing::RunCommand({testing::BinPath("pf"), "synth", "--out", clip_dir, "--width", "96",
                           "--height", "72", "--frames", "4"});
  ASSERT_EQ(synth.exit_code, 0) << synth.err;
  absl::StatusOr<LoadedClip> clip = LoadClip(clip_dir + "/clip.json");
  ASSERT_TRUE(clip.ok()) << clip.status();
  pb::Task task;
  task.set_task_id("recon");
  task.set_attempt(2);
  task.set_operation("operations/scene1");
  pb::ReconstructWork* work = task.mutable_reconstruct();
  work->set_scene("scenes/built");
  work->mutable_options()->set_ns(800);
  work->mutable_options()->set_nd(100);
  absl::StatusOr<BlobDigest> manifest = store_->PutFile(clip_dir + "/clip.json");
  ASSERT_TRUE(manifest.ok());
  work->mutable_clip()->mutable_manifest()->set_sha256(manifest->sha256);
  for (const ClipFileRef& ref : ReferencedFiles(clip->clip)) {
    absl::StatusOr<BlobDigest> digest = store_->PutFile(clip_dir + "/" + ref.path);
    ASSERT_TRUE(digest.ok());
    (*work->mutable_clip()->mutable_files())[ref.path].set_sha256(digest->sha256);
  }
  service_.Add(task);
  StartWorker();
  ASSERT_TRUE(service_.WaitFor([&] { return service_.completed.size() == 1; }));
  ASSERT_TRUE(service_.WaitFor([&] {
    return service_.leases.back().cached_scenes_size() == 1 &&
           service_.leases.back().cached_scenes(0) == "scenes/built";
  }));
  StopWorker();
  EXPECT_TRUE(service_.failed.empty());

  const pb::CompleteTaskRequest& done = service_.completed[0];
  EXPECT_EQ(done.attempt(), 2);
  ASSERT_TRUE(done.has_reconstruct());
  const pb::Scene& scene = done.reconstruct().scene();
  EXPECT_EQ(scene.model(), "analytic");
  EXPECT_GT(scene.gaussians(), 0);
  EXPECT_EQ(scene.gaussians(), scene.static_gaussians() + scene.dynamic_gaussians());
  // The uploaded scene file is the one the statistics describe.
  absl::StatusOr<std::string> stored = store_->PathOf(scene.scene_file().sha256());
  ASSERT_TRUE(stored.ok()) << stored.status();
  absl::StatusOr<GaussianScene> loaded = LoadScene(*stored);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  EXPECT_EQ(static_cast<int64_t>(loaded->size()), scene.gaussians());
  EXPECT_EQ(scene.scene_file().size_bytes(), static_cast<int64_t>(fs::file_size(*stored)));
  // Progress went out with the heartbeats' stages; the attempt dir is gone.
  EXPECT_TRUE(WorkDirEntries().empty());
}

TEST(WorkerMain, BadFlagsExitWithTwo) {
  const std::string bin = testing::BinPath("pf-worker");
  testing::CommandResult result = testing::RunCommand({bin, "--help"});
  EXPECT_EQ(result.exit_code, 0);
  EXPECT_NE(result.out.find("--cache-bytes N"), std::string::npos) << result.out;
  result = testing::RunCommand({"/usr/bin/env", "-u", "PF_SERVER", bin});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("--server: required"), std::string::npos) << result.err;
  result = testing::RunCommand({bin, "--server", "localhost:1", "--cache-bytes", "lots"});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("--cache-bytes"), std::string::npos) << result.err;
  result = testing::RunCommand({bin, "--server", "localhost:1", "--heartbeat-ms", "0"});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("--heartbeat-ms: must be in [10, 600000], got 0"), std::string::npos)
      << result.err;
  result = testing::RunCommand({bin, "--server", "localhost:1", "--device", "cuda:0"});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("--device: 'cuda:0' is not available"), std::string::npos)
      << result.err;
  result = testing::RunCommand({bin, "--server", "localhost:1", "--bogus"});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("bogus"), std::string::npos) << result.err;
}

}  // namespace
}  // namespace pf
