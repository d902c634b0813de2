// pf_store_bench: how fast a job store takes render jobs and hands out
// their tasks, with N threads each holding its own store object (as N
// pf-server request threads or N servers would). Prints one JSON object.
//
//   pf_store_bench --store sqlite:/tmp/bench.db --threads 8 --jobs 400 --tasks_per_job 4
//   pf_store_bench --store postgresql://postgres@127.0.0.1:5432/bench --threads 8
//
// Phase 1 (creates): the threads create --jobs render jobs of
// --tasks_per_job chunks on one READY scene; creates_per_s = jobs / s.
// Phase 2 (leases): the threads lease and complete tasks until none is
// queued; leases_per_s = tasks leased (each also completed) / s.
#include <chrono>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "common/command_line.h"
#include "common/elapsed.h"
#include "common/status_macros.h"
#include "server/store/job_store.h"
#include "server/store/postgres_database.h"

namespace pf {
namespace {

int64_t NowMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// Creates scene `scene_id` and runs its reconstruction (and whatever an
// earlier run left queued) to the end.
absl::Status MakeReadyScene(JobStore& store, const std::string& scene_id) {
  ASSIGN_OR_RETURN(
      CreateSceneOutcome outcome,
      store.CreateSceneJob(scene_id, "hash-" + scene_id, "{}", "", "{}", "{}", "bench", NowMs()));
  while (true) {
    ASSIGN_OR_RETURN(SceneRecord scene, store.GetScene(scene_id));
    if (scene.state == SceneState::kReady) return absl::OkStatus();
    ASSIGN_OR_RETURN(std::optional<TaskLease> lease, store.LeaseTask("bench-setup", {}, NowMs()));
    if (!lease) {
      return absl::InternalError(absl::StrCat("scene ", scene_id, " is ",
                                              SceneStateName(scene.state),
                                              " but nothing is left to lease"));
    }
    RETURN_IF_ERROR(store.CompleteTask(lease->task.id, lease->task.attempt, "{}", "{}", NowMs()));
  }
}

// Runs `body(thread_index, store)` on `threads` threads, each with its own
// store; returns the first error.
template <typename Body>
absl::Status RunThreads(const std::string& spec, int threads, const Body& body) {
  std::vector<std::unique_ptr<JobStore>> stores;
  for (int t = 0; t < threads; ++t) {
    ASSIGN_OR_RETURN(std::unique_ptr<JobStore> store, OpenJobStore(spec, {}));
    stores.push_back(std::move(store));
  }
  std::vector<absl::Status> results(threads);
  std::vector<std::thread> workers;
  for (int t = 0; t < threads; ++t) {
    workers.emplace_back([&, t] { results[t] = body(t, *stores[t]); });
  }
  for (std::thread& worker : workers) worker.join();
  for (const absl::Status& status : results) RETURN_IF_ERROR(status);
  return absl::OkStatus();
}

absl::Status Run(const std::vector<std::string>& args) {
  ASSIGN_OR_RETURN(CommandLine cl,
                   CommandLine::Parse(args, {"store", "threads", "jobs", "tasks_per_job"}));
  const std::string spec = cl.Get("store");
  if (spec.empty()) return absl::InvalidArgumentError("--store: required (an OpenJobStore spec)");
  ASSIGN_OR_RETURN(int64_t threads, cl.GetInt("threads", 8));
  ASSIGN_OR_RETURN(int64_t jobs, cl.GetInt("jobs", 400));
  ASSIGN_OR_RETURN(int64_t tasks_per_job, cl.GetInt("tasks_per_job", 4));
  if (threads < 1 || threads > 256) {
    return absl::InvalidArgumentError(absl::StrCat("--threads: 1 to 256, got ", threads));
  }
  if (jobs < threads) {
    return absl::InvalidArgumentError(
        absl::StrCat("--jobs: at least --threads (", threads, "), got ", jobs));
  }
  if (tasks_per_job < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("--tasks_per_job: at least 1, got ", tasks_per_job));
  }

  ASSIGN_OR_RETURN(std::unique_ptr<JobStore> setup, OpenJobStore(spec, {}));
  const std::string scene_id = absl::StrCat("bench-", NowMs());
  RETURN_IF_ERROR(MakeReadyScene(*setup, scene_id));

  std::vector<NewTask> tasks;
  for (int i = 0; i < tasks_per_job; ++i) {
    tasks.push_back(
        {.first_view = i, .view_count = 1, .work = "{\"chunk\":" + std::to_string(i) + "}"});
  }
  auto start = std::chrono::steady_clock::now();
  RETURN_IF_ERROR(RunThreads(spec, threads, [&](int t, JobStore& store) -> absl::Status {
    // Jobs split as evenly as they go.
    const int64_t mine = jobs / threads + (t < jobs % threads ? 1 : 0);
    for (int64_t j = 0; j < mine; ++j) {
      bool same = false;
      RETURN_IF_ERROR(store
                          .CreateRenderJob(scene_id, "", "{}", static_cast<int>(tasks_per_job),
                                           tasks, "bench", NowMs(), &same)
                          .status());
    }
    return absl::OkStatus();
  }));
  const double create_s = SecondsSince(start);

  std::vector<int64_t> leased(threads, 0);
  start = std::chrono::steady_clock::now();
  RETURN_IF_ERROR(RunThreads(spec, threads, [&](int t, JobStore& store) -> absl::Status {
    const std::string worker = absl::StrCat("bench-worker-", t);
    while (true) {
      ASSIGN_OR_RETURN(std::optional<TaskLease> lease,
                       store.LeaseTask(worker, {scene_id}, NowMs()));
      if (!lease) return absl::OkStatus();
      RETURN_IF_ERROR(store.CompleteTask(lease->task.id, lease->task.attempt, "{}", "", NowMs()));
      ++leased[t];
    }
  }));
  const double lease_s = SecondsSince(start);
  int64_t total_leased = 0;
  for (int64_t n : leased) total_leased += n;

  std::printf(
      "{\"store\": \"%s\", \"threads\": %lld, \"jobs\": %lld, \"tasks_per_job\": %lld, "
      "\"create_seconds\": %.3f, \"creates_per_s\": %.1f, \"tasks_leased\": %lld, "
      "\"lease_seconds\": %.3f, \"leases_per_s\": %.1f}\n",
      RedactPostgresConnection(spec).c_str(), static_cast<long long>(threads),
      static_cast<long long>(jobs), static_cast<long long>(tasks_per_job), create_s,
      jobs / create_s, static_cast<long long>(total_leased), lease_s, total_leased / lease_s);
  return absl::OkStatus();
}

}  // namespace
}  // namespace pf

int main(int argc, char** argv) {
  return pf::ExitStatusFor("pf_store_bench",
                           pf::Run(std::vector<std::string>(argv + 1, argv + argc)));
}
