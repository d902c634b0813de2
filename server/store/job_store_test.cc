// The JobStore contract, as one suite parameterised over the backends: each
// test gets a fresh store from the backend's factory. SQLite: a new file;
// PostgreSQL: a new database on one throwaway server per test binary
// (tests/postgres_server.h), skipped where no server can be started.
#include "server/store/job_store.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <functional>
#include <memory>
#include <ostream>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "common/status_macros.h"
#include "server/store/sql_job_store.h"
#include "server/store/sqlite_database.h"
#include "tests/postgres_server.h"
#include "tests/test_util.h"

namespace pf {
namespace {

constexpr int64_t kT0 = 1'700'000'000'000;  // The tests' clock starts here.
constexpr int64_t kLeaseMs = 1000;
constexpr int kMaxAttempts = 3;

struct StoreBackend {
  std::string name;
  // Returns why the backend cannot run on this machine ("" when it can).
  std::function<std::string()> why_unavailable;
  // Returns the OpenJobStore spec of a fresh, empty store; `temp_dir` is
  // the test's own empty directory.
  std::function<absl::StatusOr<std::string>(const std::string& temp_dir)> make_spec;
};

const StoreBackend kBackends[] = {
    {"Sqlite", [] { return std::string(); },
     [](const std::string& dir) -> absl::StatusOr<std::string> {
       return "sqlite:" + dir + "/jobs.db";
     }},
    {"Postgres", [] { return testing::PostgresServer::WhyUnavailable().value_or(""); },
     [](const std::string&) -> absl::StatusOr<std::string> {
       ASSIGN_OR_RETURN(testing::PostgresServer * server, testing::PostgresServer::Shared());
       return server->CreateFreshDatabase();
     }},
};

void PrintTo(const StoreBackend& backend, std::ostream* os) { *os << backend.name; }

class JobStoreTest : public ::testing::TestWithParam<StoreBackend> {
 protected:
  void SetUp() override {
    if (const std::string why = GetParam().why_unavailable(); !why.empty()) GTEST_SKIP() << why;
    absl::StatusOr<std::string> spec = GetParam().make_spec(testing::MakeTempDir("job_store_test"));
    ASSERT_TRUE(spec.ok()) << spec.status();
    spec_ = *spec;
    store_ = Open();
    ASSERT_NE(store_, nullptr);
  }

  // Opens another store object on the same database.
  std::unique_ptr<JobStore> Open() {
    absl::StatusOr<std::unique_ptr<JobStore>> store =
        OpenJobStore(spec_, {.max_attempts = kMaxAttempts, .lease_duration_ms = kLeaseMs});
    EXPECT_TRUE(store.ok()) << store.status();
    return store.ok() ? *std::move(store) : nullptr;
  }

  CreateSceneOutcome CreateScene(const std::string& scene_id, const std::string& request_id = "",
                                 int64_t now_ms = kT0) {
    absl::StatusOr<CreateSceneOutcome> outcome = store_->CreateSceneJob(
        scene_id, "hash-" + scene_id, "{\"name\":\"" + scene_id + "\"}", request_id,
        "{\"request\":\"" + scene_id + "\"}", "{\"work\":\"" + scene_id + "\"}", "alice", now_ms);
    EXPECT_TRUE(outcome.ok()) << outcome.status();
    return outcome.ok() ? *outcome : CreateSceneOutcome{};
  }

  TaskLease Lease(const std::string& worker, const std::vector<std::string>& cached = {},
                  int64_t now_ms = kT0) {
    absl::StatusOr<std::optional<TaskLease>> lease = store_->LeaseTask(worker, cached, now_ms);
    EXPECT_TRUE(lease.ok()) << lease.status();
    EXPECT_TRUE(lease.ok() && lease->has_value()) << "nothing to lease";
    return lease.ok() && lease->has_value() ? **lease : TaskLease{};
  }

  // Creates scene `scene_id` and runs its reconstruction to the end.
  void MakeReadyScene(const std::string& scene_id) {
    CreateScene(scene_id);
    TaskLease lease = Lease("builder");
    ASSERT_EQ(lease.task.scene_id, scene_id);
    ASSERT_TRUE(store_
                    ->CompleteTask(lease.task.id, lease.task.attempt, "{}",
                                   "{\"name\":\"" + scene_id + "\",\"ready\":true}", kT0)
                    .ok());
  }

  // A render job of `chunks` chunks of `views_per_chunk` views each.
  JobRecord CreateRender(const std::string& scene_id, int chunks, int views_per_chunk = 2,
                         const std::string& request_id = "", bool* same_request = nullptr,
                         int64_t now_ms = kT0) {
    std::vector<NewTask> tasks;
    for (int i = 0; i < chunks; ++i) {
      tasks.push_back({.first_view = i * views_per_chunk,
                       .view_count = views_per_chunk,
                       .work = "{\"chunk\":" + std::to_string(i) + "}"});
    }
    bool same = false;
    absl::StatusOr<JobRecord> job =
        store_->CreateRenderJob(scene_id, request_id, "{\"render\":1}", chunks * views_per_chunk,
                                tasks, "bob", now_ms, same_request ? same_request : &same);
    EXPECT_TRUE(job.ok()) << job.status();
    return job.ok() ? *job : JobRecord{};
  }

  JobRecord Job(const std::string& job_id) {
    absl::StatusOr<JobRecord> job = store_->GetJob(job_id);
    EXPECT_TRUE(job.ok()) << job.status();
    return job.ok() ? *job : JobRecord{};
  }

  std::vector<TaskRecord> Tasks(const std::string& job_id) {
    absl::StatusOr<std::vector<TaskRecord>> tasks = store_->ListTasks(job_id);
    EXPECT_TRUE(tasks.ok()) << tasks.status();
    return tasks.ok() ? *tasks : std::vector<TaskRecord>{};
  }

  TaskRecord Task(const std::string& task_id) {
    absl::StatusOr<TaskRecord> task = store_->GetTask(task_id);
    EXPECT_TRUE(task.ok()) << task.status();
    return task.ok() ? *task : TaskRecord{};
  }

  SceneRecord Scene(const std::string& scene_id) {
    absl::StatusOr<SceneRecord> scene = store_->GetScene(scene_id);
    EXPECT_TRUE(scene.ok()) << scene.status();
    return scene.ok() ? *scene : SceneRecord{};
  }

  int Expire(int64_t now_ms) {
    absl::StatusOr<int> expired = store_->ExpireLeases(now_ms);
    EXPECT_TRUE(expired.ok()) << expired.status();
    return expired.ok() ? *expired : -1;
  }

  // Returns what a heartbeat of (task, attempt) answers: true to stop.
  bool HeartbeatSaysStop(const std::string& task_id, int attempt, int64_t now_ms) {
    absl::StatusOr<bool> stop = store_->Heartbeat(task_id, attempt, "x", 0.1, 0, now_ms, nullptr);
    EXPECT_TRUE(stop.ok()) << stop.status();
    return stop.ok() && *stop;
  }

  int Queued(JobKind kind) {
    absl::StatusOr<int> count = store_->CountQueuedTasks(kind);
    EXPECT_TRUE(count.ok()) << count.status();
    return count.ok() ? *count : -1;
  }

  bool NothingToLease() {
    absl::StatusOr<std::optional<TaskLease>> lease = store_->LeaseTask("idle", {}, kT0);
    return lease.ok() && !lease->has_value();
  }

  std::string spec_;
  std::unique_ptr<JobStore> store_;
};

// -- CreateSceneJob ----------------------------------------------------------------

TEST_P(JobStoreTest, CreateSceneJobCreatesSceneJobAndQueuedTask) {
  CreateSceneOutcome outcome = CreateScene("s1", "req-1");
  EXPECT_EQ(outcome.kind, CreateSceneOutcome::Kind::kCreated);
  EXPECT_EQ(outcome.job.id.size(), 16u);
  EXPECT_EQ(outcome.job.id.find_first_not_of("0123456789abcdef"), std::string::npos);
  EXPECT_EQ(outcome.job.kind, JobKind::kReconstruct);
  EXPECT_EQ(outcome.job.state, JobState::kQueued);
  EXPECT_EQ(outcome.job.request_id, "req-1");
  EXPECT_EQ(outcome.job.scene_id, "s1");
  EXPECT_EQ(outcome.job.request, "{\"request\":\"s1\"}");
  EXPECT_EQ(outcome.job.owner, "alice");
  EXPECT_EQ(outcome.job.tasks_total, 1);
  EXPECT_EQ(outcome.job.create_time_ms, kT0);
  EXPECT_EQ(outcome.scene.id, "s1");
  EXPECT_EQ(outcome.scene.state, SceneState::kCreating);
  EXPECT_EQ(outcome.scene.job_id, outcome.job.id);
  EXPECT_EQ(outcome.scene.content_hash, "hash-s1");
  EXPECT_EQ(outcome.scene.description, "{\"name\":\"s1\"}");

  std::vector<TaskRecord> tasks = Tasks(outcome.job.id);
  ASSERT_EQ(tasks.size(), 1u);
  EXPECT_EQ(tasks[0].state, TaskState::kQueued);
  EXPECT_EQ(tasks[0].kind, JobKind::kReconstruct);
  EXPECT_EQ(tasks[0].work, "{\"work\":\"s1\"}");
  EXPECT_EQ(tasks[0].attempt, 0);
  EXPECT_EQ(Queued(JobKind::kReconstruct), 1);
  EXPECT_EQ(Queued(JobKind::kRender), 0);

  absl::StatusOr<SceneRecord> scene = store_->GetScene("s1");
  ASSERT_TRUE(scene.ok()) << scene.status();
  EXPECT_EQ(scene->state, SceneState::kCreating);
  EXPECT_EQ(store_->GetScene("nope").status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(store_->GetJob("nope").status().code(), absl::StatusCode::kNotFound);
}

TEST_P(JobStoreTest, CreateSceneJobJoinsSceneBeingCreated) {
  CreateSceneOutcome first = CreateScene("s1", "req-1");
  CreateSceneOutcome second = CreateScene("s1", "req-2");
  EXPECT_EQ(second.kind, CreateSceneOutcome::Kind::kJoined);
  EXPECT_EQ(second.job.id, first.job.id);
  EXPECT_EQ(second.scene.state, SceneState::kCreating);
  EXPECT_EQ(Queued(JobKind::kReconstruct), 1);
}

TEST_P(JobStoreTest, CreateSceneJobIsCacheHitOnceReady) {
  CreateSceneOutcome first = CreateScene("s1");
  TaskLease lease = Lease("w1");
  ASSERT_TRUE(store_->CompleteTask(lease.task.id, 1, "{\"ok\":1}", "{\"final\":1}", kT0 + 5).ok());

  CreateSceneOutcome again = CreateScene("s1", "", kT0 + 10);
  EXPECT_EQ(again.kind, CreateSceneOutcome::Kind::kCacheHit);
  EXPECT_EQ(again.job.id, first.job.id);
  EXPECT_EQ(again.job.state, JobState::kSucceeded);
  EXPECT_EQ(again.job.fraction, 1.0);
  EXPECT_EQ(again.scene.state, SceneState::kReady);
  EXPECT_EQ(again.scene.description, "{\"final\":1}");
  EXPECT_EQ(again.scene.update_time_ms, kT0 + 5);
  EXPECT_EQ(Queued(JobKind::kReconstruct), 0);
  EXPECT_EQ(Tasks(first.job.id)[0].result, "{\"ok\":1}");
}

TEST_P(JobStoreTest, CreateSceneJobWithSeenRequestIdReturnsThatJob) {
  CreateSceneOutcome first = CreateScene("s1", "req-1");
  // Even naming another scene: the request id decides.
  CreateSceneOutcome again = CreateScene("s2", "req-1");
  EXPECT_EQ(again.kind, CreateSceneOutcome::Kind::kSameRequest);
  EXPECT_EQ(again.job.id, first.job.id);
  EXPECT_EQ(again.scene.id, "s1");
  EXPECT_EQ(store_->GetScene("s2").status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(Queued(JobKind::kReconstruct), 1);
}

TEST_P(JobStoreTest, CreateSceneJobRetriesFailedScene) {
  CreateSceneOutcome first = CreateScene("s1");
  TaskLease lease = Lease("w1");
  ASSERT_TRUE(store_->FailTask(lease.task.id, 1, "bad clip", /*permanent=*/true, kT0).ok());
  ASSERT_EQ(Scene("s1").state, SceneState::kFailed);

  CreateSceneOutcome retry = CreateScene("s1", "", kT0 + 1);
  EXPECT_EQ(retry.kind, CreateSceneOutcome::Kind::kCreated);
  EXPECT_NE(retry.job.id, first.job.id);
  EXPECT_EQ(retry.job.state, JobState::kQueued);
  EXPECT_EQ(retry.scene.state, SceneState::kCreating);
  EXPECT_EQ(retry.scene.job_id, retry.job.id);
  EXPECT_EQ(retry.scene.error, "");
  EXPECT_EQ(retry.scene.create_time_ms, kT0);
  EXPECT_EQ(Job(first.job.id).state, JobState::kFailed);
  EXPECT_EQ(Lease("w2").task.job_id, retry.job.id);
}

// -- Render jobs --------------------------------------------------------------------

TEST_P(JobStoreTest, RenderJobOnReadySceneIsQueued) {
  MakeReadyScene("s1");
  bool same = true;
  JobRecord job = CreateRender("s1", 3, 2, "render-1", &same);
  EXPECT_FALSE(same);
  EXPECT_EQ(job.kind, JobKind::kRender);
  EXPECT_EQ(job.state, JobState::kQueued);
  EXPECT_EQ(job.frames_total, 6);
  EXPECT_EQ(job.tasks_total, 3);
  EXPECT_EQ(job.frames_done, 0);
  EXPECT_EQ(job.owner, "bob");
  std::vector<TaskRecord> tasks = Tasks(job.id);
  ASSERT_EQ(tasks.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(tasks[i].index, i);
    EXPECT_EQ(tasks[i].state, TaskState::kQueued);
    EXPECT_EQ(tasks[i].first_view, 2 * i);
    EXPECT_EQ(tasks[i].view_count, 2);
    EXPECT_EQ(tasks[i].scene_id, "s1");
    EXPECT_EQ(tasks[i].work, "{\"chunk\":" + std::to_string(i) + "}");
  }
  EXPECT_EQ(Queued(JobKind::kRender), 3);

  JobRecord again = CreateRender("s1", 3, 2, "render-1", &same);
  EXPECT_TRUE(same);
  EXPECT_EQ(again.id, job.id);
  EXPECT_EQ(Queued(JobKind::kRender), 3);
}

TEST_P(JobStoreTest, RenderJobWaitsForSceneThenQueues) {
  CreateSceneOutcome scene = CreateScene("s1");
  JobRecord job = CreateRender("s1", 2);
  EXPECT_EQ(job.state, JobState::kWaitingForScene);
  for (const TaskRecord& task : Tasks(job.id)) EXPECT_EQ(task.state, TaskState::kWaitingForScene);
  EXPECT_EQ(Queued(JobKind::kRender), 0);

  TaskLease lease = Lease("w1");
  EXPECT_EQ(lease.task.job_id, scene.job.id);  // Waiting tasks are not leased.
  EXPECT_TRUE(NothingToLease());
  ASSERT_TRUE(store_->CompleteTask(lease.task.id, 1, "{}", "{\"ready\":1}", kT0 + 3).ok());

  JobRecord queued = Job(job.id);
  EXPECT_EQ(queued.state, JobState::kQueued);
  EXPECT_EQ(queued.update_time_ms, kT0 + 3);
  for (const TaskRecord& task : Tasks(job.id)) EXPECT_EQ(task.state, TaskState::kQueued);
  EXPECT_EQ(Queued(JobKind::kRender), 2);
}

TEST_P(JobStoreTest, RenderJobFailsWhenItsSceneFails) {
  CreateScene("s1");
  JobRecord job = CreateRender("s1", 2);
  TaskLease lease = Lease("w1");
  ASSERT_TRUE(store_->FailTask(lease.task.id, 1, "no frames", /*permanent=*/true, kT0 + 2).ok());

  JobRecord failed = Job(job.id);
  EXPECT_EQ(failed.state, JobState::kFailed);
  EXPECT_EQ(failed.error_code, static_cast<int>(absl::StatusCode::kFailedPrecondition));
  EXPECT_EQ(failed.error_message,
            "scene s1 could not be created: reconstruction failed permanently after 1 attempt: "
            "attempt 1 on worker w1: failed: no frames");
  for (const TaskRecord& task : Tasks(job.id)) EXPECT_EQ(task.state, TaskState::kCancelled);
  EXPECT_EQ(Queued(JobKind::kRender), 0);
}

TEST_P(JobStoreTest, RenderJobNeedsAnExistingSceneThatDidNotFail) {
  bool same = false;
  std::vector<NewTask> tasks = {{.first_view = 0, .view_count = 1, .work = "{}"}};
  absl::StatusOr<JobRecord> absent =
      store_->CreateRenderJob("nope", "", "{}", 1, tasks, "", kT0, &same);
  EXPECT_EQ(absent.status().code(), absl::StatusCode::kNotFound);
  EXPECT_NE(std::string(absent.status().message()).find("nope"), std::string::npos);

  CreateScene("s1");
  TaskLease lease = Lease("w1");
  ASSERT_TRUE(store_->FailTask(lease.task.id, 1, "bad", /*permanent=*/true, kT0).ok());
  absl::StatusOr<JobRecord> failed =
      store_->CreateRenderJob("s1", "", "{}", 1, tasks, "", kT0, &same);
  EXPECT_EQ(failed.status().code(), absl::StatusCode::kFailedPrecondition);

  MakeReadyScene("s2");
  EXPECT_EQ(store_->CreateRenderJob("s2", "", "{}", 2, tasks, "", kT0, &same).status().code(),
            absl::StatusCode::kInvalidArgument);  // frames_total does not match the tasks.
  EXPECT_EQ(store_->CreateRenderJob("s2", "", "{}", 0, {}, "", kT0, &same).status().code(),
            absl::StatusCode::kInvalidArgument);
}

// -- Leasing ------------------------------------------------------------------------

TEST_P(JobStoreTest, LeasesOldestQueuedTaskFirst) {
  MakeReadyScene("s1");
  JobRecord first = CreateRender("s1", 2);
  CreateSceneOutcome recon = CreateScene("s2");
  JobRecord second = CreateRender("s1", 1);

  EXPECT_EQ(Lease("w").task.id, Tasks(first.id)[0].id);
  EXPECT_EQ(Lease("w").task.id, Tasks(first.id)[1].id);
  EXPECT_EQ(Lease("w").task.job_id, recon.job.id);
  EXPECT_EQ(Lease("w").task.job_id, second.id);
  EXPECT_TRUE(NothingToLease());
}

TEST_P(JobStoreTest, LeasePrefersRenderTasksOfCachedScenes) {
  MakeReadyScene("s1");
  MakeReadyScene("s2");
  CreateSceneOutcome recon = CreateScene("s3");
  JobRecord on_s1 = CreateRender("s1", 1);
  JobRecord on_s2 = CreateRender("s2", 1);

  // A reconstruction is not "cached" even if its scene is named.
  EXPECT_EQ(Lease("w", {"s3", "s2"}).task.job_id, on_s2.id);
  EXPECT_EQ(Lease("w", {"s2"}).task.job_id, recon.job.id);  // None cached left: oldest.
  EXPECT_EQ(Lease("w", {"s2"}).task.job_id, on_s1.id);
  EXPECT_TRUE(NothingToLease());
}

TEST_P(JobStoreTest, LeaseStartsAnAttemptAndRunsTheJob) {
  MakeReadyScene("s1");
  JobRecord job = CreateRender("s1", 2);
  TaskLease lease = Lease("w1", {}, kT0 + 100);
  EXPECT_EQ(lease.task.state, TaskState::kLeased);
  EXPECT_EQ(lease.task.attempt, 1);
  EXPECT_EQ(lease.task.worker_id, "w1");
  EXPECT_EQ(lease.task.lease_deadline_ms, kT0 + 100 + kLeaseMs);
  ASSERT_EQ(lease.task.attempts.size(), 1u);
  EXPECT_EQ(lease.task.attempts[0].number, 1);
  EXPECT_EQ(lease.task.attempts[0].worker_id, "w1");
  EXPECT_EQ(lease.task.attempts[0].outcome, "running");
  EXPECT_EQ(lease.task.attempts[0].start_ms, kT0 + 100);
  EXPECT_EQ(lease.task.attempts[0].end_ms, 0);
  EXPECT_EQ(lease.job.id, job.id);
  EXPECT_EQ(lease.job.state, JobState::kRunning);
  EXPECT_EQ(Job(job.id).state, JobState::kRunning);
  EXPECT_EQ(Queued(JobKind::kRender), 1);

  absl::StatusOr<TaskRecord> task = store_->GetTask(lease.task.id);
  ASSERT_TRUE(task.ok()) << task.status();
  EXPECT_EQ(task->state, TaskState::kLeased);
  EXPECT_EQ(task->attempts.size(), 1u);
  EXPECT_EQ(store_->GetTask("nope").status().code(), absl::StatusCode::kNotFound);
}

TEST_P(JobStoreTest, CompletingEveryTaskSucceedsTheJob) {
  MakeReadyScene("s1");
  JobRecord job = CreateRender("s1", 2);
  TaskLease a = Lease("w1");
  TaskLease b = Lease("w2");
  ASSERT_TRUE(store_->CompleteTask(a.task.id, 1, "{\"a\":1}", "", kT0 + 1).ok());
  EXPECT_EQ(Job(job.id).state, JobState::kRunning);
  ASSERT_TRUE(store_->CompleteTask(b.task.id, 1, "{\"b\":1}", "", kT0 + 2).ok());
  JobRecord done = Job(job.id);
  EXPECT_EQ(done.state, JobState::kSucceeded);
  EXPECT_EQ(done.tasks_done, 2);
  EXPECT_EQ(done.frames_done, 4);
  EXPECT_EQ(done.fraction, 1.0);
  EXPECT_EQ(done.update_time_ms, kT0 + 2);
  std::vector<TaskRecord> tasks = Tasks(job.id);
  EXPECT_EQ(tasks[1].result, "{\"b\":1}");
  EXPECT_EQ(tasks[1].attempts[0].outcome, "succeeded");
  EXPECT_EQ(tasks[1].attempts[0].end_ms, kT0 + 2);
  // A completed task cannot be completed again.
  EXPECT_EQ(store_->CompleteTask(a.task.id, 1, "{}", "", kT0 + 3).code(),
            absl::StatusCode::kFailedPrecondition);
}

TEST_P(JobStoreTest, HeartbeatExtendsLeaseAndAggregatesProgress) {
  MakeReadyScene("s1");
  JobRecord job = CreateRender("s1", 3, 2);  // 6 frames.
  TaskLease first = Lease("w1");
  ASSERT_TRUE(store_->CompleteTask(first.task.id, 1, "{}", "", kT0).ok());
  TaskLease second = Lease("w2");

  int64_t deadline = 0;
  absl::StatusOr<bool> cancelled =
      store_->Heartbeat(second.task.id, 1, "rasterizing", 0.5, 1, kT0 + 700, &deadline);
  ASSERT_TRUE(cancelled.ok()) << cancelled.status();
  EXPECT_FALSE(*cancelled);
  EXPECT_EQ(deadline, kT0 + 700 + kLeaseMs);

  JobRecord progress = Job(job.id);
  EXPECT_EQ(progress.frames_done, 3);  // 2 of the done chunk + 1 reported.
  EXPECT_DOUBLE_EQ(progress.fraction, 0.5);
  EXPECT_EQ(progress.stage, "rasterizing");
  EXPECT_EQ(progress.tasks_done, 1);
  EXPECT_EQ(progress.tasks_total, 3);
  TaskRecord task = Task(second.task.id);
  EXPECT_EQ(task.lease_deadline_ms, kT0 + 700 + kLeaseMs);
  EXPECT_EQ(task.frames_done, 1);
  EXPECT_DOUBLE_EQ(task.fraction, 0.5);

  // The extended lease outlives the original deadline.
  EXPECT_EQ(Expire(kT0 + kLeaseMs + 500), 0);
  EXPECT_EQ(Expire(kT0 + 700 + kLeaseMs + 1), 1);
}

TEST_P(JobStoreTest, ReconstructionProgressIsItsTaskFraction) {
  CreateSceneOutcome scene = CreateScene("s1");
  TaskLease lease = Lease("w1");
  ASSERT_TRUE(store_->Heartbeat(lease.task.id, 1, "training", 0.25, 0, kT0 + 1, nullptr).ok());
  JobRecord job = Job(scene.job.id);
  EXPECT_DOUBLE_EQ(job.fraction, 0.25);
  EXPECT_EQ(job.stage, "training");
  ASSERT_TRUE(store_->Heartbeat(lease.task.id, 1, "exporting", 0.9, 0, kT0 + 2, nullptr).ok());
  job = Job(scene.job.id);
  EXPECT_DOUBLE_EQ(job.fraction, 0.9);
  EXPECT_EQ(job.stage, "exporting");
}

TEST_P(JobStoreTest, StaleAttemptIsRefusedAndChangesNothing) {
  MakeReadyScene("s1");
  CreateRender("s1", 1);
  TaskLease old = Lease("w1");
  ASSERT_EQ(Expire(kT0 + kLeaseMs + 1), 1);
  TaskLease current = Lease("w2", {}, kT0 + kLeaseMs + 2);
  ASSERT_EQ(current.task.id, old.task.id);
  EXPECT_EQ(current.task.attempt, 2);

  EXPECT_EQ(store_->Heartbeat(old.task.id, 1, "late", 0.9, 2, kT0 + 2000, nullptr).status().code(),
            absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(store_->CompleteTask(old.task.id, 1, "{\"stale\":1}", "", kT0 + 2000).code(),
            absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(store_->FailTask(old.task.id, 1, "late", true, kT0 + 2000).code(),
            absl::StatusCode::kFailedPrecondition);

  absl::StatusOr<TaskRecord> task = store_->GetTask(old.task.id);
  ASSERT_TRUE(task.ok());
  EXPECT_EQ(task->state, TaskState::kLeased);
  EXPECT_EQ(task->attempt, 2);
  EXPECT_EQ(task->worker_id, "w2");
  EXPECT_EQ(task->result, "");
  EXPECT_EQ(task->stage, "");
  EXPECT_EQ(task->lease_deadline_ms, kT0 + kLeaseMs + 2 + kLeaseMs);
  ASSERT_EQ(task->attempts.size(), 2u);
  EXPECT_EQ(task->attempts[0].outcome, "lease expired");
  EXPECT_EQ(task->attempts[0].end_ms, kT0 + kLeaseMs + 1);
  EXPECT_EQ(task->attempts[1].outcome, "running");
  EXPECT_EQ(Job(current.job.id).state, JobState::kRunning);

  EXPECT_TRUE(store_->CompleteTask(old.task.id, 2, "{\"fresh\":1}", "", kT0 + 2000).ok());
  EXPECT_EQ(Task(old.task.id).result, "{\"fresh\":1}");
}

TEST_P(JobStoreTest, ExpiredLeasesRequeueUntilAttemptsRunOut) {
  MakeReadyScene("s1");
  JobRecord job = CreateRender("s1", 3, 2);
  for (int i = 0; i < 2; ++i) {
    TaskLease lease = Lease("w0");
    ASSERT_TRUE(store_->CompleteTask(lease.task.id, 1, "{}", "", kT0).ok());
  }
  int64_t now = kT0;
  TaskLease first = Lease("w1", {}, now);
  ASSERT_TRUE(store_->Heartbeat(first.task.id, 1, "rasterizing", 0.5, 1, now, nullptr).ok());
  EXPECT_EQ(Job(job.id).frames_done, 5);
  EXPECT_EQ(Expire(now + kLeaseMs), 0);  // Not yet passed.
  EXPECT_EQ(Expire(now + kLeaseMs + 1), 1);
  TaskRecord requeued = Task(first.task.id);
  EXPECT_EQ(requeued.state, TaskState::kQueued);
  EXPECT_EQ(requeued.worker_id, "");
  EXPECT_EQ(requeued.frames_done, 0);  // The expired attempt's progress is dropped.
  EXPECT_EQ(requeued.fraction, 0.0);
  EXPECT_EQ(Job(job.id).frames_done, 4);
  EXPECT_EQ(Queued(JobKind::kRender), 1);

  now += 2 * kLeaseMs;
  TaskLease second = Lease("w2", {}, now);
  EXPECT_EQ(second.task.id, first.task.id);
  EXPECT_EQ(second.task.attempt, 2);
  ASSERT_TRUE(store_->FailTask(second.task.id, 2, "out of memory", false, now + 5).ok());
  EXPECT_EQ(Job(job.id).state, JobState::kRunning);

  now += 2 * kLeaseMs;
  TaskLease third = Lease("w3", {}, now);
  EXPECT_EQ(third.task.attempt, 3);
  EXPECT_EQ(Expire(now + kLeaseMs + 1), 1);

  JobRecord failed = Job(job.id);
  EXPECT_EQ(failed.state, JobState::kFailed);
  EXPECT_EQ(failed.error_code, static_cast<int>(absl::StatusCode::kAborted));
  EXPECT_EQ(failed.error_message,
            "chunk 2 (views 4-5) failed after 3 attempts: attempt 1 on worker w1: lease expired; "
            "attempt 2 on worker w2: failed: out of memory; attempt 3 on worker w3: lease expired");
  EXPECT_EQ(Task(first.task.id).state, TaskState::kFailed);
  EXPECT_EQ(Queued(JobKind::kRender), 0);
  EXPECT_TRUE(NothingToLease());
}

TEST_P(JobStoreTest, PermanentFailureFailsTheJobAtOnce) {
  MakeReadyScene("s1");
  JobRecord job = CreateRender("s1", 3, 1);
  TaskLease bad = Lease("w1");
  TaskLease other = Lease("w2");
  ASSERT_TRUE(store_->FailTask(bad.task.id, 1, "view 0 has no camera", true, kT0 + 9).ok());

  JobRecord failed = Job(job.id);
  EXPECT_EQ(failed.state, JobState::kFailed);
  EXPECT_EQ(failed.error_code, static_cast<int>(absl::StatusCode::kInvalidArgument));
  EXPECT_EQ(failed.error_message,
            "chunk 0 (view 0) failed permanently after 1 attempt: attempt 1 on worker w1: "
            "failed: view 0 has no camera");
  std::vector<TaskRecord> tasks = Tasks(job.id);
  EXPECT_EQ(tasks[0].state, TaskState::kFailed);
  EXPECT_EQ(tasks[1].state, TaskState::kCancelled);
  EXPECT_EQ(tasks[1].attempts[0].outcome, "cancelled");
  EXPECT_EQ(tasks[2].state, TaskState::kCancelled);
  // The holder of the other chunk is told to stop.
  EXPECT_TRUE(HeartbeatSaysStop(other.task.id, 1, kT0 + 10));
  EXPECT_TRUE(NothingToLease());
}

TEST_P(JobStoreTest, PermanentReconstructionFailureFailsTheScene) {
  CreateScene("s1");
  TaskLease lease = Lease("w1");
  ASSERT_TRUE(store_->FailTask(lease.task.id, 1, "clip has no frames", true, kT0).ok());
  SceneRecord scene = Scene("s1");
  EXPECT_EQ(scene.state, SceneState::kFailed);
  EXPECT_EQ(scene.error,
            "reconstruction failed permanently after 1 attempt: attempt 1 on worker w1: "
            "failed: clip has no frames");
}

// -- Cancelling and deleting --------------------------------------------------------

TEST_P(JobStoreTest, CancelJobCancelsQueuedAndLeasedTasks) {
  MakeReadyScene("s1");
  JobRecord job = CreateRender("s1", 3);
  TaskLease leased = Lease("w1");

  absl::StatusOr<JobRecord> cancelled = store_->CancelJob(job.id, kT0 + 50);
  ASSERT_TRUE(cancelled.ok()) << cancelled.status();
  EXPECT_EQ(cancelled->state, JobState::kCancelled);
  EXPECT_EQ(cancelled->error_code, static_cast<int>(absl::StatusCode::kCancelled));
  EXPECT_EQ(cancelled->update_time_ms, kT0 + 50);
  std::vector<TaskRecord> tasks = Tasks(job.id);
  for (const TaskRecord& task : tasks) EXPECT_EQ(task.state, TaskState::kCancelled);
  EXPECT_EQ(tasks[0].attempts[0].outcome, "cancelled");
  EXPECT_EQ(tasks[0].attempts[0].end_ms, kT0 + 50);
  EXPECT_EQ(Queued(JobKind::kRender), 0);
  EXPECT_TRUE(NothingToLease());

  // The worker learns at its heartbeat; its result is refused.
  EXPECT_TRUE(HeartbeatSaysStop(leased.task.id, 1, kT0 + 60));
  EXPECT_EQ(store_->CompleteTask(leased.task.id, 1, "{}", "", kT0 + 70).code(),
            absl::StatusCode::kFailedPrecondition);

  // Cancelling an ended job changes nothing.
  absl::StatusOr<JobRecord> again = store_->CancelJob(job.id, kT0 + 90);
  ASSERT_TRUE(again.ok()) << again.status();
  EXPECT_EQ(again->state, JobState::kCancelled);
  EXPECT_EQ(again->update_time_ms, kT0 + 50);
  EXPECT_EQ(store_->CancelJob("nope", kT0).status().code(), absl::StatusCode::kNotFound);
}

TEST_P(JobStoreTest, CancelledReconstructionFailsSceneAndWaitingRenders) {
  CreateSceneOutcome scene = CreateScene("s1");
  JobRecord render = CreateRender("s1", 2);
  ASSERT_TRUE(store_->CancelJob(scene.job.id, kT0 + 1).ok());

  EXPECT_EQ(Job(scene.job.id).state, JobState::kCancelled);
  SceneRecord failed = Scene("s1");
  EXPECT_EQ(failed.state, SceneState::kFailed);
  EXPECT_EQ(failed.error, "cancelled");
  JobRecord waiting = Job(render.id);
  EXPECT_EQ(waiting.state, JobState::kFailed);
  EXPECT_EQ(waiting.error_code, static_cast<int>(absl::StatusCode::kFailedPrecondition));
  EXPECT_EQ(waiting.error_message, "scene s1 could not be created: cancelled");
  EXPECT_TRUE(NothingToLease());
}

TEST_P(JobStoreTest, DeleteSceneRemovesItAndCancelsItsCreation) {
  MakeReadyScene("ready");
  ASSERT_TRUE(store_->DeleteScene("ready", kT0).ok());
  EXPECT_EQ(store_->GetScene("ready").status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(store_->DeleteScene("ready", kT0).code(), absl::StatusCode::kNotFound);

  CreateSceneOutcome creating = CreateScene("creating");
  JobRecord render = CreateRender("creating", 1);
  ASSERT_TRUE(store_->DeleteScene("creating", kT0 + 1).ok());
  EXPECT_EQ(store_->GetScene("creating").status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(Job(creating.job.id).state, JobState::kCancelled);
  EXPECT_EQ(Job(render.id).state, JobState::kFailed);
  EXPECT_TRUE(NothingToLease());

  // The scene can be created afresh.
  EXPECT_EQ(CreateScene("creating").kind, CreateSceneOutcome::Kind::kCreated);
}

// -- Listing ----------------------------------------------------------------------

TEST_P(JobStoreTest, ListsPageNewestFirst) {
  std::vector<std::string> job_ids;
  for (int i = 0; i < 7; ++i) {
    job_ids.push_back(CreateScene("s" + std::to_string(i), "", kT0 + i).job.id);
  }
  std::vector<std::string> scene_ids;
  std::string token;
  std::vector<size_t> page_sizes;
  do {
    absl::StatusOr<Page<SceneRecord>> page = store_->ListScenes(3, token);
    ASSERT_TRUE(page.ok()) << page.status();
    page_sizes.push_back(page->items.size());
    for (const SceneRecord& scene : page->items) scene_ids.push_back(scene.id);
    token = page->next_page_token;
  } while (!token.empty());
  EXPECT_EQ(page_sizes, (std::vector<size_t>{3, 3, 1}));
  EXPECT_EQ(scene_ids, (std::vector<std::string>{"s6", "s5", "s4", "s3", "s2", "s1", "s0"}));

  std::vector<std::string> listed;
  page_sizes.clear();
  do {
    absl::StatusOr<Page<JobRecord>> page = store_->ListJobs(JobKind::kReconstruct, 3, token);
    ASSERT_TRUE(page.ok()) << page.status();
    page_sizes.push_back(page->items.size());
    for (const JobRecord& job : page->items) listed.push_back(job.id);
    token = page->next_page_token;
  } while (!token.empty());
  EXPECT_EQ(page_sizes, (std::vector<size_t>{3, 3, 1}));
  std::reverse(job_ids.begin(), job_ids.end());
  EXPECT_EQ(listed, job_ids);

  absl::StatusOr<Page<JobRecord>> renders = store_->ListJobs(JobKind::kRender, 3, "");
  ASSERT_TRUE(renders.ok()) << renders.status();
  EXPECT_TRUE(renders->items.empty());
  absl::StatusOr<Page<JobRecord>> all = store_->ListJobs(std::nullopt, 7, "");
  ASSERT_TRUE(all.ok()) << all.status();
  EXPECT_EQ(all->items.size(), 7u);
  EXPECT_EQ(all->next_page_token, "");  // Exactly one full page.
  EXPECT_EQ(store_->ListJobs(std::nullopt, 3, "garbage").status().code(),
            absl::StatusCode::kInvalidArgument);
  // A scenes token is not a jobs token.
  absl::StatusOr<Page<SceneRecord>> scenes = store_->ListScenes(3, "");
  ASSERT_TRUE(scenes.ok()) << scenes.status();
  const std::string scenes_token = scenes->next_page_token;
  ASSERT_FALSE(scenes_token.empty());
  EXPECT_EQ(store_->ListJobs(std::nullopt, 3, scenes_token).status().code(),
            absl::StatusCode::kInvalidArgument);
}

// -- Durability and concurrency ---------------------------------------------------

TEST_P(JobStoreTest, ReopenedStoreHasEverythingAndLeasingContinues) {
  MakeReadyScene("s1");
  JobRecord job = CreateRender("s1", 2, 2, "render-1");
  TaskLease first = Lease("w1");
  ASSERT_TRUE(store_->Heartbeat(first.task.id, 1, "rasterizing", 0.5, 1, kT0 + 1, nullptr).ok());
  store_.reset();

  store_ = Open();
  ASSERT_NE(store_, nullptr);
  EXPECT_EQ(Scene("s1").state, SceneState::kReady);
  JobRecord reopened = Job(job.id);
  EXPECT_EQ(reopened.state, JobState::kRunning);
  EXPECT_EQ(reopened.frames_done, 1);
  EXPECT_EQ(reopened.stage, "rasterizing");
  EXPECT_EQ(reopened.request_id, "render-1");
  bool same = false;
  EXPECT_EQ(CreateRender("s1", 2, 2, "render-1", &same).id, job.id);
  EXPECT_TRUE(same);

  TaskLease second = Lease("w2");
  EXPECT_EQ(second.task.id, Tasks(job.id)[1].id);
  EXPECT_TRUE(store_->CompleteTask(first.task.id, 1, "{}", "", kT0 + 2).ok());
  EXPECT_TRUE(store_->CompleteTask(second.task.id, 1, "{}", "", kT0 + 3).ok());
  EXPECT_EQ(Job(job.id).state, JobState::kSucceeded);
}

TEST_P(JobStoreTest, ConcurrentLeasingHandsOutEachTaskOnce) {
  constexpr int kTasks = 50;
  constexpr int kThreads = 8;
  MakeReadyScene("s1");
  JobRecord job = CreateRender("s1", kTasks, 1);

  std::vector<std::vector<std::string>> leased(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      std::unique_ptr<JobStore> store = Open();
      if (store == nullptr) return;
      const std::string worker = "w" + std::to_string(t);
      while (true) {
        absl::StatusOr<std::optional<TaskLease>> lease = store->LeaseTask(worker, {}, kT0);
        if (!lease.ok()) {
          ADD_FAILURE() << lease.status();
          return;
        }
        if (!lease->has_value()) return;
        leased[t].push_back((*lease)->task.id);
      }
    });
  }
  for (std::thread& thread : threads) thread.join();

  std::vector<std::string> all;
  for (const std::vector<std::string>& ids : leased) all.insert(all.end(), ids.begin(), ids.end());
  EXPECT_EQ(all.size(), static_cast<size_t>(kTasks));
  EXPECT_EQ(std::set<std::string>(all.begin(), all.end()).size(), static_cast<size_t>(kTasks));
  for (const TaskRecord& task : Tasks(job.id)) {
    EXPECT_EQ(task.state, TaskState::kLeased);
    EXPECT_EQ(task.attempt, 1);
  }
  EXPECT_EQ(Queued(JobKind::kRender), 0);
}

// Servers sharing one store receive the same scene at once: one creates
// the reconstruction, every other one joins it (on PostgreSQL the losers of
// the insert race fail with a unique violation and their retry joins).
TEST_P(JobStoreTest, ConcurrentCreatesOfOneSceneMakeOneReconstruction) {
  constexpr int kThreads = 8;
  std::vector<std::unique_ptr<JobStore>> stores;
  for (int t = 0; t < kThreads; ++t) {
    stores.push_back(Open());
    ASSERT_NE(stores.back(), nullptr);
  }
  std::vector<absl::StatusOr<CreateSceneOutcome>> outcomes(kThreads, absl::UnknownError("not run"));
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      outcomes[t] = stores[t]->CreateSceneJob("s1", "hash-s1", "{}", "", "{}", "{}", "alice", kT0);
    });
  }
  for (std::thread& thread : threads) thread.join();

  int created = 0;
  std::set<std::string> job_ids;
  for (const absl::StatusOr<CreateSceneOutcome>& outcome : outcomes) {
    ASSERT_TRUE(outcome.ok()) << outcome.status();
    if (outcome->kind == CreateSceneOutcome::Kind::kCreated) {
      ++created;
    } else {
      EXPECT_EQ(outcome->kind, CreateSceneOutcome::Kind::kJoined);
    }
    job_ids.insert(outcome->job.id);
  }
  EXPECT_EQ(created, 1);
  EXPECT_EQ(job_ids.size(), 1u);
  EXPECT_EQ(Scene("s1").job_id, *job_ids.begin());
  EXPECT_EQ(Queued(JobKind::kReconstruct), 1);
  absl::StatusOr<Page<JobRecord>> jobs = store_->ListJobs(JobKind::kReconstruct, 100, "");
  ASSERT_TRUE(jobs.ok()) << jobs.status();
  EXPECT_EQ(jobs->items.size(), 1u);
}

// Replicas finish the last chunks of one job at the same moment: whichever
// commits second must see the other's chunk done and end the job (on
// PostgreSQL's READ COMMITTED each used to count the other's chunk as not
// done, and the job stayed RUNNING with every task DONE).
TEST_P(JobStoreTest, ConcurrentCompletionsOfTheLastTasksSucceedTheJob) {
  constexpr int kThreads = 4;
  constexpr int kRounds = 25;
  std::vector<std::unique_ptr<JobStore>> stores;
  for (int t = 0; t < kThreads; ++t) {
    stores.push_back(Open());
    ASSERT_NE(stores.back(), nullptr);
  }
  MakeReadyScene("s1");
  for (int round = 0; round < kRounds; ++round) {
    JobRecord job = CreateRender("s1", kThreads, 1);
    std::vector<TaskLease> leases;
    for (int t = 0; t < kThreads; ++t) leases.push_back(Lease("w" + std::to_string(t)));
    std::atomic<int> ready = 0;
    std::vector<absl::Status> results(kThreads);
    std::vector<std::thread> threads;
    for (int t = 0; t < kThreads; ++t) {
      threads.emplace_back([&, t] {
        ready.fetch_add(1);
        while (ready.load() < kThreads) std::this_thread::yield();
        results[t] = stores[t]->CompleteTask(leases[t].task.id, 1, "{}", "", kT0 + 1);
      });
    }
    for (std::thread& thread : threads) thread.join();
    for (const absl::Status& status : results) ASSERT_TRUE(status.ok()) << status;
    const JobRecord done = Job(job.id);
    ASSERT_EQ(done.state, JobState::kSucceeded)
        << "round " << round << ": " << done.tasks_done << " of " << kThreads << " tasks done";
  }
}

// -- Limits and integrity ----------------------------------------------------------

TEST_P(JobStoreTest, CountUnfinishedJobsCountsOnlyTheOwnersJobsThatHaveNotEnded) {
  // alice submits scenes, bob render jobs (the fixture's owners).
  EXPECT_EQ(*store_->CountUnfinishedJobs("alice"), 0);
  MakeReadyScene("s1");  // Its reconstruction SUCCEEDED: not counted.
  CreateScene("s2");     // QUEUED.
  EXPECT_EQ(*store_->CountUnfinishedJobs("alice"), 1);
  const JobRecord waiting = CreateRender("s2", 1);  // WAITING_FOR_SCENE.
  const JobRecord queued = CreateRender("s1", 1);   // QUEUED.
  const JobRecord cancelled = CreateRender("s1", 1);
  ASSERT_TRUE(store_->CancelJob(cancelled.id, kT0).ok());
  EXPECT_EQ(*store_->CountUnfinishedJobs("bob"), 2);
  EXPECT_EQ(*store_->CountUnfinishedJobs("alice"), 1);
  EXPECT_EQ(*store_->CountUnfinishedJobs(""), 0);
  EXPECT_EQ(*store_->CountUnfinishedJobs("carol"), 0);

  // A RUNNING job still counts; a finished one no longer does.
  TaskLease lease = Lease("w1", {"s1"});
  ASSERT_EQ(lease.job.id, queued.id);
  EXPECT_EQ(*store_->CountUnfinishedJobs("bob"), 2);
  ASSERT_TRUE(store_->CompleteTask(lease.task.id, lease.task.attempt, "{}", "", kT0).ok());
  EXPECT_EQ(*store_->CountUnfinishedJobs("bob"), 1);
  EXPECT_EQ(Job(waiting.id).state, JobState::kWaitingForScene);
}

TEST_P(JobStoreTest, RebuildSceneQueuesANewReconstructionAndRenderChunksWaitForIt) {
  MakeReadyScene("s1");
  const SceneRecord before = Scene("s1");
  const JobRecord render = CreateRender("s1", 3);
  const std::vector<TaskRecord> chunks = Tasks(render.id);
  // Chunk 0 done, chunk 1 leased, chunk 2 queued.
  TaskLease first = Lease("w1", {"s1"});
  ASSERT_EQ(first.task.id, chunks[0].id);
  ASSERT_TRUE(
      store_->CompleteTask(first.task.id, first.task.attempt, "{\"files\":0}", "", kT0).ok());
  TaskLease second = Lease("w2", {"s1"});
  ASSERT_EQ(second.task.id, chunks[1].id);

  absl::StatusOr<SceneRecord> rebuilt =
      store_->RebuildScene("s1", "hash mismatch", "{\"name\":\"s1\",\"fresh\":true}", kT0 + 5);
  ASSERT_TRUE(rebuilt.ok()) << rebuilt.status();
  EXPECT_EQ(rebuilt->state, SceneState::kCreating);
  EXPECT_NE(rebuilt->job_id, before.job_id);
  EXPECT_EQ(rebuilt->description, "{\"name\":\"s1\",\"fresh\":true}");
  EXPECT_EQ(rebuilt->content_hash, before.content_hash);

  // The old build's job is untouched; the new one repeats its work.
  EXPECT_EQ(Job(before.job_id).state, JobState::kSucceeded);
  const JobRecord rebuild = Job(rebuilt->job_id);
  EXPECT_EQ(rebuild.kind, JobKind::kReconstruct);
  EXPECT_EQ(rebuild.state, JobState::kQueued);
  EXPECT_EQ(rebuild.request, Job(before.job_id).request);
  EXPECT_EQ(rebuild.owner, "alice");
  ASSERT_EQ(Tasks(rebuild.id).size(), 1u);
  EXPECT_EQ(Tasks(rebuild.id)[0].work, Tasks(before.job_id)[0].work);

  // The render job and its unfinished chunks wait; the leased attempt ended
  // and its worker lost the lease.
  EXPECT_EQ(Job(render.id).state, JobState::kWaitingForScene);
  EXPECT_EQ(Task(chunks[0].id).state, TaskState::kDone);
  const TaskRecord lost = Task(chunks[1].id);
  EXPECT_EQ(lost.state, TaskState::kWaitingForScene);
  ASSERT_EQ(lost.attempts.size(), 1u);
  EXPECT_EQ(lost.attempts[0].outcome, "scene file corrupt: hash mismatch");
  EXPECT_EQ(lost.attempts[0].end_ms, kT0 + 5);
  EXPECT_EQ(Task(chunks[2].id).state, TaskState::kWaitingForScene);
  EXPECT_EQ(store_->CompleteTask(second.task.id, second.task.attempt, "{}", "", kT0 + 6).code(),
            absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(*store_->CountQueuedTasks(JobKind::kRender), 0);

  // A second report while it is rebuilt changes nothing more.
  absl::StatusOr<SceneRecord> again = store_->RebuildScene("s1", "again", "{}", kT0 + 7);
  ASSERT_TRUE(again.ok()) << again.status();
  EXPECT_EQ(again->job_id, rebuilt->job_id);

  // The rebuild completes: the scene is READY again and the chunks run to
  // the end of the job.
  TaskLease build = Lease("w3");
  ASSERT_EQ(build.job.id, rebuilt->job_id);
  ASSERT_TRUE(store_
                  ->CompleteTask(build.task.id, build.task.attempt, "{}",
                                 "{\"name\":\"s1\",\"rebuilt\":true}", kT0 + 8)
                  .ok());
  EXPECT_EQ(Scene("s1").state, SceneState::kReady);
  EXPECT_EQ(Scene("s1").job_id, rebuilt->job_id);
  EXPECT_EQ(Job(render.id).state, JobState::kQueued);
  for (int i = 0; i < 2; ++i) {
    TaskLease chunk = Lease("w1", {"s1"}, kT0 + 9);
    EXPECT_EQ(chunk.job.id, render.id);
    ASSERT_TRUE(store_->CompleteTask(chunk.task.id, chunk.task.attempt, "{}", "", kT0 + 9).ok());
  }
  EXPECT_EQ(Job(render.id).state, JobState::kSucceeded);
  EXPECT_EQ(Task(chunks[1].id).attempts.size(), 2u);
}

TEST_P(JobStoreTest, RebuildSceneRefusesAbsentAndFailedScenes) {
  EXPECT_EQ(store_->RebuildScene("nope", "x", "{}", kT0).status().code(),
            absl::StatusCode::kNotFound);
  const CreateSceneOutcome created = CreateScene("s1");
  ASSERT_TRUE(store_->CancelJob(created.job.id, kT0).ok());
  ASSERT_EQ(Scene("s1").state, SceneState::kFailed);
  EXPECT_EQ(store_->RebuildScene("s1", "x", "{}", kT0).status().code(),
            absl::StatusCode::kFailedPrecondition);
}

// A scene built at `done_ms` (created just before).
void BuildSceneAt(JobStore& store, const std::string& scene_id, int64_t done_ms) {
  ASSERT_TRUE(
      store.CreateSceneJob(scene_id, "hash-" + scene_id, "{}", "", "{}", "{}", "alice", done_ms - 1)
          .ok());
  absl::StatusOr<std::optional<TaskLease>> lease = store.LeaseTask("builder", {}, done_ms - 1);
  ASSERT_TRUE(lease.ok() && lease->has_value());
  ASSERT_EQ((*lease)->task.scene_id, scene_id);
  ASSERT_TRUE(
      store.CompleteTask((*lease)->task.id, (*lease)->task.attempt, "{}", "", done_ms).ok());
}

TEST_P(JobStoreTest, EvictionTakesTheLeastRecentlyUsedSceneThatNoJobNeeds) {
  BuildSceneAt(*store_, "old", kT0 + 10);
  BuildSceneAt(*store_, "newer", kT0 + 20);
  CreateScene("building", "", kT0 + 30);  // CREATING: never evicted.
  const JobRecord render = CreateRender("old", 1, 2, "", nullptr, kT0 + 40);  // "old" in use.

  absl::StatusOr<std::optional<SceneRecord>> evicted = store_->EvictLeastRecentlyUsedScene();
  ASSERT_TRUE(evicted.ok()) << evicted.status();
  ASSERT_TRUE(evicted->has_value());
  EXPECT_EQ((*evicted)->id, "newer");
  EXPECT_EQ(store_->GetScene("newer").status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(Job((*evicted)->job_id).state, JobState::kSucceeded);  // History stays.

  // Nothing more while "old" has an unfinished render job.
  evicted = store_->EvictLeastRecentlyUsedScene();
  ASSERT_TRUE(evicted.ok()) << evicted.status();
  EXPECT_FALSE(evicted->has_value());
  EXPECT_EQ(Scene("old").state, SceneState::kReady);
  EXPECT_EQ(Scene("building").state, SceneState::kCreating);

  ASSERT_TRUE(store_->CancelJob(render.id, kT0 + 50).ok());
  evicted = store_->EvictLeastRecentlyUsedScene();
  ASSERT_TRUE(evicted.ok() && evicted->has_value());
  EXPECT_EQ((*evicted)->id, "old");
  EXPECT_EQ(Job(render.id).state, JobState::kCancelled);
}

TEST_P(JobStoreTest, LeasesAndCacheHitsCountAsUsesOfAScene) {
  BuildSceneAt(*store_, "a", kT0 + 10);
  BuildSceneAt(*store_, "b", kT0 + 20);
  // A chunk of "a" leased and done at +30: "a" is now the more recent.
  const JobRecord render = CreateRender("a", 1, 2, "", nullptr, kT0 + 25);
  TaskLease chunk = Lease("w1", {"a"}, kT0 + 30);
  ASSERT_EQ(chunk.job.id, render.id);
  ASSERT_TRUE(store_->CompleteTask(chunk.task.id, chunk.task.attempt, "{}", "", kT0 + 31).ok());
  EXPECT_EQ(Scene("a").update_time_ms, kT0 + 30);
  // A cache hit of "b" at +40 makes it the more recent again.
  CreateSceneOutcome hit = CreateScene("b", "", kT0 + 40);
  ASSERT_EQ(hit.kind, CreateSceneOutcome::Kind::kCacheHit);
  EXPECT_EQ(Scene("b").update_time_ms, kT0 + 40);

  absl::StatusOr<std::optional<SceneRecord>> evicted = store_->EvictLeastRecentlyUsedScene();
  ASSERT_TRUE(evicted.ok() && evicted->has_value());
  EXPECT_EQ((*evicted)->id, "a");
}

TEST_P(JobStoreTest, AFailedRebuildFailsTheRenderJobsWaitingForIt) {
  MakeReadyScene("s1");
  const JobRecord render = CreateRender("s1", 1);
  ASSERT_TRUE(store_->RebuildScene("s1", "gone", "{}", kT0).ok());
  TaskLease build = Lease("w1");
  ASSERT_EQ(build.task.kind, JobKind::kReconstruct);
  ASSERT_TRUE(store_->FailTask(build.task.id, build.task.attempt, "bad input", true, kT0).ok());
  EXPECT_EQ(Scene("s1").state, SceneState::kFailed);
  EXPECT_EQ(Job(render.id).state, JobState::kFailed);
  EXPECT_EQ(Job(render.id).error_code, static_cast<int>(absl::StatusCode::kFailedPrecondition));
}

// Authentication: scene access is gained by creating, joining, hitting the
// cache of, or rendering a scene; lists are filtered by it.
TEST_P(JobStoreTest, OwnersSeeScenesTheyCreatedHitInTheCacheOrRendered) {
  MakeReadyScene("s1");  // Alice's.
  const CreateSceneOutcome s2 = CreateScene("s2");
  const auto has = [&](const std::string& owner, const std::string& scene) {
    absl::StatusOr<bool> access = store_->HasSceneAccess(owner, scene);
    EXPECT_TRUE(access.ok()) << access.status();
    return access.ok() && *access;
  };
  const auto scenes_of = [&](const std::string& owner) {
    std::vector<std::string> ids;
    absl::StatusOr<Page<SceneRecord>> page = store_->ListScenesOf(owner, 50, "");
    EXPECT_TRUE(page.ok()) << page.status();
    if (page.ok()) {
      for (const SceneRecord& scene : page->items) ids.push_back(scene.id);
    }
    return ids;
  };
  const auto jobs_of = [&](const std::string& owner, std::optional<JobKind> kind) {
    std::set<std::string> ids;
    absl::StatusOr<Page<JobRecord>> page = store_->ListJobsOf(owner, kind, 50, "");
    EXPECT_TRUE(page.ok()) << page.status();
    if (page.ok()) {
      for (const JobRecord& job : page->items) ids.insert(job.id);
    }
    return ids;
  };
  EXPECT_TRUE(has("alice", "s1"));
  EXPECT_TRUE(has("alice", "s2"));
  EXPECT_FALSE(has("bob", "s1"));
  EXPECT_TRUE(scenes_of("bob").empty());
  EXPECT_TRUE(jobs_of("bob", std::nullopt).empty());
  EXPECT_EQ(scenes_of("alice"), (std::vector<std::string>{"s2", "s1"}));

  // Bob renders s1: he sees s1, its reconstruction and his render job; not s2.
  const JobRecord render = CreateRender("s1", 1);
  EXPECT_EQ(render.owner, "bob");
  EXPECT_TRUE(has("bob", "s1"));
  EXPECT_FALSE(has("bob", "s2"));
  EXPECT_EQ(scenes_of("bob"), std::vector<std::string>{"s1"});
  const std::string s1_job = store_->GetScene("s1")->job_id;
  EXPECT_EQ(jobs_of("bob", std::nullopt), (std::set<std::string>{render.id, s1_job}));
  EXPECT_EQ(jobs_of("bob", JobKind::kRender), std::set<std::string>{render.id});
  EXPECT_EQ(jobs_of("alice", std::nullopt), (std::set<std::string>{s1_job, s2.job.id}));
  EXPECT_TRUE(jobs_of("alice", JobKind::kRender).empty());

  // Carol hits the cache of s1 and joins the build of s2.
  for (const std::string scene : {"s1", "s2"}) {
    absl::StatusOr<CreateSceneOutcome> outcome =
        store_->CreateSceneJob(scene, "hash-" + scene, "{}", "", "{}", "{}", "carol", kT0 + 1);
    ASSERT_TRUE(outcome.ok()) << outcome.status();
    EXPECT_EQ(outcome->kind, scene == "s1" ? CreateSceneOutcome::Kind::kCacheHit
                                           : CreateSceneOutcome::Kind::kJoined);
    EXPECT_TRUE(has("carol", scene));
  }
  EXPECT_EQ(jobs_of("carol", JobKind::kReconstruct), (std::set<std::string>{s1_job, s2.job.id}));

  // Pages of an owner's scenes.
  absl::StatusOr<Page<SceneRecord>> first = store_->ListScenesOf("alice", 1, "");
  ASSERT_TRUE(first.ok()) << first.status();
  ASSERT_EQ(first->items.size(), 1u);
  EXPECT_EQ(first->items[0].id, "s2");
  absl::StatusOr<Page<SceneRecord>> second =
      store_->ListScenesOf("alice", 1, first->next_page_token);
  ASSERT_TRUE(second.ok()) << second.status();
  ASSERT_EQ(second->items.size(), 1u);
  EXPECT_EQ(second->items[0].id, "s1");
  EXPECT_TRUE(second->next_page_token.empty());
}

INSTANTIATE_TEST_SUITE_P(Backends, JobStoreTest, ::testing::ValuesIn(kBackends),
                         [](const ::testing::TestParamInfo<StoreBackend>& info) {
                           return info.param.name;
                         });

// -- Not per backend ----------------------------------------------------------------

TEST(OpenJobStore, RejectsUnknownSpecsNamingTheAcceptedForms) {
  absl::StatusOr<std::unique_ptr<JobStore>> store = OpenJobStore("mysql://db", {});
  EXPECT_EQ(store.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(std::string(store.status().message()).find("mysql://db"), std::string::npos);
  EXPECT_NE(std::string(store.status().message()).find("sqlite:PATH"), std::string::npos);
  EXPECT_NE(std::string(store.status().message()).find("postgresql://USER:PASS@HOST:PORT/DB"),
            std::string::npos);
  EXPECT_EQ(OpenJobStore("sqlite:", {}).status().code(), absl::StatusCode::kInvalidArgument);
  const std::string dir = testing::MakeTempDir("job_store_test");
  EXPECT_EQ(OpenJobStore("sqlite:" + dir + "/jobs.db", {.max_attempts = 0}).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(OpenJobStore, PostgresErrorsNameTheSpecButNotThePassword) {
  // Port 1 on loopback: nothing listens, the connection is refused at once.
  for (const std::string scheme : {"postgresql", "postgres"}) {
    absl::StatusOr<std::unique_ptr<JobStore>> store =
        OpenJobStore(scheme + "://pf:hunter2@127.0.0.1:1/jobs", {});
    EXPECT_EQ(store.status().code(), absl::StatusCode::kUnavailable) << store.status();
    const std::string message(store.status().message());
    EXPECT_NE(message.find(scheme + "://pf:***@127.0.0.1:1/jobs"), std::string::npos) << message;
    EXPECT_EQ(message.find("hunter2"), std::string::npos) << message;
  }
  absl::StatusOr<std::unique_ptr<JobStore>> malformed =
      OpenJobStore("postgresql://pf:hunter2@[::1/jobs", {});  // Unclosed '['.
  EXPECT_EQ(malformed.status().code(), absl::StatusCode::kInvalidArgument) << malformed.status();
  EXPECT_EQ(std::string(malformed.status().message()).find("hunter2"), std::string::npos);
}

TEST(SqlJobStoreMigrations, SecondRunIsANoOp) {
  const std::string path = testing::MakeTempDir("job_store_test") + "/jobs.db";
  absl::StatusOr<std::unique_ptr<SqliteDatabase>> db = SqliteDatabase::Open(path);
  ASSERT_TRUE(db.ok()) << db.status();
  absl::StatusOr<int> first = ApplyMigrations(**db);
  ASSERT_TRUE(first.ok()) << first.status();
  EXPECT_EQ(*first, LatestSchemaVersion());
  ASSERT_TRUE((*db)
                  ->Exec("INSERT INTO scenes (id, state, job_id, content_hash, description, "
                         "create_time_ms, update_time_ms, seq) "
                         "VALUES ('kept', 'READY', 'j', 'h', '{}', 1, 1, 1)")
                  .ok());
  absl::StatusOr<int> second = ApplyMigrations(**db);
  ASSERT_TRUE(second.ok()) << second.status();
  EXPECT_EQ(*second, 0);
  EXPECT_EQ((*db)->Exec("SELECT COUNT(*) FROM schema_migrations")->at(0).at(0).AsInt(),
            LatestSchemaVersion());
  EXPECT_EQ((*db)->Exec("SELECT COUNT(*) FROM scenes")->at(0).at(0).AsInt(), 1);

  // A store opened on it migrates nothing and sees the row.
  absl::StatusOr<std::unique_ptr<JobStore>> store = OpenJobStore("sqlite:" + path, {});
  ASSERT_TRUE(store.ok()) << store.status();
  EXPECT_EQ((*store)->GetScene("kept")->state, SceneState::kReady);

  // A schema newer than this binary is refused.
  ASSERT_TRUE(
      (*db)
          ->Exec("INSERT INTO schema_migrations (version) VALUES ($1)", {LatestSchemaVersion() + 1})
          .ok());
  EXPECT_EQ(ApplyMigrations(**db).status().code(), absl::StatusCode::kFailedPrecondition);
}

}  // namespace
}  // namespace pf
