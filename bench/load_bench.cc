// The load benchmark of issue #8: pf-server (SQLite store) and pf-worker
// processes on loopback, one scene reconstructed, then --clients threads
// (default 16), each with its own channel, for --seconds (default 120):
// create a 1-view render job, poll it with GetOperation and GetRenderJob
// every --poll-ms until it is done, and again. Prints one JSON object:
// jobs created and completed per second, p50/p99 latency of each RPC, p50/p99
// job turnaround, and the server's resident memory (VmRSS) after the scene
// was built (start), at the end and at its peak (sampled every 250 ms), with
// whether the end stayed within --rss-bound-mib of the start.
//
// A benchmark, not a test: it asserts nothing about time; it exits 1 only
// when the service could not be set up or no job completed.
//
//   pf_load_bench [--seconds 120] [--clients 16] [--workers 2] [--poll-ms 50]
//                 [--rss-bound-mib 64] [--dir DIR]
#include <google/protobuf/util/json_util.h>
#include <grpcpp/grpcpp.h>
#include <signal.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/remote/clip_upload.h"
#include "common/command_line.h"
#include "common/status_macros.h"
#include "google/longrunning/operations.grpc.pb.h"
#include "pointforward/v1/resources.pb.h"
#include "pointforward/v1/service.grpc.pb.h"
#include "rpc/blob_transfer.h"
#include "rpc/grpc_status.h"
#include "tests/service_harness.h"
#include "tests/test_util.h"

namespace pf {
namespace {

namespace v1 = pointforward::v1;
using google::longrunning::Operation;
using Clock = std::chrono::steady_clock;

struct Options {
  int seconds = 120;
  int clients = 16;
  int workers = 2;
  int poll_ms = 50;
  int rss_bound_mib = 64;
  std::string dir;
};

double MillisSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// VmRSS of process `pid` in KiB, or -1.
int64_t RssKib(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::stoll(line.substr(6));
  }
  return -1;
}

// Latencies (ms) of one kind of call, and its failures.
struct Samples {
  std::vector<double> ms;
  int64_t errors = 0;

  void Merge(const Samples& other) {
    ms.insert(ms.end(), other.ms.begin(), other.ms.end());
    errors += other.errors;
  }

  // {"calls", "errors", "p50_ms", "p99_ms", "max_ms"}.
  nlohmann::json Summary() {
    std::sort(ms.begin(), ms.end());
    const auto at = [&](double q) {
      return ms.empty() ? 0.0 : ms[std::min(ms.size() - 1, static_cast<size_t>(q * ms.size()))];
    };
    const auto round = [](double v) { return std::round(v * 100) / 100; };
    return {{"calls", ms.size()},
            {"errors", errors},
            {"p50_ms", round(at(0.50))},
            {"p99_ms", round(at(0.99))},
            {"max_ms", round(ms.empty() ? 0.0 : ms.back())}};
  }
};

// What one client thread measured.
struct ClientResult {
  Samples create;
  Samples get_operation;
  Samples get_render_job;
  Samples turnaround;  // Create call start to the poll that saw the job done.
  int64_t created = 0;
  int64_t completed = 0;
  int64_t failed = 0;
  int64_t unfinished = 0;  // Still running when the grace period ended.
  std::string first_error;
};

// `count` 1-view render requests: the clip's first camera at each of its frames.
absl::StatusOr<std::vector<v1::RenderViews>> OneViewRequests(const std::string& clip_path) {
  std::ifstream in(clip_path);
  const nlohmann::json clip = nlohmann::json::parse(in, nullptr, false);
  if (clip.is_discarded()) return absl::InvalidArgumentError(clip_path + ": not JSON");
  const nlohmann::json& camera = clip["cameras"][0];
  std::vector<v1::RenderViews> out;
  for (const nlohmann::json& frame : clip["frames"]) {
    if (frame["camera"] != camera["id"]) continue;
    nlohmann::json views;
    views["cameras"] = nlohmann::json::array({camera});
    views["views"] = nlohmann::json::array({{{"camera", camera["id"]},
                                             {"timestampUs", frame["timestampUs"]},
                                             {"worldFromCamera", frame["worldFromCamera"]},
                                             {"name", "view"}}});
    v1::RenderViews message;
    if (!google::protobuf::util::JsonStringToMessage(views.dump(), &message).ok()) {
      return absl::InternalError("views: not a RenderViews message");
    }
    out.push_back(std::move(message));
  }
  if (out.empty()) return absl::InvalidArgumentError(clip_path + ": no frames of the first camera");
  return out;
}

// One client: creates a job, polls it to the end, repeats until `stop_at`;
// the job in flight then gets `grace` to finish.
ClientResult RunClient(const std::string& address, const std::string& scene,
                       const std::vector<v1::RenderViews>& views, int index, int poll_ms,
                       Clock::time_point stop_at, std::chrono::seconds grace) {
  ClientResult result;
  auto channel = MakeChannel(address);
  auto renders = v1::RenderService::NewStub(channel);
  auto operations = google::longrunning::Operations::NewStub(channel);
  const auto note = [&](const grpc::Status& status) {
    if (result.first_error.empty()) {
      result.first_error = absl::StrCat(status.error_code(), ": ", status.error_message());
    }
  };
  for (int64_t n = 0; Clock::now() < stop_at; ++n) {
    v1::CreateRenderJobRequest request;
    request.set_scene(scene);
    *request.mutable_views() = views[(index + n) % views.size()];
    request.set_request_id(absl::StrCat("load-", index, "-", n));
    const auto created_at = Clock::now();
    Operation op;
    {
      grpc::ClientContext context;
      context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
      const grpc::Status status = renders->CreateRenderJob(&context, request, &op);
      if (!status.ok()) {
        ++result.create.errors;
        note(status);
        std::this_thread::sleep_for(std::chrono::milliseconds(poll_ms));
        continue;
      }
      result.create.ms.push_back(MillisSince(created_at));
      ++result.created;
    }
    const std::string job_name =
        absl::StrCat("renderJobs/", op.name().substr(op.name().find('/') + 1));
    bool finished = op.done();
    for (int poll = 0; !finished; ++poll) {
      if (Clock::now() > stop_at + grace) {
        ++result.unfinished;
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(poll_ms));
      grpc::ClientContext context;
      context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
      const auto call_at = Clock::now();
      if (poll % 2 == 0) {
        google::longrunning::GetOperationRequest get;
        get.set_name(op.name());
        const grpc::Status status = operations->GetOperation(&context, get, &op);
        if (!status.ok()) {
          ++result.get_operation.errors;
          note(status);
          continue;
        }
        result.get_operation.ms.push_back(MillisSince(call_at));
        finished = op.done();
        if (finished && op.has_error()) ++result.failed;
      } else {
        v1::GetRenderJobRequest get;
        get.set_name(job_name);
        v1::RenderJob job;
        const grpc::Status status = renders->GetRenderJob(&context, get, &job);
        if (!status.ok()) {
          ++result.get_render_job.errors;
          note(status);
          continue;
        }
        result.get_render_job.ms.push_back(MillisSince(call_at));
        finished = job.state() == v1::RenderJob::SUCCEEDED ||
                   job.state() == v1::RenderJob::FAILED || job.state() == v1::RenderJob::CANCELLED;
        if (finished && job.state() != v1::RenderJob::SUCCEEDED) ++result.failed;
      }
    }
    if (finished) {
      ++result.completed;
      result.turnaround.ms.push_back(MillisSince(created_at));
    }
  }
  return result;
}

absl::StatusOr<Options> ParseOptions(int argc, char** argv) {
  const std::vector<std::string> words(argv + 1, argv + argc);
  ASSIGN_OR_RETURN(CommandLine cl, CommandLine::Parse(words, {"seconds", "clients", "workers",
                                                              "poll-ms", "rss-bound-mib", "dir"}));
  if (!cl.positional().empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("unexpected argument '", cl.positional()[0], "'"));
  }
  Options options;
  const auto int_flag = [&](const std::string& name, int fallback, int min,
                            int max) -> absl::StatusOr<int> {
    ASSIGN_OR_RETURN(const int64_t value, cl.GetInt(name, fallback));
    if (value < min || value > max) {
      return absl::InvalidArgumentError(
          absl::StrCat("--", name, ": must be in [", min, ", ", max, "], got ", value));
    }
    return static_cast<int>(value);
  };
  ASSIGN_OR_RETURN(options.seconds, int_flag("seconds", options.seconds, 1, 86400));
  ASSIGN_OR_RETURN(options.clients, int_flag("clients", options.clients, 1, 1024));
  ASSIGN_OR_RETURN(options.workers, int_flag("workers", options.workers, 1, 16));
  ASSIGN_OR_RETURN(options.poll_ms, int_flag("poll-ms", options.poll_ms, 1, 60000));
  ASSIGN_OR_RETURN(options.rss_bound_mib,
                   int_flag("rss-bound-mib", options.rss_bound_mib, 1, 1 << 20));
  options.dir = cl.Get("dir");
  return options;
}

int Fail(const std::string& message) {
  std::fprintf(stderr, "pf_load_bench: %s\n", message.c_str());
  return 1;
}

int Main(int argc, char** argv) {
  absl::StatusOr<Options> parsed = ParseOptions(argc, argv);
  if (!parsed.ok()) {
    return Fail(absl::StrCat(parsed.status().message(),
                             "\nusage: pf_load_bench [--seconds 120] [--clients 16] [--workers 2] "
                             "[--poll-ms 50] [--rss-bound-mib 64] [--dir DIR]"));
  }
  const Options options = *parsed;
  const std::string dir = options.dir.empty() ? testing::MakeTempDir("pf_load_bench") : options.dir;

  // A small clip and its scene.
  const testing::CommandResult synth =
      testing::RunCommand({testing::BinPath("pf"), "synth", "--out", dir + "/clip", "--width",
                           "192", "--height", "144", "--frames", "6", "--cameras", "2"});
  if (synth.exit_code != 0) return Fail("pf synth: " + synth.err);
  const std::string clip = dir + "/clip/clip.json";
  absl::StatusOr<std::vector<v1::RenderViews>> views = OneViewRequests(clip);
  if (!views.ok()) return Fail(views.status().ToString());

  testing::ServerProcess server(dir);
  if (!server.Start()) return Fail("pf-server did not start:\n" + server.Log());
  const int64_t rss_after_boot = RssKib(server.pid());
  std::vector<std::unique_ptr<testing::WorkerProcess>> workers;
  for (int w = 0; w < options.workers; ++w) {
    workers.push_back(
        std::make_unique<testing::WorkerProcess>(server.address(), dir, absl::StrCat("w", w + 1)));
    if (!workers.back()->Start()) return Fail("pf-worker did not start");
  }
  auto channel = MakeChannel(server.address());
  absl::StatusOr<ClipUploadPlan> plan = PlanClipUpload(clip);
  if (!plan.ok()) return Fail(plan.status().ToString());
  BlobClient blobs(channel, server.address());
  absl::StatusOr<v1::UploadedClip> uploaded = UploadClip(*plan, blobs);
  if (!uploaded.ok()) return Fail(uploaded.status().ToString());
  v1::CreateSceneRequest create;
  *create.mutable_clip()->mutable_uploaded() = *uploaded;
  Operation scene_op;
  {
    grpc::ClientContext context;
    const grpc::Status status =
        v1::SceneService::NewStub(channel)->CreateScene(&context, create, &scene_op);
    if (!status.ok()) return Fail("CreateScene: " + status.error_message());
  }
  auto operations = google::longrunning::Operations::NewStub(channel);
  const auto scene_deadline = Clock::now() + std::chrono::minutes(5);
  while (!scene_op.done() && Clock::now() < scene_deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    grpc::ClientContext context;
    google::longrunning::GetOperationRequest get;
    get.set_name(scene_op.name());
    (void)operations->GetOperation(&context, get, &scene_op);
  }
  if (!scene_op.done() || scene_op.has_error()) {
    return Fail("the scene was not built: " + scene_op.error().message() + "\n" + server.Log());
  }
  v1::Scene scene;
  scene_op.response().UnpackTo(&scene);

  // The load, with the server's memory sampled beside it.
  const int64_t rss_start = RssKib(server.pid());
  std::atomic<bool> sampling{true};
  std::atomic<int64_t> rss_peak{rss_start};
  std::vector<int64_t> rss_every_10s;
  std::thread sampler([&] {
    const auto begin = Clock::now();
    int next_mark = 0;
    while (sampling) {
      const int64_t rss = RssKib(server.pid());
      if (rss > rss_peak) rss_peak = rss;
      if (MillisSince(begin) >= next_mark * 10000.0) {
        rss_every_10s.push_back(rss);
        ++next_mark;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(250));
    }
  });
  const auto load_start = Clock::now();
  const auto stop_at = load_start + std::chrono::seconds(options.seconds);
  std::vector<ClientResult> results(options.clients);
  std::vector<std::thread> clients;
  for (int c = 0; c < options.clients; ++c) {
    clients.emplace_back([&, c] {
      results[c] = RunClient(server.address(), scene.name(), *views, c, options.poll_ms, stop_at,
                             std::chrono::seconds(30));
    });
  }
  for (std::thread& client : clients) client.join();
  const double load_seconds = MillisSince(load_start) / 1000;
  const int64_t rss_end = RssKib(server.pid());
  std::this_thread::sleep_for(std::chrono::seconds(2));
  const int64_t rss_idle = RssKib(server.pid());
  sampling = false;
  sampler.join();

  ClientResult total;
  for (const ClientResult& r : results) {
    total.create.Merge(r.create);
    total.get_operation.Merge(r.get_operation);
    total.get_render_job.Merge(r.get_render_job);
    total.turnaround.Merge(r.turnaround);
    total.created += r.created;
    total.completed += r.completed;
    total.failed += r.failed;
    total.unfinished += r.unfinished;
    if (total.first_error.empty()) total.first_error = r.first_error;
  }
  Samples gets;
  gets.Merge(total.get_operation);
  gets.Merge(total.get_render_job);
  const auto mib = [](int64_t kib) { return std::round(kib / 1024.0 * 10) / 10; };
  const double growth_mib = (rss_end - rss_start) / 1024.0;
  std::vector<double> series_mib;
  for (int64_t kib : rss_every_10s) series_mib.push_back(mib(kib));

  nlohmann::json out;
  out["seconds"] = std::round(load_seconds * 10) / 10;
  out["clients"] = options.clients;
  out["workers"] = options.workers;
  out["poll_ms"] = options.poll_ms;
  out["jobs_created"] = total.created;
  out["jobs_completed"] = total.completed;
  out["jobs_failed"] = total.failed;
  out["jobs_unfinished"] = total.unfinished;
  out["created_per_s"] = std::round(total.created / load_seconds * 10) / 10;
  out["completed_per_s"] = std::round(total.completed / load_seconds * 10) / 10;
  out["create_render_job"] = total.create.Summary();
  out["get_operation"] = total.get_operation.Summary();
  out["get_render_job"] = total.get_render_job.Summary();
  out["get_calls"] = gets.Summary();
  out["get_calls_per_s"] = std::round(gets.ms.size() / load_seconds * 10) / 10;
  out["turnaround"] = total.turnaround.Summary();
  out["server_rss_mib"] = {
      {"after_boot", mib(rss_after_boot)}, {"start", mib(rss_start)}, {"end", mib(rss_end)},
      {"end_idle_2s", mib(rss_idle)},      {"peak", mib(rss_peak)},   {"every_10s", series_mib}};
  out["rss_growth_mib"] = std::round(growth_mib * 10) / 10;
  out["rss_bound_mib"] = options.rss_bound_mib;
  out["rss_bound_held"] = growth_mib <= options.rss_bound_mib;
  if (!total.first_error.empty()) out["first_error"] = total.first_error;
  std::error_code ec;
  out["store_bytes"] = static_cast<int64_t>(std::filesystem::file_size(dir + "/jobs.db", ec));
  std::printf("%s\n", out.dump().c_str());

  for (auto& worker : workers) worker->Kill(SIGTERM);
  server.Kill(SIGTERM);
  return total.completed > 0 ? 0 : 1;
}

}  // namespace
}  // namespace pf

int main(int argc, char** argv) { return pf::Main(argc, argv); }
