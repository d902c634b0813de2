// The cluster on loopback: a real PostgreSQL server, two pf-server replicas
// on it sharing one blob directory, three pf-worker processes spread over
// the replicas. 3 reconstructions and 30 render jobs (each naming a clip,
// so it waits for its scene) are submitted concurrently through both
// replicas while one worker is SIGKILLed and one replica is killed and
// restarted. Every job must complete exactly once: each chunk succeeds once,
// no output is listed twice, every output blob is intact, nothing is lost.
#include <grpcpp/grpcpp.h>
#include <signal.h>

#include <filesystem>
#include <map>
#include <mutex>
#include <regex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "common/hash.h"
#include "google/longrunning/operations.grpc.pb.h"
#include "gtest/gtest.h"
#include "pointforward/v1/resources.pb.h"
#include "rpc/grpc_status.h"
#include "tests/postgres_server.h"
#include "tests/service_checks.h"
#include "tests/service_harness.h"
#include "tests/test_util.h"

namespace pf {
namespace {

namespace v1 = pointforward::v1;
using google::longrunning::Operation;
using testing::BinPath;
using testing::CommandResult;
using testing::Find;
using testing::GetOperation;
using testing::ListOperations;
using testing::RunCommand;
using testing::ServerProcess;
using testing::SynthSmallClip;
using testing::WaitFor;
using testing::WorkerProcess;

TEST(Cluster, TwoReplicasThreeWorkersEveryJobOnceDespiteAKilledWorkerAndARestartedServer) {
  if (std::optional<std::string> why = testing::PostgresServer::WhyUnavailable()) {
    GTEST_SKIP() << *why;
  }
  absl::StatusOr<testing::PostgresServer*> postgres = testing::PostgresServer::Shared();
  ASSERT_TRUE(postgres.ok()) << postgres.status();
  absl::StatusOr<std::string> url = (*postgres)->CreateFreshDatabase();
  ASSERT_TRUE(url.ok()) << url.status();

  const std::string dir = testing::MakeTempDir("cluster");
  std::vector<std::string> clips;
  for (int seed = 1; seed <= 3; ++seed) {
    const std::string out = dir + "/clip" + std::to_string(seed);
    const CommandResult synth = SynthSmallClip(out, {"--seed", std::to_string(seed)});
    ASSERT_EQ(synth.exit_code, 0) << synth.err;
    clips.push_back(out + "/clip.json");
  }
  // Four views of the first camera at the clip's first frame poses.
  {
    const CommandResult views = RunCommand(
        {"/usr/bin/python3", "-c",
         "import json,sys\n"
         "c=json.load(open(sys.argv[1]))\n"
         "cam=c['cameras'][0]\n"
         "fs=[f for f in c['frames'] if f['camera']==cam['id']]\n"
         "v=[{'camera':cam['id'],'timestampUs':fs[i%len(fs)].get('timestampUs',0),"
         "'worldFromCamera':fs[i%len(fs)]['worldFromCamera'],'name':'v%d'%i} for i in range(4)]\n"
         "json.dump({'cameras':[cam],'views':v},open(sys.argv[2],'w'))\n",
         clips[0], dir + "/views.json"});
    ASSERT_EQ(views.exit_code, 0) << views.err;
  }

  const std::vector<std::string> flags = {"--lease-seconds", "3", "--chunk-frames", "2"};
  ServerProcess server1(dir, "server1", *url, dir + "/blobs");
  ServerProcess server2(dir, "server2", *url, dir + "/blobs");
  ASSERT_TRUE(server1.Start(flags)) << server1.Log();
  ASSERT_TRUE(server2.Start(flags)) << server2.Log();
  WorkerProcess w1(server1.address(), dir, "w1");
  WorkerProcess w2(server2.address(), dir, "w2");
  WorkerProcess w3(server1.address(), dir, "w3");
  for (WorkerProcess* worker : {&w1, &w2, &w3}) {
    ASSERT_TRUE(worker->Start({"--stage-delay-ms", "150", "--heartbeat-ms", "300"}));
  }
  const std::vector<std::string> servers = {server1.address(), server2.address()};

  // 3 reconstructions and 30 render jobs, from 6 concurrent clients, every
  // other one through the other replica.
  std::mutex mu;
  std::vector<std::string> recon_ops;
  std::vector<std::string> render_ops;
  std::vector<std::string> failures;
  std::vector<std::thread> clients;
  for (int client = 0; client < 6; ++client) {
    clients.emplace_back([&, client] {
      for (int i = client; i < 33; i += 6) {
        const std::string& server = servers[i % 2];
        std::vector<std::string> argv = {BinPath("pf"), "--server", server};
        if (i < 3) {
          argv.insert(argv.end(), {"scene", "create", clips[i]});
        } else {
          argv.insert(argv.end(), {"render", "--clip", clips[i % 3], "--cameras",
                                   dir + "/views.json", "--out", dir + "/unused"});
        }
        const CommandResult result = RunCommand(argv);
        const std::string op = Find(result.out, "operations/[0-9a-f]+");
        std::lock_guard<std::mutex> lock(mu);
        if (result.exit_code != 0 || op.empty()) {
          failures.push_back(result.out + result.err);
        } else {
          (i < 3 ? recon_ops : render_ops).push_back(op);
        }
      }
    });
  }
  for (std::thread& client : clients) client.join();
  ASSERT_TRUE(failures.empty()) << failures.front();
  ASSERT_EQ(recon_ops.size(), 3u);
  ASSERT_EQ(render_ops.size(), 30u);

  // Faults during the run: a worker dies, a replica is killed and restarted.
  EXPECT_EQ(w2.Kill(SIGKILL), 128 + SIGKILL);
  EXPECT_EQ(server1.Kill(SIGKILL), 128 + SIGKILL);
  std::this_thread::sleep_for(std::chrono::seconds(1));
  ASSERT_TRUE(server1.Restart()) << server1.Log();

  // Everything finishes; either replica answers for every job.
  std::vector<std::string> all_ops = recon_ops;
  all_ops.insert(all_ops.end(), render_ops.begin(), render_ops.end());
  std::map<std::string, Operation> done;
  ASSERT_TRUE(WaitFor(
      [&] {
        for (size_t i = 0; i < all_ops.size(); ++i) {
          if (done.count(all_ops[i])) continue;
          absl::StatusOr<Operation> op =
              GetOperation(servers[i % 2], all_ops[i], /*deadline_seconds=*/5);
          if (op.ok() && op->done()) done[all_ops[i]] = *op;
        }
        return done.size() == all_ops.size();
      },
      std::chrono::seconds(300)))
      << done.size() << " of " << all_ops.size() << " done\n"
      << server1.Log() << server2.Log();

  std::set<std::string> scenes;
  for (const std::string& name : recon_ops) {
    const Operation& op = done[name];
    ASSERT_FALSE(op.has_error()) << name << ": " << op.error().message();
    v1::Scene scene;
    ASSERT_TRUE(op.response().UnpackTo(&scene));
    EXPECT_EQ(scene.state(), v1::Scene::READY);
    scenes.insert(scene.name());
  }
  EXPECT_EQ(scenes.size(), 3u);

  std::set<std::string> blobs_checked;
  for (const std::string& name : render_ops) {
    const Operation& op = done[name];
    ASSERT_FALSE(op.has_error()) << name << ": " << op.error().message();
    v1::RenderJob job;
    ASSERT_TRUE(op.response().UnpackTo(&job));
    EXPECT_EQ(job.state(), v1::RenderJob::SUCCEEDED);
    EXPECT_TRUE(scenes.count(job.scene())) << job.scene();
    // 4 views: EXR + PNG each, and manifest.json; no name twice.
    std::set<std::string> names;
    for (const v1::OutputFile& file : job.files()) {
      EXPECT_TRUE(names.insert(file.name()).second) << name << " lists " << file.name() << " twice";
      const std::string& sha = file.digest().sha256();
      if (blobs_checked.insert(sha).second) {
        absl::StatusOr<std::string> actual =
            Sha256File(dir + "/blobs/" + sha.substr(0, 2) + "/" + sha);
        ASSERT_TRUE(actual.ok()) << actual.status();
        EXPECT_EQ(*actual, sha) << file.name();
      }
    }
    EXPECT_EQ(names.size(), 9u) << name;
    // Each chunk succeeded exactly once, whatever happened to other attempts.
    v1::OperationMetadata metadata;
    ASSERT_TRUE(op.metadata().UnpackTo(&metadata));
    EXPECT_EQ(metadata.frames_done(), 4);
    std::map<std::string, int> successes;
    for (const v1::Attempt& attempt : metadata.attempts()) {
      if (attempt.outcome() == "succeeded") ++successes[attempt.task()];
    }
    ASSERT_EQ(successes.size(), 2u) << metadata.DebugString();
    for (const auto& [task, count] : successes) EXPECT_EQ(count, 1) << name << " " << task;
  }

  // No job lost or duplicated: the store holds exactly the 3 + 30 submitted,
  // listed in pages of 7 (several pages, paging across replicas too).
  EXPECT_EQ(ListOperations(server2.address(), "kind=reconstruct", 7).size(), 3u);
  EXPECT_EQ(ListOperations(server1.address(), "kind=render", 7).size(), 30u);
  EXPECT_EQ(server1.Kill(SIGTERM), 0);
  EXPECT_EQ(server2.Kill(SIGTERM), 0);
}

}  // namespace
}  // namespace pf
