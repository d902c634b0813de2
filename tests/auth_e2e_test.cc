// Authentication and TLS end to end: pf-server with a token file (and TLS
// with a certificate made by openssl for this run), pf-worker and the `pf`
// command line as real processes on loopback, calls made with real gRPC
// stubs. Each promise of docs/SERVICE.md "Authentication and TLS" is
// checked by trying to break it: no token, a wrong token, another owner's
// token, a user token on WorkerService, a plaintext client on a TLS port.
#include <google/protobuf/descriptor.h>
#include <google/protobuf/util/json_util.h>
#include <grpcpp/grpcpp.h>
#include <signal.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "common/hash.h"
#include "google/longrunning/operations.grpc.pb.h"
#include "gtest/gtest.h"
#include "pointforward/v1/blobs.grpc.pb.h"
#include "pointforward/v1/service.grpc.pb.h"
#include "pointforward/v1/worker.grpc.pb.h"
#include "rpc/grpc_status.h"
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
using testing::RunCommand;
using testing::ServerProcess;
using testing::SynthSmallClip;
using testing::WaitFor;
using testing::WorkerProcess;

constexpr char kAliceToken[] = "alice-token-5f1c2e9a7b3d";
constexpr char kBobToken[] = "bob-token-0a9e8d7c6b5a4f3e";
constexpr char kAdminToken[] = "admin-token-77aa88bb99cc";
constexpr char kWorkerToken[] = "worker-token-1234abcd5678ef";
constexpr char kCarolToken[] = "carol-token-added-later-42";

std::string TokenLine(const std::string& token, const std::string& owner,
                      const std::string& role = "") {
  return Sha256Hex(token) + " " + owner + (role.empty() ? "" : " " + role) + "\n";
}

void WriteFile(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// Stubs over one channel with `token` (none when empty).
struct Client {
  explicit Client(const std::string& address, const std::string& token = "",
                  ChannelOptions options = {}) {
    options.token = token;
    channel = MakeChannel(address, options);
    scenes = v1::SceneService::NewStub(channel);
    renders = v1::RenderService::NewStub(channel);
    operations = google::longrunning::Operations::NewStub(channel);
    blobs = v1::BlobService::NewStub(channel);
    workers = v1::WorkerService::NewStub(channel);
  }

  grpc::Status GetOperation(const std::string& name, Operation* op = nullptr) {
    grpc::ClientContext context;
    Deadline(context);
    google::longrunning::GetOperationRequest request;
    request.set_name(name);
    Operation ignored;
    return operations->GetOperation(&context, request, op != nullptr ? op : &ignored);
  }
  grpc::Status CancelOperation(const std::string& name) {
    grpc::ClientContext context;
    Deadline(context);
    google::longrunning::CancelOperationRequest request;
    request.set_name(name);
    google::protobuf::Empty empty;
    return operations->CancelOperation(&context, request, &empty);
  }
  grpc::Status GetScene(const std::string& name) {
    grpc::ClientContext context;
    Deadline(context);
    v1::GetSceneRequest request;
    request.set_name(name);
    v1::Scene scene;
    return scenes->GetScene(&context, request, &scene);
  }
  // Names of every operation the token may list.
  std::set<std::string> OperationNames(grpc::Status* status = nullptr) {
    grpc::ClientContext context;
    Deadline(context);
    google::longrunning::ListOperationsRequest request;
    request.set_page_size(1000);
    google::longrunning::ListOperationsResponse response;
    const grpc::Status got = operations->ListOperations(&context, request, &response);
    if (status != nullptr) *status = got;
    std::set<std::string> names;
    for (const Operation& op : response.operations()) names.insert(op.name());
    return names;
  }
  std::set<std::string> SceneNames() {
    grpc::ClientContext context;
    Deadline(context);
    v1::ListScenesRequest request;
    v1::ListScenesResponse response;
    EXPECT_TRUE(scenes->ListScenes(&context, request, &response).ok());
    std::set<std::string> names;
    for (const v1::Scene& scene : response.scenes()) names.insert(scene.name());
    return names;
  }
  std::set<std::string> RenderJobNames() {
    grpc::ClientContext context;
    Deadline(context);
    v1::ListRenderJobsRequest request;
    v1::ListRenderJobsResponse response;
    EXPECT_TRUE(renders->ListRenderJobs(&context, request, &response).ok());
    std::set<std::string> names;
    for (const v1::RenderJob& job : response.render_jobs()) names.insert(job.name());
    return names;
  }

  static void Deadline(grpc::ClientContext& context) {
    context.set_deadline(std::chrono::system_clock::now() +
                         testing::Scaled(std::chrono::seconds(10)));
  }

  std::shared_ptr<grpc::Channel> channel;
  std::unique_ptr<v1::SceneService::Stub> scenes;
  std::unique_ptr<v1::RenderService::Stub> renders;
  std::unique_ptr<google::longrunning::Operations::Stub> operations;
  std::unique_ptr<v1::BlobService::Stub> blobs;
  std::unique_ptr<v1::WorkerService::Stub> workers;
};

// Every RPC of the five services, called with an empty request: the name
// "/package.Service/Method" -> the call's status.
std::map<std::string, std::function<grpc::Status()>> EveryRpc(Client& c) {
  using Empty = google::protobuf::Empty;
  std::map<std::string, std::function<grpc::Status()>> calls;
  const auto unary = [&](const std::string& name, auto call) {
    calls[name] = [call] {
      grpc::ClientContext context;
      Client::Deadline(context);
      return call(&context);
    };
  };
  const std::string scene = "/pointforward.v1.SceneService/";
  unary(scene + "CreateScene", [&c](grpc::ClientContext* x) {
    Operation op;
    return c.scenes->CreateScene(x, v1::CreateSceneRequest(), &op);
  });
  unary(scene + "GetScene", [&c](grpc::ClientContext* x) {
    v1::Scene out;
    return c.scenes->GetScene(x, v1::GetSceneRequest(), &out);
  });
  unary(scene + "ListScenes", [&c](grpc::ClientContext* x) {
    v1::ListScenesResponse out;
    return c.scenes->ListScenes(x, v1::ListScenesRequest(), &out);
  });
  unary(scene + "DeleteScene", [&c](grpc::ClientContext* x) {
    Empty out;
    return c.scenes->DeleteScene(x, v1::DeleteSceneRequest(), &out);
  });
  unary(scene + "ExportScene", [&c](grpc::ClientContext* x) {
    auto reader = c.scenes->ExportScene(x, v1::ExportSceneRequest());
    v1::ExportSceneChunk chunk;
    while (reader->Read(&chunk)) {
    }
    return reader->Finish();
  });
  const std::string render = "/pointforward.v1.RenderService/";
  unary(render + "CreateRenderJob", [&c](grpc::ClientContext* x) {
    Operation op;
    return c.renders->CreateRenderJob(x, v1::CreateRenderJobRequest(), &op);
  });
  unary(render + "GetRenderJob", [&c](grpc::ClientContext* x) {
    v1::RenderJob out;
    return c.renders->GetRenderJob(x, v1::GetRenderJobRequest(), &out);
  });
  unary(render + "ListRenderJobs", [&c](grpc::ClientContext* x) {
    v1::ListRenderJobsResponse out;
    return c.renders->ListRenderJobs(x, v1::ListRenderJobsRequest(), &out);
  });
  const std::string ops = "/google.longrunning.Operations/";
  unary(ops + "ListOperations", [&c](grpc::ClientContext* x) {
    google::longrunning::ListOperationsResponse out;
    return c.operations->ListOperations(x, google::longrunning::ListOperationsRequest(), &out);
  });
  unary(ops + "GetOperation", [&c](grpc::ClientContext* x) {
    Operation out;
    return c.operations->GetOperation(x, google::longrunning::GetOperationRequest(), &out);
  });
  unary(ops + "DeleteOperation", [&c](grpc::ClientContext* x) {
    Empty out;
    return c.operations->DeleteOperation(x, google::longrunning::DeleteOperationRequest(), &out);
  });
  unary(ops + "CancelOperation", [&c](grpc::ClientContext* x) {
    Empty out;
    return c.operations->CancelOperation(x, google::longrunning::CancelOperationRequest(), &out);
  });
  unary(ops + "WaitOperation", [&c](grpc::ClientContext* x) {
    Operation out;
    return c.operations->WaitOperation(x, google::longrunning::WaitOperationRequest(), &out);
  });
  const std::string blobs = "/pointforward.v1.BlobService/";
  unary(blobs + "WriteBlob", [&c](grpc::ClientContext* x) {
    v1::WriteBlobResponse out;
    auto writer = c.blobs->WriteBlob(x, &out);
    v1::WriteBlobRequest request;
    request.mutable_digest()->set_sha256(Sha256Hex("x"));
    request.mutable_digest()->set_size_bytes(1);
    request.set_data("x");
    writer->Write(request);
    writer->WritesDone();
    return writer->Finish();
  });
  unary(blobs + "ReadBlob", [&c](grpc::ClientContext* x) {
    v1::ReadBlobRequest request;
    request.set_sha256(Sha256Hex("x"));
    auto reader = c.blobs->ReadBlob(x, request);
    v1::ReadBlobResponse chunk;
    while (reader->Read(&chunk)) {
    }
    return reader->Finish();
  });
  unary(blobs + "FindMissingBlobs", [&c](grpc::ClientContext* x) {
    v1::FindMissingBlobsResponse out;
    return c.blobs->FindMissingBlobs(x, v1::FindMissingBlobsRequest(), &out);
  });
  const std::string worker = "/pointforward.v1.WorkerService/";
  unary(worker + "LeaseTask", [&c](grpc::ClientContext* x) {
    v1::LeaseTaskRequest request;
    request.set_worker_id("intruder");
    v1::LeaseTaskResponse out;
    return c.workers->LeaseTask(x, request, &out);
  });
  unary(worker + "Heartbeat", [&c](grpc::ClientContext* x) {
    v1::HeartbeatResponse out;
    return c.workers->Heartbeat(x, v1::HeartbeatRequest(), &out);
  });
  unary(worker + "CompleteTask", [&c](grpc::ClientContext* x) {
    v1::CompleteTaskResponse out;
    return c.workers->CompleteTask(x, v1::CompleteTaskRequest(), &out);
  });
  unary(worker + "FailTask", [&c](grpc::ClientContext* x) {
    v1::FailTaskResponse out;
    return c.workers->FailTask(x, v1::FailTaskRequest(), &out);
  });
  return calls;
}

class AuthE2e : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new std::string(testing::MakeTempDir("auth_e2e"));
    const CommandResult synth = SynthSmallClip(*dir_ + "/clip");
    ASSERT_EQ(synth.exit_code, 0) << synth.err;
    WriteViews(*dir_ + "/clip/clip.json", *dir_ + "/views.json");
    MakeCertificates(*dir_);
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }

  // Two views of the clip's first frame.
  static void WriteViews(const std::string& clip_path, const std::string& path) {
    std::ifstream in(clip_path);
    const nlohmann::json clip = nlohmann::json::parse(in);
    nlohmann::json views;
    views["cameras"] = nlohmann::json::array({clip["cameras"][0]});
    for (int i = 0; i < 2; ++i) {
      const nlohmann::json& frame = clip["frames"][0];
      views["views"].push_back({{"camera", frame["camera"]},
                                {"timestampUs", frame["timestampUs"]},
                                {"worldFromCamera", frame["worldFromCamera"]},
                                {"name", "v" + std::to_string(i)}});
    }
    std::ofstream(path) << views.dump(2);
  }

  // A throwaway CA, a server certificate for 127.0.0.1 and localhost, and a
  // client certificate, all signed by the CA.
  static void MakeCertificates(const std::string& dir) {
    const auto run = [](const std::vector<std::string>& argv) {
      const CommandResult result = RunCommand(argv);
      ASSERT_EQ(result.exit_code, 0) << argv[1] << ": " << result.err;
    };
    WriteFile(dir + "/san.cnf", "subjectAltName=IP:127.0.0.1,DNS:localhost\n");
    run({"/usr/bin/openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout",
         dir + "/ca.key", "-out", dir + "/ca.pem", "-days", "2", "-subj", "/CN=pf-test-ca"});
    for (const std::string name : {"server", "client"}) {
      run({"/usr/bin/openssl", "req", "-newkey", "rsa:2048", "-nodes", "-keyout",
           dir + "/" + name + ".key", "-out", dir + "/" + name + ".csr", "-subj",
           "/CN=" + (name == "server" ? std::string("localhost") : "pf-test-worker")});
      run({"/usr/bin/openssl", "x509", "-req", "-in", dir + "/" + name + ".csr", "-CA",
           dir + "/ca.pem", "-CAkey", dir + "/ca.key", "-CAcreateserial", "-out",
           dir + "/" + name + ".pem", "-days", "2", "-extfile", dir + "/san.cnf"});
    }
  }

  void SetUp() override {
    test_dir_ = testing::MakeTempDir("auth_case");
    tokens_ = test_dir_ + "/tokens.txt";
    WriteFile(tokens_, "# owners of the test\n" + TokenLine(kAliceToken, "alice") +
                           TokenLine(kBobToken, "bob") + TokenLine(kAdminToken, "root", "admin") +
                           "\n" + TokenLine(kWorkerToken, "farm", "worker"));
    for (const auto& [name, token] : std::map<std::string, std::string>{{"alice", kAliceToken},
                                                                        {"bob", kBobToken},
                                                                        {"admin", kAdminToken},
                                                                        {"worker", kWorkerToken}}) {
      WriteFile(TokenFile(name), token + "\n");
    }
  }

  std::string TokenFile(const std::string& name) const { return test_dir_ + "/" + name + ".token"; }

  static ChannelOptions Tls(bool client_certificate = false) {
    ChannelOptions options;
    options.tls = true;
    options.tls_ca_pem = ReadFile(*dir_ + "/ca.pem");
    if (client_certificate) {
      options.tls_cert_pem = ReadFile(*dir_ + "/client.pem");
      options.tls_key_pem = ReadFile(*dir_ + "/client.key");
    }
    return options;
  }

  // `pf --server ADDR --token-file FILE args...`.
  CommandResult Pf(const ServerProcess& server, const std::string& who,
                   std::vector<std::string> args) {
    args.insert(args.begin(),
                {BinPath("pf"), "--server", server.address(), "--token-file", TokenFile(who)});
    return RunCommand(args);
  }

  // Creates a render job of `scene` as `client`'s owner; returns its operation name.
  static std::string CreateRenderJob(Client& client, const std::string& scene) {
    std::ifstream in(*dir_ + "/views.json");
    const std::string json((std::istreambuf_iterator<char>(in)), {});
    v1::CreateRenderJobRequest request;
    request.set_scene(scene);
    EXPECT_TRUE(google::protobuf::util::JsonStringToMessage(json, request.mutable_views()).ok());
    grpc::ClientContext context;
    Client::Deadline(context);
    Operation op;
    const grpc::Status status = client.renders->CreateRenderJob(&context, request, &op);
    EXPECT_TRUE(status.ok()) << status.error_message();
    return op.name();
  }

  static std::string* dir_;
  std::string test_dir_;
  std::string tokens_;
};

std::string* AuthE2e::dir_ = nullptr;

TEST_F(AuthE2e, HashTokenPrintsTheSha256OfTheTokenOnStdin) {
  const CommandResult hashed = RunCommand({"/bin/sh", "-c",
                                           "printf '%s\\n' " + std::string(kAliceToken) + " | " +
                                               BinPath("pf-server") + " hash-token"});
  ASSERT_EQ(hashed.exit_code, 0) << hashed.err;
  EXPECT_EQ(hashed.out, Sha256Hex(kAliceToken) + "\n");
  const CommandResult short_token =
      RunCommand({"/bin/sh", "-c", "printf short | " + BinPath("pf-server") + " hash-token"});
  EXPECT_EQ(short_token.exit_code, 2);
  EXPECT_NE(short_token.err.find("at least 16"), std::string::npos) << short_token.err;
}

TEST_F(AuthE2e, MalformedTokenFileStopsTheServerNamingTheLine) {
  WriteFile(tokens_, TokenLine(kAliceToken, "alice") + "not-a-hash bob\n");
  const CommandResult result = RunCommand({BinPath("pf-server"), "--listen", "127.0.0.1:0",
                                           "--store", "sqlite:" + test_dir_ + "/jobs.db", "--blobs",
                                           test_dir_ + "/blobs", "--auth-token-file", tokens_});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("tokens.txt:2: 'not-a-hash' is not a SHA-256"), std::string::npos)
      << result.err;
}

TEST_F(AuthE2e, EveryRpcButHealthRefusesCallsWithoutOrWithAWrongToken) {
  ServerProcess server(test_dir_);
  // Start() waits for a health check made without any token.
  ASSERT_TRUE(server.Start({"--auth-token-file", tokens_})) << server.Log();
  EXPECT_TRUE(testing::Serving(server.address()));

  Client anonymous(server.address());
  Client wrong(server.address(), "not-a-token-anyone-holds");
  std::map<std::string, std::function<grpc::Status()>> anonymous_calls = EveryRpc(anonymous);
  std::map<std::string, std::function<grpc::Status()>> wrong_calls = EveryRpc(wrong);

  // The table covers every method the five services declare.
  std::set<std::string> declared;
  for (const char* service : {"pointforward.v1.SceneService", "pointforward.v1.RenderService",
                              "google.longrunning.Operations", "pointforward.v1.BlobService",
                              "pointforward.v1.WorkerService"}) {
    const google::protobuf::ServiceDescriptor* descriptor =
        google::protobuf::DescriptorPool::generated_pool()->FindServiceByName(service);
    ASSERT_NE(descriptor, nullptr) << service;
    for (int i = 0; i < descriptor->method_count(); ++i) {
      declared.insert("/" + std::string(service) + "/" + descriptor->method(i)->name());
    }
  }
  std::set<std::string> called;
  for (const auto& [name, call] : anonymous_calls) called.insert(name);
  EXPECT_EQ(called, declared);

  for (const auto& [name, call] : anonymous_calls) {
    const grpc::Status status = call();
    EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAUTHENTICATED) << name;
    EXPECT_EQ(status.error_message(), "missing bearer token") << name;
  }
  for (const auto& [name, call] : wrong_calls) {
    const grpc::Status status = call();
    EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAUTHENTICATED) << name;
    EXPECT_EQ(status.error_message(), "unknown token") << name;
  }
  // Nothing was stored on their behalf.
  Client admin(server.address(), kAdminToken);
  EXPECT_TRUE(admin.OperationNames().empty());

  // The command line says so too.
  const CommandResult cli =
      RunCommand({BinPath("pf"), "--server", server.address(), "jobs", "list"});
  EXPECT_NE(cli.exit_code, 0);
  EXPECT_NE(cli.err.find("missing bearer token"), std::string::npos) << cli.err;
  // ...and where a token comes from.
  EXPECT_NE(cli.err.find("set PF_TOKEN, or put it in a file and pass --token-file FILE"),
            std::string::npos)
      << cli.err;
}

TEST_F(AuthE2e, OwnersSeeAndCancelOnlyTheirOwnAdminsEverything) {
  ServerProcess server(test_dir_);
  ASSERT_TRUE(server.Start({"--auth-token-file", tokens_})) << server.Log();
  WorkerProcess worker(server.address(), test_dir_, "w1");
  ASSERT_TRUE(worker.Start({"--token-file", TokenFile("worker")}));

  // Alice: the whole flow through the command line and pf-worker.
  const CommandResult rendered = Pf(server, "alice",
                                    {"render", "--clip", *dir_ + "/clip/clip.json", "--cameras",
                                     *dir_ + "/views.json", "--out", test_dir_ + "/out", "--wait"});
  ASSERT_EQ(rendered.exit_code, 0) << rendered.err << worker.Log() << server.Log();
  EXPECT_TRUE(fs::exists(test_dir_ + "/out/v0.exr"));
  EXPECT_TRUE(fs::exists(test_dir_ + "/out/v1.exr"));
  EXPECT_TRUE(fs::exists(test_dir_ + "/out/manifest.json"));

  Client alice(server.address(), kAliceToken);
  Client bob(server.address(), kBobToken);
  Client admin(server.address(), kAdminToken);
  const std::set<std::string> scenes = alice.SceneNames();
  ASSERT_EQ(scenes.size(), 1u);
  const std::string scene = *scenes.begin();
  const std::set<std::string> alice_ops = alice.OperationNames();
  ASSERT_EQ(alice_ops.size(), 2u);  // The reconstruction and the render job.

  // Bob sees none of it and may touch none of it.
  EXPECT_TRUE(bob.SceneNames().empty());
  EXPECT_TRUE(bob.OperationNames().empty());
  EXPECT_TRUE(bob.RenderJobNames().empty());
  // What he may not see answers as what does not exist (NOT_FOUND, the
  // same words), whatever the call.
  const std::string absent_scene = "scenes/000000000000000000000000";
  const std::string absent_op = "operations/00000000000000000000";
  for (const std::string& which : {scene, absent_scene}) {
    const grpc::Status get = bob.GetScene(which);
    EXPECT_EQ(get.error_code(), grpc::StatusCode::NOT_FOUND) << which;
    EXPECT_EQ(get.error_message(), "name: " + which + " not found");
    v1::CreateRenderJobRequest render;
    render.set_scene(which);
    render.mutable_views()->add_views()->set_camera("c");
    grpc::ClientContext context;
    Client::Deadline(context);
    Operation op;
    const grpc::Status created = bob.renders->CreateRenderJob(&context, render, &op);
    EXPECT_EQ(created.error_code(), grpc::StatusCode::NOT_FOUND) << which;
    EXPECT_EQ(created.error_message(), "scene: " + which + " not found");
  }
  for (const std::string& op : alice_ops) {
    for (const std::string& which : {op, absent_op}) {
      const grpc::Status get = bob.GetOperation(which);
      EXPECT_EQ(get.error_code(), grpc::StatusCode::NOT_FOUND) << which;
      EXPECT_EQ(get.error_message(), "name: " + which + " not found");
      const grpc::Status cancel = bob.CancelOperation(which);
      EXPECT_EQ(cancel.error_code(), grpc::StatusCode::NOT_FOUND) << which;
      EXPECT_EQ(cancel.error_message(), "name: " + which + " not found");
    }
  }
  // An admin sees everything; what does not exist is NOT_FOUND for it too.
  EXPECT_EQ(admin.GetScene(absent_scene).error_code(), grpc::StatusCode::NOT_FOUND);
  const CommandResult bob_get = Pf(server, "bob", {"scene", "get", scene});
  EXPECT_NE(bob_get.exit_code, 0);
  EXPECT_NE(bob_get.err.find(scene + " not found"), std::string::npos) << bob_get.err;

  // A job left queued (no worker), for the cancellations.
  worker.Kill(SIGTERM);
  const std::string queued = CreateRenderJob(alice, scene);
  ASSERT_FALSE(queued.empty());
  EXPECT_EQ(bob.CancelOperation(queued).error_code(), grpc::StatusCode::NOT_FOUND);
  Operation op;
  ASSERT_TRUE(alice.GetOperation(queued, &op).ok());
  EXPECT_FALSE(op.done());

  // The admin lists everyone's and cancels Alice's job.
  std::set<std::string> all = admin.OperationNames();
  EXPECT_TRUE(all.count(queued));
  for (const std::string& name : alice_ops) EXPECT_TRUE(all.count(name)) << name;
  EXPECT_TRUE(admin.SceneNames().count(scene));
  EXPECT_TRUE(admin.GetScene(scene).ok());
  ASSERT_TRUE(admin.CancelOperation(queued).ok());
  ASSERT_TRUE(alice.GetOperation(queued, &op).ok());
  EXPECT_TRUE(op.done());
  EXPECT_EQ(op.error().code(), static_cast<int>(grpc::StatusCode::CANCELLED));

  // Bob submitting the same clip hits the cache: he proved he holds the data
  // and now sees the scene and its reconstruction, but not Alice's renders.
  const CommandResult created =
      Pf(server, "bob", {"scene", "create", *dir_ + "/clip/clip.json", "--wait"});
  ASSERT_EQ(created.exit_code, 0) << created.err;
  EXPECT_EQ(bob.SceneNames(), scenes);
  EXPECT_TRUE(bob.GetScene(scene).ok());
  EXPECT_EQ(bob.RenderJobNames().size(), 0u);
  EXPECT_EQ(bob.OperationNames().size(), 1u);
  EXPECT_EQ(bob.GetOperation(queued).error_code(), grpc::StatusCode::NOT_FOUND);
}

// One WaitOperation call of `name` waiting up to `seconds`.
grpc::Status WaitOnce(Client& client, const std::string& name, int seconds = 0,
                      grpc::ClientContext* context = nullptr) {
  grpc::ClientContext own;
  if (context == nullptr) {
    context = &own;
    Client::Deadline(own);
  }
  google::longrunning::WaitOperationRequest request;
  request.set_name(name);
  request.mutable_timeout()->set_seconds(seconds);
  Operation op;
  return client.operations->WaitOperation(context, request, &op);
}

// A WaitOperation of 60 s in its own thread, until Stop().
class LongPoll {
 public:
  LongPoll(Client& client, const std::string& name)
      : thread_([this, &client, name] {
          status_ = WaitOnce(client, name, 60, &context_);
          done_ = true;
        }) {}
  ~LongPoll() { Stop(); }
  void Stop() {
    context_.TryCancel();
    if (thread_.joinable()) thread_.join();
  }
  // True once the call returned; then status() is its outcome.
  bool done() const { return done_; }
  std::string Describe() const {
    return done_ ? absl::StrCat("ended: ", status_.error_code(), " ", status_.error_message())
                 : "in flight";
  }

 private:
  grpc::ClientContext context_;
  grpc::Status status_;
  std::atomic<bool> done_{false};
  std::thread thread_;
};

// Keeps `polls` in flight: a poll that ended (the connection dropped under
// load) is started again, its end added to `log`.
void KeepPolling(std::vector<std::unique_ptr<LongPoll>>& polls, Client& client,
                 const std::string& name, std::string* log) {
  for (std::unique_ptr<LongPoll>& poll : polls) {
    if (!poll->done()) continue;
    absl::StrAppend(log, poll->Describe(), "; ");
    poll = std::make_unique<LongPoll>(client, name);
  }
}

TEST_F(AuthE2e, LongPollsAreCappedPerOwnerAndInAllWhileOtherCallsAreServed) {
  ServerProcess server(test_dir_);
  ASSERT_TRUE(server.Start(
      {"--auth-token-file", tokens_, "--max-long-polls", "3", "--max-long-polls-per-caller", "2"}))
      << server.Log();
  // A reconstruction nobody works on, that both Alice and Bob may see.
  const CommandResult created = Pf(server, "alice", {"scene", "create", *dir_ + "/clip/clip.json"});
  ASSERT_EQ(created.exit_code, 0) << created.err;
  const std::string op = created.out.substr(0, created.out.find('\n'));
  ASSERT_EQ(Pf(server, "bob", {"scene", "create", *dir_ + "/clip/clip.json"}).exit_code, 0);
  Client alice(server.address(), kAliceToken);
  Client bob(server.address(), kBobToken);

  // Alice holds two long polls: her third is refused, naming the cap.
  std::vector<std::unique_ptr<LongPoll>> alices;
  alices.push_back(std::make_unique<LongPoll>(alice, op));
  alices.push_back(std::make_unique<LongPoll>(alice, op));
  grpc::Status third;
  std::string restarts;
  EXPECT_TRUE(WaitFor(
      [&] {
        KeepPolling(alices, alice, op, &restarts);
        third = WaitOnce(alice, op);
        return third.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED;
      },
      std::chrono::seconds(10)))
      << third.error_code() << " " << third.error_message() << "; polls restarted: " << restarts
      << alices[0]->Describe() << ", " << alices[1]->Describe();
  EXPECT_NE(third.error_message().find("(pf-server --max-long-polls-per-caller)"),
            std::string::npos)
      << third.error_message();
  // Bob still gets one; then the server's cap of 3 is reached.
  std::vector<std::unique_ptr<LongPoll>> bobs;
  bobs.push_back(std::make_unique<LongPoll>(bob, op));
  grpc::Status fourth;
  EXPECT_TRUE(WaitFor(
      [&] {
        KeepPolling(alices, alice, op, &restarts);
        KeepPolling(bobs, bob, op, &restarts);
        fourth = WaitOnce(bob, op);
        return fourth.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED;
      },
      std::chrono::seconds(10)))
      << fourth.error_code() << " " << fourth.error_message() << "; polls restarted: " << restarts;
  EXPECT_NE(fourth.error_message().find("(pf-server --max-long-polls)"), std::string::npos)
      << fourth.error_message();
  // Every other call is served meanwhile.
  EXPECT_EQ(bob.SceneNames().size(), 1u);
  EXPECT_TRUE(bob.GetOperation(op).ok());
  EXPECT_EQ(alice.OperationNames().size(), 1u);
  EXPECT_EQ(Pf(server, "alice", {"jobs", "get", op}).exit_code, 0);
  // Polls that end give their places back.
  for (auto& poll : alices) poll->Stop();
  EXPECT_TRUE(WaitFor([&] { return WaitOnce(alice, op).ok(); }, std::chrono::seconds(10)));
  for (auto& poll : bobs) poll->Stop();
}

TEST_F(AuthE2e, OnlyWorkerOrAdminTokensMayLeaseTasks) {
  ServerProcess server(test_dir_);
  ASSERT_TRUE(server.Start({"--auth-token-file", tokens_})) << server.Log();

  Client alice(server.address(), kAliceToken);
  for (const auto& [name, call] : EveryRpc(alice)) {
    if (name.find("WorkerService") == std::string::npos) continue;
    const grpc::Status status = call();
    EXPECT_EQ(status.error_code(), grpc::StatusCode::PERMISSION_DENIED) << name;
    EXPECT_NE(status.error_message().find("needs a worker or admin token"), std::string::npos)
        << status.error_message();
  }
  // A pf-worker holding a user token is refused and says why.
  WorkerProcess worker(server.address(), test_dir_, "w-user");
  ASSERT_TRUE(worker.Start({"--token-file", TokenFile("alice")}));
  EXPECT_TRUE(WaitFor([&] { return worker.Log().find("PERMISSION_DENIED") != std::string::npos; },
                      std::chrono::seconds(10)))
      << worker.Log();

  // A worker token leases (nothing queued: an empty answer, no error).
  Client farm(server.address(), kWorkerToken);
  grpc::ClientContext context;
  Client::Deadline(context);
  v1::LeaseTaskRequest request;
  request.set_worker_id("farm-1");
  v1::LeaseTaskResponse response;
  const grpc::Status leased = farm.workers->LeaseTask(&context, request, &response);
  EXPECT_TRUE(leased.ok()) << leased.error_message();
  EXPECT_FALSE(response.has_task());
}

TEST_F(AuthE2e, ATokenAddedToTheFileWorksWithinTheReloadTimeWithoutARestart) {
  ServerProcess server(test_dir_);
  ASSERT_TRUE(server.Start({"--auth-token-file", tokens_})) << server.Log();
  const pid_t pid = server.pid();
  Client carol(server.address(), kCarolToken);
  grpc::Status status;
  carol.OperationNames(&status);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAUTHENTICATED);

  std::ofstream(tokens_, std::ios::app) << TokenLine(kCarolToken, "carol");
  const auto added = std::chrono::steady_clock::now();
  EXPECT_TRUE(WaitFor(
      [&] {
        carol.OperationNames(&status);
        return status.ok();
      },
      std::chrono::seconds(5)))
      << status.error_message();
  // Documented: within one second of the change; the rest is slack for the
  // 100 ms polling here (scaled for a sanitizer build or a loaded machine).
  EXPECT_LT(std::chrono::steady_clock::now() - added,
            testing::Scaled(std::chrono::milliseconds(2500)));
  EXPECT_EQ(server.pid(), pid);
  EXPECT_NE(server.Log().find("reloaded token file"), std::string::npos);

  // Removing a token revokes it the same way.
  WriteFile(tokens_, TokenLine(kAdminToken, "root", "admin"));
  EXPECT_TRUE(WaitFor(
      [&] {
        carol.OperationNames(&status);
        return status.error_code() == grpc::StatusCode::UNAUTHENTICATED;
      },
      std::chrono::seconds(5)));
}

TEST_F(AuthE2e, WithTlsPlaintextClientsAreRefusedAndTlsClientsWork) {
  ServerProcess server(test_dir_);
  server.set_health_channel(Tls());
  ASSERT_TRUE(server.Start({"--auth-token-file", tokens_, "--tls-cert", *dir_ + "/server.pem",
                            "--tls-key", *dir_ + "/server.key"}))
      << server.Log();
  EXPECT_FALSE(testing::Serving(server.address()));  // Plaintext health check.

  grpc::Status status;
  Client plaintext(server.address(), kAliceToken);
  plaintext.OperationNames(&status);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE) << status.error_message();

  Client tls(server.address(), kAliceToken, Tls());
  tls.OperationNames(&status);
  EXPECT_TRUE(status.ok()) << status.error_message();
  Client tls_without_token(server.address(), "", Tls());
  tls_without_token.OperationNames(&status);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAUTHENTICATED);

  // The command line with --tls-ca, and without it.
  const CommandResult with_ca =
      Pf(server, "alice", {"--tls-ca", *dir_ + "/ca.pem", "jobs", "list"});
  EXPECT_EQ(with_ca.exit_code, 0) << with_ca.err;
  const CommandResult without = Pf(server, "alice", {"jobs", "list"});
  EXPECT_EQ(without.exit_code, 3) << without.err;
}

TEST_F(AuthE2e, MutualTlsRequiresAClientCertificateSignedByTheCa) {
  ServerProcess server(test_dir_);
  server.set_health_channel(Tls(/*client_certificate=*/true));
  ASSERT_TRUE(
      server.Start({"--auth-token-file", tokens_, "--tls-cert", *dir_ + "/server.pem", "--tls-key",
                    *dir_ + "/server.key", "--tls-client-ca", *dir_ + "/ca.pem"}))
      << server.Log();
  grpc::Status status;
  Client no_certificate(server.address(), kWorkerToken, Tls());
  no_certificate.OperationNames(&status);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE) << status.error_message();
  Client with_certificate(server.address(), kWorkerToken, Tls(true));
  with_certificate.OperationNames(&status);
  EXPECT_TRUE(status.ok()) << status.error_message();
}

TEST_F(AuthE2e, WorkerOnlyMutualTlsAsksACertificateOfWorkersAlone) {
  ServerProcess server(test_dir_);
  server.set_health_channel(Tls());
  ASSERT_TRUE(
      server.Start({"--auth-token-file", tokens_, "--tls-cert", *dir_ + "/server.pem", "--tls-key",
                    *dir_ + "/server.key", "--tls-worker-ca", *dir_ + "/ca.pem"}))
      << server.Log();
  const auto lease = [&](const ChannelOptions& channel) {
    Client farm(server.address(), kWorkerToken, channel);
    grpc::ClientContext context;
    Client::Deadline(context);
    v1::LeaseTaskRequest request;
    request.set_worker_id("farm-1");
    v1::LeaseTaskResponse response;
    return farm.workers->LeaseTask(&context, request, &response);
  };

  // A user needs no certificate.
  grpc::Status status;
  Client alice(server.address(), kAliceToken, Tls());
  alice.OperationNames(&status);
  EXPECT_TRUE(status.ok()) << status.error_message();
  // A worker token without one is refused, naming the flag; with one it leases.
  const grpc::Status without = lease(Tls());
  EXPECT_EQ(without.error_code(), grpc::StatusCode::UNAUTHENTICATED) << without.error_message();
  EXPECT_NE(without.error_message().find("--tls-worker-ca"), std::string::npos);
  const grpc::Status with = lease(Tls(/*client_certificate=*/true));
  EXPECT_TRUE(with.ok()) << with.error_message();

  // The two client-CA flags together are refused at start.
  const CommandResult both = testing::RunCommand(
      {testing::BinPath("pf-server"), "--listen", "127.0.0.1:0", "--store",
       "sqlite:" + test_dir_ + "/both.db", "--blobs", test_dir_ + "/both-blobs", "--tls-cert",
       *dir_ + "/server.pem", "--tls-key", *dir_ + "/server.key", "--tls-client-ca",
       *dir_ + "/ca.pem", "--tls-worker-ca", *dir_ + "/ca.pem"});
  EXPECT_NE(both.exit_code, 0);
  EXPECT_NE(both.err.find("--tls-client-ca and --tls-worker-ca"), std::string::npos) << both.err;
}

}  // namespace
}  // namespace pf
