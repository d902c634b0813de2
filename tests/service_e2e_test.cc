// End-to-end tests of the service: pf-server (SQLite store) and pf-worker
// processes on loopback, driven by the remote `pf` command line and by gRPC
// stubs, checked against what embedded mode (`pf reconstruct`, `pf render`)
// produces for the same input. Nothing is mocked: real processes, real gRPC,
// a real SQLite file, EXRs read back with OpenImageIO.
#include <google/protobuf/util/json_util.h>
#include <google/protobuf/util/time_util.h>
#include <grpcpp/grpcpp.h>
#include <signal.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "common/file_util.h"
#include "google/longrunning/operations.grpc.pb.h"
#include "gtest/gtest.h"
#include "pointforward/v1/blobs.grpc.pb.h"
#include "pointforward/v1/resources.pb.h"
#include "pointforward/v1/service.grpc.pb.h"
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
using testing::CountOf;
using testing::Find;
using testing::GetOperation;
using testing::ListOperations;
using testing::Metadata;
using testing::ReadExr;
using testing::RgbPsnr;
using testing::RunCommand;
using testing::ServerProcess;
using testing::SynthSmallClip;
using testing::ViewsOfFirstCamera;
using testing::WaitDone;
using testing::WaitFor;
using testing::WorkerProcess;

std::string Pf() { return BinPath("pf"); }

// A small synth clip, its views file, and the embedded-mode reference
// renders, made once for all tests.
class ServiceE2e : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new std::string(testing::MakeTempDir("service_e2e"));
    const CommandResult synth = SynthSmallClip(*dir_ + "/clip");
    ASSERT_EQ(synth.exit_code, 0) << synth.err;
    // Views moved 0.1 m sideways from each other.
    std::ifstream in(Clip());
    const nlohmann::json clip = nlohmann::json::parse(in);
    std::ofstream(*dir_ + "/views20.json") << ViewsOfFirstCamera(clip, 20, 0.1).dump(2);
    std::ofstream(*dir_ + "/views4.json") << ViewsOfFirstCamera(clip, 4, 0.1).dump(2);
    const CommandResult recon =
        RunCommand({Pf(), "reconstruct", Clip(), "--out", *dir_ + "/embedded.pfs"});
    ASSERT_EQ(recon.exit_code, 0) << recon.err;
    const CommandResult render =
        RunCommand({Pf(), "render", *dir_ + "/embedded.pfs", "--cameras", *dir_ + "/views20.json",
                    "--out", *dir_ + "/embedded"});
    ASSERT_EQ(render.exit_code, 0) << render.err;
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }

  static std::string Clip() { return *dir_ + "/clip/clip.json"; }
  static std::string* dir_;

  // Per test: a fresh server directory.
  void SetUp() override { test_dir_ = testing::MakeTempDir("service_case"); }

  CommandResult Remote(ServerProcess& server, std::vector<std::string> args) {
    args.insert(args.begin(), {Pf(), "--server", server.address()});
    return RunCommand(args);
  }

  std::string test_dir_;
};

std::string* ServiceE2e::dir_ = nullptr;

TEST_F(ServiceE2e, TwoWorkersRenderTwentyViewsThatMatchEmbeddedModeAndTheCacheHits) {
  ServerProcess server(test_dir_);
  ASSERT_TRUE(server.Start({"--chunk-frames", "2"})) << server.Log();
  WorkerProcess w1(server.address(), test_dir_, "w1");
  WorkerProcess w2(server.address(), test_dir_, "w2");
  ASSERT_TRUE(w1.Start());
  ASSERT_TRUE(w2.Start());

  const CommandResult create = Remote(server, {"scene", "create", Clip(), "--wait"});
  ASSERT_EQ(create.exit_code, 0) << create.out << create.err;
  const std::string scene = Find(create.out, "scenes/[0-9a-f]+");
  ASSERT_FALSE(scene.empty()) << create.out;

  const std::string out = test_dir_ + "/remote";
  const CommandResult render = Remote(
      server, {"render", scene, "--cameras", *dir_ + "/views20.json", "--out", out, "--wait"});
  ASSERT_EQ(render.exit_code, 0) << render.out << render.err;

  // Every view downloaded, matching embedded mode.
  for (int i = 0; i < 20; ++i) {
    char name[16];
    std::snprintf(name, sizeof(name), "v%02d", i);
    const std::string remote_exr = out + "/" + name + ".exr";
    ASSERT_TRUE(fs::exists(remote_exr)) << remote_exr;
    ASSERT_TRUE(fs::exists(out + "/" + name + ".png"));
    EXPECT_GE(RgbPsnr(remote_exr, *dir_ + "/embedded/" + name + ".exr"), 60.0) << name;
  }
  std::ifstream manifest_in(out + "/manifest.json");
  const nlohmann::json manifest = nlohmann::json::parse(manifest_in);
  ASSERT_EQ(manifest["views"].size(), 20u);
  EXPECT_EQ(manifest["views"][7]["name"], "v07");

  // Ten chunks of two views, spread over both workers.
  const std::vector<Operation> renders = ListOperations(server.address(), "kind=render", 1000);
  ASSERT_EQ(renders.size(), 1u);
  const v1::OperationMetadata metadata = Metadata(renders[0]);
  EXPECT_EQ(metadata.frames_done(), 20);
  std::map<std::string, int> chunks_by_worker;
  for (const v1::Attempt& attempt : metadata.attempts()) {
    if (attempt.outcome() == "succeeded") ++chunks_by_worker[attempt.worker()];
  }
  EXPECT_EQ(chunks_by_worker["w1"] + chunks_by_worker["w2"], 10);
  EXPECT_GE(chunks_by_worker["w1"], 1);
  EXPECT_GE(chunks_by_worker["w2"], 1);

  // The same clip again: a cache hit, no second reconstruction.
  const CommandResult again = Remote(server, {"scene", "create", Clip()});
  ASSERT_EQ(again.exit_code, 0) << again.err;
  EXPECT_NE(again.out.find("cache hit"), std::string::npos) << again.out;
  EXPECT_NE(again.out.find(scene), std::string::npos) << again.out;
  EXPECT_EQ(ListOperations(server.address(), "kind=reconstruct", 1000).size(), 1u);
  EXPECT_EQ(CountOf(w1.Log() + w2.Log(), "reconstructed " + scene), 1) << w1.Log() << w2.Log();

  // Clean stops on SIGTERM.
  EXPECT_EQ(w1.Kill(SIGTERM), 0) << w1.Log();
  EXPECT_EQ(w2.Kill(SIGTERM), 0) << w2.Log();
  EXPECT_EQ(server.Kill(SIGTERM), 0) << server.Log();
}

TEST_F(ServiceE2e, WorkerKilledDuringReconstructionTheOtherFinishesIt) {
  ServerProcess server(test_dir_);
  ASSERT_TRUE(server.Start({"--lease-seconds", "2"})) << server.Log();
  // A slow worker (each reconstruction stage takes 1.5 s longer) takes the job.
  WorkerProcess slow(server.address(), test_dir_, "slow");
  ASSERT_TRUE(slow.Start({"--stage-delay-ms", "1500"}));
  const CommandResult create = Remote(server, {"scene", "create", Clip()});
  ASSERT_EQ(create.exit_code, 0) << create.err;
  const std::string op_name = Find(create.out, "operations/[0-9a-f]+");
  ASSERT_FALSE(op_name.empty()) << create.out;
  ASSERT_TRUE(WaitFor(
      [&] {
        absl::StatusOr<Operation> op = GetOperation(server.address(), op_name);
        return op.ok() && !Metadata(*op).stage().empty();
      },
      std::chrono::seconds(30)))
      << server.Log();
  EXPECT_EQ(slow.Kill(SIGKILL), 128 + SIGKILL);

  WorkerProcess fast(server.address(), test_dir_, "fast");
  ASSERT_TRUE(fast.Start());
  const Operation done = WaitDone(server.address(), op_name);
  ASSERT_TRUE(done.done()) << server.Log();
  ASSERT_FALSE(done.has_error()) << done.error().message();
  const v1::OperationMetadata metadata = Metadata(done);
  ASSERT_EQ(metadata.attempts_size(), 2) << metadata.DebugString();
  EXPECT_EQ(metadata.attempts(0).worker(), "slow");
  EXPECT_NE(metadata.attempts(0).outcome().find("lease expired"), std::string::npos);
  EXPECT_EQ(metadata.attempts(1).worker(), "fast");
  EXPECT_EQ(metadata.attempts(1).outcome(), "succeeded");
  v1::Scene scene;
  ASSERT_TRUE(done.response().UnpackTo(&scene));
  EXPECT_EQ(scene.state(), v1::Scene::READY);

  // The scene is complete and correct: its renders match embedded mode.
  const std::string out = test_dir_ + "/remote";
  const CommandResult render = Remote(server, {"render", scene.name(), "--cameras",
                                               *dir_ + "/views4.json", "--out", out, "--wait"});
  ASSERT_EQ(render.exit_code, 0) << render.out << render.err;
  for (const char* name : {"v00", "v01", "v02", "v03"}) {
    EXPECT_GE(RgbPsnr(out + "/" + name + ".exr", *dir_ + "/embedded/" + name + ".exr"), 60.0);
  }

  // Nothing of the dead attempt remains: no partial upload on the server,
  // and the dead worker's scratch space is emptied when it comes back.
  EXPECT_TRUE(!fs::exists(test_dir_ + "/blobs/tmp") || fs::is_empty(test_dir_ + "/blobs/tmp"));
  ASSERT_TRUE(slow.Start());
  ASSERT_TRUE(WaitFor([&] { return fs::exists(slow.work_dir()) && fs::is_empty(slow.work_dir()); },
                      std::chrono::seconds(10)))
      << slow.Log();
}

TEST_F(ServiceE2e, ServerKilledAndRestartedLosesNoAcceptedJob) {
  ServerProcess server(test_dir_);
  ASSERT_TRUE(server.Start()) << server.Log();
  WorkerProcess worker(server.address(), test_dir_, "w1");
  ASSERT_TRUE(worker.Start({"--stage-delay-ms", "200"}));
  const CommandResult create = Remote(server, {"scene", "create", Clip(), "--wait"});
  ASSERT_EQ(create.exit_code, 0) << create.err;
  const std::string scene = Find(create.out, "scenes/[0-9a-f]+");

  std::vector<std::string> ops;
  for (int i = 0; i < 3; ++i) {
    const CommandResult render =
        Remote(server, {"render", scene, "--cameras", *dir_ + "/views4.json", "--out",
                        test_dir_ + "/unused", "--chunk-frames", "1"});
    ASSERT_EQ(render.exit_code, 0) << render.err;
    ops.push_back(Find(render.out, "operations/[0-9a-f]+"));
    ASSERT_FALSE(ops.back().empty()) << render.out;
  }
  EXPECT_EQ(server.Kill(SIGKILL), 128 + SIGKILL);
  ASSERT_TRUE(server.Restart()) << server.Log();

  EXPECT_EQ(ListOperations(server.address(), "kind=render", 1000).size(), 3u);
  for (const std::string& op_name : ops) {
    const Operation done = WaitDone(server.address(), op_name);
    ASSERT_TRUE(done.done()) << op_name << "\n" << server.Log() << worker.Log();
    EXPECT_FALSE(done.has_error()) << done.error().message();
    v1::RenderJob job;
    ASSERT_TRUE(done.response().UnpackTo(&job));
    EXPECT_EQ(job.state(), v1::RenderJob::SUCCEEDED);
    EXPECT_EQ(job.files_size(), 4 * 2 + 1);  // EXR and PNG per view, manifest.json.
  }
}

TEST_F(ServiceE2e, CancelStopsARunningRenderJob) {
  ServerProcess server(test_dir_);
  ASSERT_TRUE(server.Start()) << server.Log();
  WorkerProcess worker(server.address(), test_dir_, "w1");
  ASSERT_TRUE(worker.Start({"--stage-delay-ms", "300"}));
  const CommandResult create = Remote(server, {"scene", "create", Clip(), "--wait"});
  ASSERT_EQ(create.exit_code, 0) << create.err;
  const std::string scene = Find(create.out, "scenes/[0-9a-f]+");

  const CommandResult render =
      Remote(server, {"render", scene, "--cameras", *dir_ + "/views20.json", "--out",
                      test_dir_ + "/unused", "--chunk-frames", "20"});
  ASSERT_EQ(render.exit_code, 0) << render.err;
  const std::string op_name = Find(render.out, "operations/[0-9a-f]+");
  ASSERT_TRUE(WaitFor(
      [&] {
        absl::StatusOr<Operation> op = GetOperation(server.address(), op_name);
        return op.ok() && Metadata(*op).frames_done() >= 1;
      },
      std::chrono::seconds(30)));
  const CommandResult cancel = Remote(server, {"jobs", "cancel", op_name});
  ASSERT_EQ(cancel.exit_code, 0) << cancel.out << cancel.err;

  const Operation done = WaitDone(server.address(), op_name, 10);
  ASSERT_TRUE(done.done());
  EXPECT_EQ(done.error().code(), static_cast<int>(grpc::StatusCode::CANCELLED));
  EXPECT_EQ(Metadata(done).state(), "CANCELLED");
  EXPECT_LT(Metadata(done).frames_done(), 20);
  // The worker drops the chunk within a couple of seconds and takes new work.
  ASSERT_TRUE(WaitFor([&] { return worker.Log().find("cancelled") != std::string::npos; },
                      std::chrono::seconds(5)))
      << worker.Log();
  const CommandResult next = Remote(server, {"render", scene, "--cameras", *dir_ + "/views4.json",
                                             "--out", test_dir_ + "/next", "--wait"});
  EXPECT_EQ(next.exit_code, 0) << next.err;
  EXPECT_TRUE(fs::exists(test_dir_ + "/next/v03.exr"));
  const CommandResult wait = Remote(server, {"jobs", "wait", op_name});
  EXPECT_EQ(wait.exit_code, 1) << wait.out << wait.err;  // Cancelled.
}

// Bad requests get INVALID_ARGUMENT or NOT_FOUND naming the field, and the
// server keeps serving.
TEST_F(ServiceE2e, BadRequestsNameTheFieldAndTheServerKeepsServing) {
  ServerProcess server(test_dir_);
  ASSERT_TRUE(server.Start({"--max-upload-bytes", "800000"})) << server.Log();
  auto channel = MakeChannel(server.address());
  auto scenes = v1::SceneService::NewStub(channel);
  auto renders = v1::RenderService::NewStub(channel);
  BlobClient blobs(channel);

  auto create_scene = [&](const v1::UploadedClip& clip) {
    v1::CreateSceneRequest request;
    *request.mutable_clip()->mutable_uploaded() = clip;
    grpc::ClientContext context;
    Operation op;
    return scenes->CreateScene(&context, request, &op);
  };
  // The clip as the remote CLI uploads it.
  std::ifstream in(Clip());
  nlohmann::json manifest = nlohmann::json::parse(in);
  v1::UploadedClip good;
  for (const nlohmann::json& frame : manifest["frames"]) {
    for (const char* key : {"image", "depth"}) {
      if (!frame.contains(key)) continue;
      const std::string path = frame[key];
      absl::StatusOr<v1::Digest> digest = blobs.UploadFile(*dir_ + "/clip/" + path);
      ASSERT_TRUE(digest.ok()) << digest.status();
      (*good.mutable_files())[path] = *digest;
    }
  }
  for (const nlohmann::json& sweep : manifest["lidar"]) {
    const std::string path = sweep["points"];
    absl::StatusOr<v1::Digest> digest = blobs.UploadFile(*dir_ + "/clip/" + path);
    ASSERT_TRUE(digest.ok()) << digest.status();
    (*good.mutable_files())[path] = *digest;
  }

  // Malformed manifest.
  v1::UploadedClip broken = good;
  *broken.mutable_manifest() = *blobs.UploadBytes("{\"cameras\": [");
  grpc::Status status = create_scene(broken);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("clip.uploaded.manifest"), std::string::npos)
      << status.error_message();

  // A pose that is not rigid: the validator's field path comes back.
  nlohmann::json skewed = manifest;
  skewed["frames"][1]["worldFromCamera"][0] = 3.0;
  v1::UploadedClip bad_pose = good;
  *bad_pose.mutable_manifest() = *blobs.UploadBytes(skewed.dump());
  status = create_scene(bad_pose);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("frames[1].worldFromCamera"), std::string::npos)
      << status.error_message();

  // A referenced file missing from the upload, and a path escaping the clip.
  v1::UploadedClip missing = good;
  *missing.mutable_manifest() = *blobs.UploadBytes(manifest.dump());
  const std::string first_image = manifest["frames"][0]["image"];
  missing.mutable_files()->erase(first_image);
  status = create_scene(missing);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("frames[0].image"), std::string::npos)
      << status.error_message();
  v1::UploadedClip escape = missing;
  (*escape.mutable_files())["../" + first_image] = good.files().at(first_image);
  status = create_scene(escape);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("clip.uploaded.files[\"../"), std::string::npos)
      << status.error_message();

  // Unknown and malformed scene names.
  {
    grpc::ClientContext context;
    v1::GetSceneRequest request;
    request.set_name("scenes/0123456789abcdef01234567");
    v1::Scene scene;
    status = scenes->GetScene(&context, request, &scene);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::NOT_FOUND);
  }
  {
    grpc::ClientContext context;
    v1::GetSceneRequest request;
    request.set_name("not-a-scene");
    v1::Scene scene;
    status = scenes->GetScene(&context, request, &scene);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_NE(status.error_message().find("name:"), std::string::npos) << status.error_message();
  }

  // Malformed views: a view naming a camera the request does not define.
  {
    v1::CreateRenderJobRequest request;
    request.set_scene("scenes/0123456789abcdef01234567");
    std::ifstream views_in(*dir_ + "/views4.json");
    std::string views_json((std::istreambuf_iterator<char>(views_in)), {});
    ASSERT_TRUE(
        google::protobuf::util::JsonStringToMessage(views_json, request.mutable_views()).ok());
    grpc::ClientContext context;
    Operation op;
    status = renders->CreateRenderJob(&context, request, &op);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::NOT_FOUND);  // Unknown scene first.
    EXPECT_NE(status.error_message().find("scene"), std::string::npos);

    request.clear_scene();
    v1::CreateSceneRequest* create = request.mutable_create_scene();
    *create->mutable_clip()->mutable_uploaded() = good;
    *create->mutable_clip()->mutable_uploaded()->mutable_manifest() =
        *blobs.UploadBytes(manifest.dump());
    request.mutable_views()->mutable_views(2)->set_camera("no-such-camera");
    grpc::ClientContext context2;
    status = renders->CreateRenderJob(&context2, request, &op);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_NE(status.error_message().find("views.views[2].camera"), std::string::npos)
        << status.error_message();
  }

  // An upload over the server's limit.
  absl::StatusOr<v1::Digest> big = blobs.UploadBytes(std::string(900000, 'x'));
  EXPECT_EQ(big.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(std::string(big.status().message()).find("800000"), std::string::npos) << big.status();

  // Still serving: a list works and the process is alive.
  grpc::ClientContext context;
  v1::ListScenesResponse list;
  EXPECT_TRUE(scenes->ListScenes(&context, v1::ListScenesRequest(), &list).ok());
  EXPECT_EQ(server.Kill(SIGTERM), 0) << server.Log();
}

// The Python example client (Debian's python3-grpcio, stubs generated by the
// build) reconstructs, renders four views and a LiDAR sweep, and reads an
// EXR and the sweep's range image back.
TEST_F(ServiceE2e, PythonClientCreatesASceneRendersAndReadsAnExr) {
  ServerProcess server(test_dir_);
  ASSERT_TRUE(server.Start({"--chunk-frames", "2"})) << server.Log();
  WorkerProcess worker(server.address(), test_dir_, "w1");
  ASSERT_TRUE(worker.Start());
  const std::string out = test_dir_ + "/py";
  const CommandResult run = RunCommand(
      {"/usr/bin/env", std::string("PYTHONPATH=") + PF_PYTHON_DIR, "/usr/bin/python3",
       testing::SourceDir() + "/examples/python/pf_client.py", "--server", server.address(),
       "--clip", Clip(), "--views", *dir_ + "/views4.json", "--out", out, "--lidar"});
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  const std::string last_line = run.out.substr(run.out.rfind("\n{") + 1);
  const nlohmann::json summary = nlohmann::json::parse(last_line);
  // Four views' EXR and PNG, the sweep's range image and points, the manifest.
  EXPECT_EQ(summary["files"], 4 * 2 + 2 + 1);
  EXPECT_EQ(summary["width"], 192);
  EXPECT_EQ(summary["height"], 144);
  EXPECT_EQ(summary["exr"], "v00.exr");
  const std::set<std::string> services = summary["services"];
  for (const char* service :
       {"pointforward.v1.SceneService", "pointforward.v1.RenderService",
        "pointforward.v1.BlobService", "google.longrunning.Operations", "grpc.health.v1.Health"}) {
    EXPECT_TRUE(services.count(service)) << service;
  }
  // The EXR it read is the one embedded mode renders.
  const auto embedded = ReadExr(*dir_ + "/embedded/v00.exr");
  for (int c = 0; c < 3; ++c) {
    const std::vector<float>& channel = embedded.at(std::string(1, "RGB"[c]));
    double sum = 0;
    for (float v : channel) sum += v;
    EXPECT_NEAR(summary["meanRgb"][c].get<double>(), sum / channel.size(), 1e-4);
  }
  EXPECT_GE(RgbPsnr(out + "/v00.exr", *dir_ + "/embedded/v00.exr"), 60.0);

  // The sweep, rendered by a worker as the third chunk, is the one pf render
  // makes of the embedded scene.
  ASSERT_EQ(summary["lidars"].size(), 1u);
  const nlohmann::json& sweep = summary["lidars"][0];
  EXPECT_EQ(sweep["beams"], 32);
  EXPECT_EQ(sweep["columns"], 720);
  nlohmann::json views = nlohmann::json::parse(std::ifstream(*dir_ + "/views4.json"));
  views["lidars"] = {sweep["view"]};
  std::ofstream(test_dir_ + "/views_lidar.json") << views.dump();
  const std::string embedded_lidar = test_dir_ + "/embedded_lidar";
  const CommandResult render =
      RunCommand({Pf(), "render", *dir_ + "/embedded.pfs", "--cameras",
                  test_dir_ + "/views_lidar.json", "--out", embedded_lidar});
  ASSERT_EQ(render.exit_code, 0) << render.err;
  const nlohmann::json local =
      nlohmann::json::parse(std::ifstream(embedded_lidar + "/manifest.json"));
  const nlohmann::json remote = nlohmann::json::parse(std::ifstream(out + "/manifest.json"));
  ASSERT_EQ(remote["lidars"].size(), 1u);
  EXPECT_EQ(remote["lidars"][0]["points"], "sweep.lidar.bin");
  EXPECT_EQ(remote["lidars"][0]["returns"], sweep["returns"]);
  EXPECT_EQ(remote["views"].size(), 4u);
  const int64_t returns = local["lidars"][0]["returns"].get<int64_t>();
  EXPECT_GT(returns, 32 * 720 / 10);  // The cameras look ahead: a part of the sweep hits.
  EXPECT_NEAR(sweep["returns"].get<double>(), returns, 0.01 * returns);
  const auto theirs = ReadExr(embedded_lidar + "/sweep.range.exr");
  const auto ours = ReadExr(out + "/sweep.range.exr");
  const std::vector<float>& hit = ours.at("hit");
  ASSERT_EQ(hit.size(), 32u * 720u);
  int same = 0;
  std::vector<double> range_error, intensity_error;
  for (size_t r = 0; r < hit.size(); ++r) {
    same += hit[r] == theirs.at("hit")[r];
    if (hit[r] > 0.5 && theirs.at("hit")[r] > 0.5) {
      range_error.push_back(std::abs(ours.at("range")[r] - theirs.at("range")[r]));
      intensity_error.push_back(std::abs(ours.at("intensity")[r] - theirs.at("intensity")[r]));
    }
  }
  EXPECT_GE(same, 0.99 * hit.size());
  ASSERT_FALSE(range_error.empty());
  std::sort(range_error.begin(), range_error.end());
  EXPECT_LT(range_error[range_error.size() / 2], 1e-3);
  std::sort(intensity_error.begin(), intensity_error.end());
  EXPECT_LT(intensity_error[intensity_error.size() / 2], 1e-3);
  // The client's summary reads the same image: its median range and
  // intensity are pf render's; the scene has pf synth's LiDAR intensity.
  std::vector<float> local_ranges, local_intensities;
  for (size_t r = 0; r < hit.size(); ++r) {
    if (theirs.at("hit")[r] > 0.5) {
      local_ranges.push_back(theirs.at("range")[r]);
      local_intensities.push_back(theirs.at("intensity")[r]);
    }
  }
  std::sort(local_ranges.begin(), local_ranges.end());
  std::sort(local_intensities.begin(), local_intensities.end());
  EXPECT_NEAR(sweep["medianRangeM"].get<double>(), local_ranges[local_ranges.size() / 2], 0.01);
  const double median_intensity = local_intensities[local_intensities.size() / 2];
  EXPECT_GT(median_intensity, 0.05);
  EXPECT_NEAR(sweep["medianIntensity"].get<double>(), median_intensity, 0.01);
}

}  // namespace
}  // namespace pf
