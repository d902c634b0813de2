// SqlJobStore: scenes, jobs, tasks and attempts in four tables, every
// operation one transaction.
//
// The state machine:
//
//   Scene:  CREATING --reconstruction done--> READY
//           CREATING --reconstruction failed or cancelled--> FAILED
//           FAILED --CreateSceneJob again--> CREATING (a new job)
//
//   Job:    render on a CREATING scene: WAITING_FOR_SCENE --scene READY--> QUEUED
//                                       WAITING_FOR_SCENE --scene FAILED--> FAILED
//           QUEUED --first lease--> RUNNING --last task DONE--> SUCCEEDED
//           QUEUED/RUNNING --a task failed for good--> FAILED
//           any state not terminal --CancelJob--> CANCELLED
//
//   Task:   WAITING_FOR_SCENE --scene READY--> QUEUED --LeaseTask--> LEASED
//           LEASED --CompleteTask--> DONE
//           LEASED --FailTask / lease expired, attempts left--> QUEUED
//           LEASED --permanent failure or last attempt--> FAILED
//           not ended --its job ended (failed, cancelled)--> CANCELLED
//
// Each lease starts an attempt (a row in `attempts`, outcome "running")
// that ends "succeeded", "failed: <reason>", "lease expired" or
// "cancelled". A worker proves it still holds a lease with (task id,
// attempt number): an older attempt's calls are refused and change nothing.
// A worker holding a CANCELLED task learns it from its next Heartbeat.
//
// Job progress is never stored: every read aggregates it over the tasks
// (views of DONE chunks plus frames_done of LEASED chunks; the stage of the
// most recent heartbeat).
//
// Ordering ("oldest", "newest first") uses `seq`, a counter assigned at
// insert, so it does not depend on the callers' clocks; ties (possible
// when PostgreSQL inserts concurrently) are broken by id.
#include "server/store/sql_job_store.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <limits>
#include <random>

#include "absl/strings/escaping.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "common/status_macros.h"

namespace pf {
namespace {

// -- Schema ------------------------------------------------------------------

struct Migration {
  int version;
  std::vector<std::string> statements;
};

// The schema, as ordered steps. Append new steps; never edit released ones.
// Types are the ones SQLite and PostgreSQL both accept.
const std::vector<Migration>& Migrations() {
  static const auto* migrations = new std::vector<Migration>{
      {1,
       {
           R"sql(CREATE TABLE scenes (
                   id TEXT PRIMARY KEY,
                   state TEXT NOT NULL,
                   job_id TEXT NOT NULL,
                   content_hash TEXT NOT NULL,
                   description TEXT NOT NULL,
                   error TEXT NOT NULL DEFAULT '',
                   create_time_ms BIGINT NOT NULL,
                   update_time_ms BIGINT NOT NULL,
                   seq BIGINT NOT NULL))sql",
           "CREATE INDEX scenes_by_seq ON scenes (seq, id)",
           "CREATE INDEX scenes_by_hash ON scenes (content_hash)",
           R"sql(CREATE TABLE jobs (
                   id TEXT PRIMARY KEY,
                   kind TEXT NOT NULL,
                   state TEXT NOT NULL,
                   request_id TEXT,
                   scene_id TEXT NOT NULL,
                   request TEXT NOT NULL,
                   error_code INTEGER NOT NULL DEFAULT 0,
                   error_message TEXT NOT NULL DEFAULT '',
                   owner TEXT NOT NULL DEFAULT '',
                   frames_total INTEGER NOT NULL DEFAULT 0,
                   create_time_ms BIGINT NOT NULL,
                   update_time_ms BIGINT NOT NULL,
                   seq BIGINT NOT NULL))sql",
           // NULL request ids (none given) never collide.
           "CREATE UNIQUE INDEX jobs_by_request ON jobs (kind, request_id)",
           "CREATE INDEX jobs_by_seq ON jobs (seq, id)",
           "CREATE INDEX jobs_by_scene ON jobs (scene_id, state)",
           R"sql(CREATE TABLE tasks (
                   id TEXT PRIMARY KEY,
                   job_id TEXT NOT NULL REFERENCES jobs (id),
                   kind TEXT NOT NULL,
                   task_index INTEGER NOT NULL,
                   state TEXT NOT NULL,
                   scene_id TEXT NOT NULL,
                   first_view INTEGER NOT NULL DEFAULT 0,
                   view_count INTEGER NOT NULL DEFAULT 0,
                   work TEXT NOT NULL,
                   result TEXT NOT NULL DEFAULT '',
                   attempt INTEGER NOT NULL DEFAULT 0,
                   worker_id TEXT NOT NULL DEFAULT '',
                   lease_deadline_ms BIGINT NOT NULL DEFAULT 0,
                   stage TEXT NOT NULL DEFAULT '',
                   fraction DOUBLE PRECISION NOT NULL DEFAULT 0,
                   frames_done INTEGER NOT NULL DEFAULT 0,
                   heartbeat_ms BIGINT NOT NULL DEFAULT 0,
                   job_seq BIGINT NOT NULL))sql",
           "CREATE INDEX tasks_by_job ON tasks (job_id, task_index)",
           "CREATE INDEX tasks_by_queue ON tasks (state, job_seq, task_index)",
           "CREATE INDEX tasks_by_deadline ON tasks (state, lease_deadline_ms)",
           R"sql(CREATE TABLE attempts (
                   task_id TEXT NOT NULL REFERENCES tasks (id),
                   number INTEGER NOT NULL,
                   worker_id TEXT NOT NULL,
                   outcome TEXT NOT NULL,
                   start_ms BIGINT NOT NULL,
                   end_ms BIGINT NOT NULL DEFAULT 0,
                   PRIMARY KEY (task_id, number)))sql",
       }},
      // Authentication: which owners may see which scenes (job_store.h,
      // "Owners"). Jobs already carry their owner.
      {2,
       {
           R"sql(CREATE TABLE scene_access (
                   owner TEXT NOT NULL,
                   scene_id TEXT NOT NULL,
                   PRIMARY KEY (owner, scene_id)))sql",
           "CREATE INDEX scene_access_by_scene ON scene_access (scene_id)",
       }},
  };
  return *migrations;
}

// -- Small helpers -------------------------------------------------------------

// Runs a statement whose rows do not matter.
absl::Status Run(SqlExecutor& tx, const std::string& sql, const std::vector<SqlValue>& params) {
  return tx.Exec(sql, params).status();
}

// Row locking for read-then-write on PostgreSQL; SQLite's BEGIN IMMEDIATE
// already holds the database's write lock.
std::string ForUpdate(const SqlExecutor& tx) {
  return tx.dialect() == SqlDialect::kPostgres ? " FOR UPDATE" : "";
}

// A shared row lock on PostgreSQL: the row cannot change until commit, but
// other transactions may hold the same lock (render jobs created on one
// scene at once do not wait for each other).
std::string ForShare(const SqlExecutor& tx) {
  return tx.dialect() == SqlDialect::kPostgres ? " FOR SHARE" : "";
}

// Serialises schema changes between servers starting at once. On
// PostgreSQL, takes a transaction-scoped advisory lock (released at COMMIT
// or ROLLBACK) before a migration step reads schema_migrations: a second
// server waits, then (READ COMMITTED: each statement sees what committed
// before it) finds the step recorded and skips it. SQLite's BEGIN IMMEDIATE
// already excludes other writers.
absl::Status LockSchema(SqlExecutor& tx) {
  if (tx.dialect() != SqlDialect::kPostgres) return absl::OkStatus();
  constexpr int64_t kSchemaLockKey = 0x70665f736368656d;  // "pf_schem".
  return Run(tx, "SELECT pg_advisory_xact_lock($1)", {kSchemaLockKey});
}

// Returns 16 random hex digits.
std::string NewId() {
  std::random_device random;
  const uint64_t bits = (uint64_t{random()} << 32) ^ uint64_t { random() };
  char text[17];
  std::snprintf(text, sizeof(text), "%016llx", static_cast<unsigned long long>(bits));
  return text;
}

template <typename Enum, size_t N>
absl::StatusOr<Enum> ParseName(const std::string& text, const char* (*name)(Enum),
                               const Enum (&values)[N], const char* what) {
  for (Enum value : values) {
    if (text == name(value)) return value;
  }
  return absl::InternalError(absl::StrCat("the store holds an unknown ", what, " '", text, "'"));
}

absl::StatusOr<JobKind> ParseJobKind(const std::string& text) {
  static constexpr JobKind kAll[] = {JobKind::kReconstruct, JobKind::kRender};
  return ParseName(text, JobKindName, kAll, "job kind");
}

absl::StatusOr<JobState> ParseJobState(const std::string& text) {
  static constexpr JobState kAll[] = {JobState::kWaitingForScene, JobState::kQueued,
                                      JobState::kRunning,         JobState::kSucceeded,
                                      JobState::kFailed,          JobState::kCancelled};
  return ParseName(text, JobStateName, kAll, "job state");
}

absl::StatusOr<TaskState> ParseTaskState(const std::string& text) {
  static constexpr TaskState kAll[] = {TaskState::kWaitingForScene, TaskState::kQueued,
                                       TaskState::kLeased,          TaskState::kDone,
                                       TaskState::kFailed,          TaskState::kCancelled};
  return ParseName(text, TaskStateName, kAll, "task state");
}

absl::StatusOr<SceneState> ParseSceneState(const std::string& text) {
  static constexpr SceneState kAll[] = {SceneState::kCreating, SceneState::kReady,
                                        SceneState::kFailed};
  return ParseName(text, SceneStateName, kAll, "scene state");
}

// -- Paging ----------------------------------------------------------------------

// A page token names the last item of the previous page by (seq, id),
// behind a prefix saying what was listed.
struct PagePosition {
  int64_t seq = std::numeric_limits<int64_t>::max();
  std::string id;
};

std::string MakePageToken(const std::string& what, int64_t seq, const std::string& id) {
  return absl::WebSafeBase64Escape(absl::StrCat(what, ":", seq, ":", id));
}

absl::StatusOr<PagePosition> ParsePageToken(const std::string& what, const std::string& token) {
  PagePosition position;
  if (token.empty()) return position;
  std::string text;
  const std::string prefix = absl::StrCat(what, ":");
  const absl::Status bad = absl::InvalidArgumentError(
      absl::StrCat("page_token: '", token, "' is not a token a previous List call returned"));
  if (!absl::WebSafeBase64Unescape(token, &text) || text.rfind(prefix, 0) != 0) return bad;
  const size_t colon = text.find(':', prefix.size());
  if (colon == std::string::npos ||
      !absl::SimpleAtoi(text.substr(prefix.size(), colon - prefix.size()), &position.seq)) {
    return bad;
  }
  position.id = text.substr(colon + 1);
  return position;
}

int ClampPageSize(int page_size) {
  constexpr int kDefault = 50;
  constexpr int kMax = 1000;
  if (page_size <= 0) return kDefault;
  return std::min(page_size, kMax);
}

// -- Reading records -------------------------------------------------------------

constexpr char kSceneColumns[] =
    "id, state, job_id, content_hash, description, error, create_time_ms, update_time_ms, seq";

absl::StatusOr<SceneRecord> SceneFromRow(const SqlRow& row) {
  SceneRecord scene;
  scene.id = row[0].AsString();
  ASSIGN_OR_RETURN(scene.state, ParseSceneState(row[1].AsString()));
  scene.job_id = row[2].AsString();
  scene.content_hash = row[3].AsString();
  scene.description = row[4].AsString();
  scene.error = row[5].AsString();
  scene.create_time_ms = row[6].AsInt();
  scene.update_time_ms = row[7].AsInt();
  return scene;
}

enum class RowLock { kNone, kShare, kUpdate };

// Returns the scene, or nullopt when absent, with `lock` on its row.
absl::StatusOr<std::optional<SceneRecord>> FindScene(SqlExecutor& tx, const std::string& scene_id,
                                                     RowLock lock) {
  const std::string lock_clause = lock == RowLock::kUpdate  ? ForUpdate(tx)
                                  : lock == RowLock::kShare ? ForShare(tx)
                                                            : "";
  ASSIGN_OR_RETURN(SqlRows rows, tx.Exec(absl::StrCat("SELECT ", kSceneColumns,
                                                      " FROM scenes WHERE id = $1", lock_clause),
                                         {scene_id}));
  if (rows.empty()) return std::nullopt;
  return SceneFromRow(rows[0]);
}

// A job with its progress aggregated over its tasks. Column 12 is seq.
constexpr char kSelectJob[] = R"sql(
    SELECT j.id, j.kind, j.state, j.request_id, j.scene_id, j.request, j.error_code,
           j.error_message, j.owner, j.frames_total, j.create_time_ms, j.update_time_ms, j.seq,
           (SELECT COUNT(*) FROM tasks t WHERE t.job_id = j.id),
           (SELECT COUNT(*) FROM tasks t WHERE t.job_id = j.id AND t.state = 'DONE'),
           (SELECT COALESCE(SUM(CASE t.state WHEN 'DONE' THEN t.view_count
                                             WHEN 'LEASED' THEN t.frames_done
                                             ELSE 0 END), 0)
              FROM tasks t WHERE t.job_id = j.id),
           (SELECT COALESCE(AVG(t.fraction), 0) FROM tasks t WHERE t.job_id = j.id),
           (SELECT t.stage FROM tasks t WHERE t.job_id = j.id AND t.heartbeat_ms > 0
              ORDER BY t.heartbeat_ms DESC, t.task_index DESC LIMIT 1)
      FROM jobs j)sql";

absl::StatusOr<JobRecord> JobFromRow(const SqlRow& row) {
  JobRecord job;
  job.id = row[0].AsString();
  ASSIGN_OR_RETURN(job.kind, ParseJobKind(row[1].AsString()));
  ASSIGN_OR_RETURN(job.state, ParseJobState(row[2].AsString()));
  job.request_id = row[3].AsString();
  job.scene_id = row[4].AsString();
  job.request = row[5].AsString();
  job.error_code = static_cast<int>(row[6].AsInt());
  job.error_message = row[7].AsString();
  job.owner = row[8].AsString();
  job.frames_total = static_cast<int>(row[9].AsInt());
  job.create_time_ms = row[10].AsInt();
  job.update_time_ms = row[11].AsInt();
  job.tasks_total = static_cast<int>(row[13].AsInt());
  job.tasks_done = static_cast<int>(row[14].AsInt());
  job.frames_done = static_cast<int>(row[15].AsInt());
  job.stage = row[17].AsString();
  // A render job's fraction is frames; a reconstruction's is its task's.
  if (job.state == JobState::kSucceeded) {
    job.fraction = 1.0;
  } else if (job.kind == JobKind::kRender) {
    job.fraction = job.frames_total > 0
                       ? std::min(1.0, static_cast<double>(job.frames_done) / job.frames_total)
                       : 0.0;
  } else {
    job.fraction = row[16].AsDouble();
  }
  return job;
}

absl::StatusOr<std::optional<JobRecord>> FindJob(SqlExecutor& tx, const std::string& job_id) {
  ASSIGN_OR_RETURN(SqlRows rows, tx.Exec(absl::StrCat(kSelectJob, " WHERE j.id = $1"), {job_id}));
  if (rows.empty()) return std::nullopt;
  return JobFromRow(rows[0]);
}

absl::StatusOr<JobRecord> LoadJob(SqlExecutor& tx, const std::string& job_id) {
  ASSIGN_OR_RETURN(std::optional<JobRecord> job, FindJob(tx, job_id));
  if (!job) return absl::NotFoundError(absl::StrCat("job ", job_id, " not found"));
  return *std::move(job);
}

// Returns the job of `kind` submitted with `request_id`, if any.
absl::StatusOr<std::optional<JobRecord>> FindJobByRequest(SqlExecutor& tx, JobKind kind,
                                                          const std::string& request_id) {
  if (request_id.empty()) return std::nullopt;
  ASSIGN_OR_RETURN(SqlRows rows,
                   tx.Exec(absl::StrCat(kSelectJob, " WHERE j.kind = $1 AND j.request_id = $2"),
                           {JobKindName(kind), request_id}));
  if (rows.empty()) return std::nullopt;
  return JobFromRow(rows[0]);
}

constexpr char kTaskColumns[] =
    "id, job_id, kind, task_index, state, scene_id, first_view, view_count, work, result, "
    "attempt, worker_id, lease_deadline_ms, stage, fraction, frames_done";

absl::StatusOr<TaskRecord> TaskFromRow(const SqlRow& row) {
  TaskRecord task;
  task.id = row[0].AsString();
  task.job_id = row[1].AsString();
  ASSIGN_OR_RETURN(task.kind, ParseJobKind(row[2].AsString()));
  task.index = static_cast<int>(row[3].AsInt());
  ASSIGN_OR_RETURN(task.state, ParseTaskState(row[4].AsString()));
  task.scene_id = row[5].AsString();
  task.first_view = static_cast<int>(row[6].AsInt());
  task.view_count = static_cast<int>(row[7].AsInt());
  task.work = row[8].AsString();
  task.result = row[9].AsString();
  task.attempt = static_cast<int>(row[10].AsInt());
  task.worker_id = row[11].AsString();
  task.lease_deadline_ms = row[12].AsInt();
  task.stage = row[13].AsString();
  task.fraction = row[14].AsDouble();
  task.frames_done = static_cast<int>(row[15].AsInt());
  return task;
}

AttemptRecord AttemptFromRow(const SqlRow& row) {  // Columns from kAttemptColumns.
  AttemptRecord attempt;
  attempt.number = static_cast<int>(row[1].AsInt());
  attempt.worker_id = row[2].AsString();
  attempt.outcome = row[3].AsString();
  attempt.start_ms = row[4].AsInt();
  attempt.end_ms = row[5].AsInt();
  return attempt;
}

constexpr char kAttemptColumns[] = "task_id, number, worker_id, outcome, start_ms, end_ms";

// Returns the task with its attempts. NOT_FOUND when absent. `lock`: for update.
absl::StatusOr<TaskRecord> LoadTask(SqlExecutor& tx, const std::string& task_id, bool lock) {
  ASSIGN_OR_RETURN(SqlRows rows,
                   tx.Exec(absl::StrCat("SELECT ", kTaskColumns, " FROM tasks WHERE id = $1",
                                        lock ? ForUpdate(tx) : ""),
                           {task_id}));
  if (rows.empty()) return absl::NotFoundError(absl::StrCat("task ", task_id, " not found"));
  ASSIGN_OR_RETURN(TaskRecord task, TaskFromRow(rows[0]));
  ASSIGN_OR_RETURN(SqlRows attempts,
                   tx.Exec(absl::StrCat("SELECT ", kAttemptColumns,
                                        " FROM attempts WHERE task_id = $1 ORDER BY number"),
                           {task_id}));
  for (const SqlRow& row : attempts) task.attempts.push_back(AttemptFromRow(row));
  return task;
}

// -- Writing -----------------------------------------------------------------------

absl::Status InsertJob(SqlExecutor& tx, const JobRecord& job) {
  return Run(tx,
             R"sql(INSERT INTO jobs (id, kind, state, request_id, scene_id, request, owner,
                                     frames_total, create_time_ms, update_time_ms, seq)
                   VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $9,
                           (SELECT COALESCE(MAX(seq), 0) + 1 FROM jobs)))sql",
             {job.id, JobKindName(job.kind), JobStateName(job.state),
              job.request_id.empty() ? SqlValue() : SqlValue(job.request_id), job.scene_id,
              job.request, job.owner, job.frames_total, job.create_time_ms});
}

absl::Status InsertTask(SqlExecutor& tx, const std::string& job_id, JobKind kind, int index,
                        TaskState state, const std::string& scene_id, const NewTask& task) {
  return Run(tx,
             R"sql(INSERT INTO tasks (id, job_id, kind, task_index, state, scene_id, first_view,
                                      view_count, work, job_seq)
                   VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9,
                           (SELECT seq FROM jobs WHERE id = $2)))sql",
             {NewId(), job_id, JobKindName(kind), index, TaskStateName(state), scene_id,
              task.first_view, task.view_count, task.work});
}

// Ends attempt `number` of `task_id` with `outcome` at `now_ms`.
absl::Status EndAttempt(SqlExecutor& tx, const std::string& task_id, int number,
                        const std::string& outcome, int64_t now_ms) {
  return Run(tx, "UPDATE attempts SET outcome = $3, end_ms = $4 WHERE task_id = $1 AND number = $2",
             {task_id, number, outcome, now_ms});
}

absl::Status EndJob(SqlExecutor& tx, const std::string& job_id, JobKind kind,
                    const std::string& scene_id, JobState state, absl::StatusCode code,
                    const std::string& message, int64_t now_ms);

// Records a use of READY scene `scene_id` (a cache hit, a render chunk
// leased): its update time orders the least recently used for eviction.
absl::Status TouchScene(SqlExecutor& tx, const std::string& scene_id, int64_t now_ms) {
  return Run(tx,
             "UPDATE scenes SET update_time_ms = $2 WHERE id = $1 AND state = 'READY'"
             " AND update_time_ms < $2",
             {scene_id, now_ms});
}

// Fails scene `scene_id` if job `job_id` is still creating it, and with it
// the render jobs waiting for it.
absl::Status FailScene(SqlExecutor& tx, const std::string& scene_id, const std::string& job_id,
                       const std::string& error, int64_t now_ms) {
  RETURN_IF_ERROR(Run(tx,
                      R"sql(UPDATE scenes SET state = 'FAILED', error = $3, update_time_ms = $4
                             WHERE id = $1 AND job_id = $2 AND state = 'CREATING')sql",
                      {scene_id, job_id, error, now_ms}));
  ASSIGN_OR_RETURN(
      SqlRows waiting,
      tx.Exec("SELECT id FROM jobs WHERE scene_id = $1 AND state = 'WAITING_FOR_SCENE'",
              {scene_id}));
  const std::string message = absl::StrCat("scene ", scene_id, " could not be created: ", error);
  for (const SqlRow& row : waiting) {
    RETURN_IF_ERROR(EndJob(tx, row[0].AsString(), JobKind::kRender, scene_id, JobState::kFailed,
                           absl::StatusCode::kFailedPrecondition, message, now_ms));
  }
  return absl::OkStatus();
}

// Ends job `job_id` in `state` with (code, message): its unfinished tasks
// are cancelled (running attempts end "cancelled"), and a reconstruction's
// scene fails.
absl::Status EndJob(SqlExecutor& tx, const std::string& job_id, JobKind kind,
                    const std::string& scene_id, JobState state, absl::StatusCode code,
                    const std::string& message, int64_t now_ms) {
  RETURN_IF_ERROR(Run(tx,
                      R"sql(UPDATE jobs SET state = $2, error_code = $3, error_message = $4,
                                            update_time_ms = $5
                             WHERE id = $1)sql",
                      {job_id, JobStateName(state), static_cast<int>(code), message, now_ms}));
  RETURN_IF_ERROR(Run(tx,
                      R"sql(UPDATE attempts SET outcome = 'cancelled', end_ms = $2
                             WHERE outcome = 'running'
                               AND task_id IN (SELECT id FROM tasks WHERE job_id = $1))sql",
                      {job_id, now_ms}));
  RETURN_IF_ERROR(Run(tx,
                      R"sql(UPDATE tasks SET state = 'CANCELLED', lease_deadline_ms = 0
                             WHERE job_id = $1
                               AND state IN ('WAITING_FOR_SCENE', 'QUEUED', 'LEASED'))sql",
                      {job_id}));
  if (kind == JobKind::kReconstruct) {
    return FailScene(tx, scene_id, job_id, message, now_ms);
  }
  return absl::OkStatus();
}

// Names a task in error messages: "reconstruction", "chunk 2 (views 4-5)".
std::string TaskLabel(const TaskRecord& task) {
  if (task.kind == JobKind::kReconstruct) return "reconstruction";
  if (task.view_count == 1) {
    return absl::StrCat("chunk ", task.index, " (view ", task.first_view, ")");
  }
  return absl::StrCat("chunk ", task.index, " (views ", task.first_view, "-",
                      task.first_view + task.view_count - 1, ")");
}

// Ends the current attempt of the LEASED `task` as failed with `outcome`;
// then queues the task again, or, when `permanent` or out of attempts,
// fails it and its job with every attempt listed.
absl::Status FailAttempt(SqlExecutor& tx, const StoreOptions& options, const TaskRecord& task,
                         const std::string& outcome, bool permanent, int64_t now_ms) {
  RETURN_IF_ERROR(EndAttempt(tx, task.id, task.attempt, outcome, now_ms));
  if (!permanent && task.attempt < options.max_attempts) {
    return Run(tx,
               R"sql(UPDATE tasks SET state = 'QUEUED', worker_id = '', lease_deadline_ms = 0,
                                      fraction = 0, frames_done = 0
                      WHERE id = $1)sql",
               {task.id});
  }
  RETURN_IF_ERROR(
      Run(tx, "UPDATE tasks SET state = 'FAILED', lease_deadline_ms = 0 WHERE id = $1", {task.id}));
  ASSIGN_OR_RETURN(TaskRecord failed, LoadTask(tx, task.id, /*lock=*/false));
  std::vector<std::string> reasons;
  for (const AttemptRecord& attempt : failed.attempts) {
    reasons.push_back(absl::StrCat("attempt ", attempt.number, " on worker ", attempt.worker_id,
                                   ": ", attempt.outcome));
  }
  const int count = static_cast<int>(failed.attempts.size());
  const std::string message =
      absl::StrCat(TaskLabel(task), permanent ? " failed permanently" : " failed", " after ", count,
                   count == 1 ? " attempt: " : " attempts: ", absl::StrJoin(reasons, "; "));
  return EndJob(tx, task.job_id, task.kind, task.scene_id, JobState::kFailed,
                permanent ? absl::StatusCode::kInvalidArgument : absl::StatusCode::kAborted,
                message, now_ms);
}

// Gives `owner` access to scene `scene_id` (job_store.h, "Owners").
absl::Status GrantSceneAccess(SqlExecutor& tx, const std::string& owner,
                              const std::string& scene_id) {
  return Run(tx,
             "INSERT INTO scene_access (owner, scene_id) VALUES ($1, $2) "
             "ON CONFLICT (owner, scene_id) DO NOTHING",
             {owner, scene_id});
}

// Scenes newest first from `page_token` on; only those `owner` has access
// to when set.
absl::StatusOr<Page<SceneRecord>> ListScenesFor(SqlExecutor& db,
                                                const std::optional<std::string>& owner,
                                                int page_size, const std::string& page_token) {
  ASSIGN_OR_RETURN(PagePosition after, ParsePageToken("scenes", page_token));
  const int size = ClampPageSize(page_size);
  std::vector<SqlValue> params = {after.seq, after.id, size + 1};
  std::string owner_clause;
  if (owner) {
    params.push_back(*owner);
    owner_clause = " AND id IN (SELECT scene_id FROM scene_access WHERE owner = $4)";
  }
  // One row more than the page tells whether another page follows.
  ASSIGN_OR_RETURN(SqlRows rows,
                   db.Exec(absl::StrCat("SELECT ", kSceneColumns,
                                        " FROM scenes WHERE (seq < $1 OR (seq = $1 AND id < $2))",
                                        owner_clause, " ORDER BY seq DESC, id DESC LIMIT $3"),
                           params));
  Page<SceneRecord> page;
  for (int i = 0; i < std::min<int>(size, rows.size()); ++i) {
    ASSIGN_OR_RETURN(SceneRecord scene, SceneFromRow(rows[i]));
    page.items.push_back(std::move(scene));
  }
  if (static_cast<int>(rows.size()) > size) {
    page.next_page_token = MakePageToken("scenes", rows[size - 1][8].AsInt(), page.items.back().id);
  }
  return page;
}

// Jobs newest first from `page_token` on, of `kind` when set; only those
// `owner` may see when set (its own, and the reconstructions of scenes it
// has access to).
absl::StatusOr<Page<JobRecord>> ListJobsFor(SqlExecutor& db,
                                            const std::optional<std::string>& owner,
                                            std::optional<JobKind> kind, int page_size,
                                            const std::string& page_token) {
  ASSIGN_OR_RETURN(PagePosition after, ParsePageToken("jobs", page_token));
  const int size = ClampPageSize(page_size);
  std::string sql = absl::StrCat(kSelectJob, " WHERE (j.seq < $1 OR (j.seq = $1 AND j.id < $2))");
  std::vector<SqlValue> params = {after.seq, after.id, size + 1};
  if (kind) {
    params.push_back(JobKindName(*kind));
    absl::StrAppend(&sql, " AND j.kind = $", params.size());
  }
  if (owner) {
    params.push_back(*owner);
    const std::string placeholder = absl::StrCat("$", params.size());
    absl::StrAppend(&sql, " AND (j.owner = ", placeholder,
                    " OR (j.kind = 'reconstruct' AND j.scene_id IN"
                    " (SELECT scene_id FROM scene_access WHERE owner = ",
                    placeholder, ")))");
  }
  absl::StrAppend(&sql, " ORDER BY j.seq DESC, j.id DESC LIMIT $3");
  ASSIGN_OR_RETURN(SqlRows rows, db.Exec(sql, params));
  Page<JobRecord> page;
  for (int i = 0; i < std::min<int>(size, rows.size()); ++i) {
    ASSIGN_OR_RETURN(JobRecord job, JobFromRow(rows[i]));
    page.items.push_back(std::move(job));
  }
  if (static_cast<int>(rows.size()) > size) {
    page.next_page_token = MakePageToken("jobs", rows[size - 1][12].AsInt(), page.items.back().id);
  }
  return page;
}

// Returns OK if `attempt` holds the lease on `task`, else
// FAILED_PRECONDITION saying what happened to it.
absl::Status CheckHoldsLease(const TaskRecord& task, int attempt) {
  if (task.attempt == attempt && task.state == TaskState::kLeased) return absl::OkStatus();
  return absl::FailedPreconditionError(
      absl::StrCat("task ", task.id, " attempt ", attempt, " no longer holds the lease (task is ",
                   TaskStateName(task.state), ", attempt ", task.attempt, ")"));
}

// Returns the task, locked, if (`task_id`, `attempt`) holds its lease.
absl::StatusOr<TaskRecord> LoadLeasedTask(SqlExecutor& tx, const std::string& task_id,
                                          int attempt) {
  ASSIGN_OR_RETURN(TaskRecord task, LoadTask(tx, task_id, /*lock=*/true));
  RETURN_IF_ERROR(CheckHoldsLease(task, attempt));
  return task;
}

}  // namespace

// -- Migrations ----------------------------------------------------------------

int LatestSchemaVersion() { return Migrations().back().version; }

absl::StatusOr<int> ApplyMigrations(SqlDatabase& db) {
  RETURN_IF_ERROR(db.Transaction([](SqlExecutor& tx) -> absl::Status {
    RETURN_IF_ERROR(LockSchema(tx));
    return Run(tx,
               "CREATE TABLE IF NOT EXISTS schema_migrations ("
               "version INTEGER PRIMARY KEY, applied_ms BIGINT NOT NULL DEFAULT 0)",
               {});
  }));
  ASSIGN_OR_RETURN(SqlRows newest,
                   db.Exec("SELECT COALESCE(MAX(version), 0) FROM schema_migrations"));
  if (newest[0][0].AsInt() > LatestSchemaVersion()) {
    return absl::FailedPreconditionError(absl::StrCat(
        "the job store's schema is version ", newest[0][0].AsInt(), ", newer than this binary's ",
        LatestSchemaVersion(), ": run a newer pf-server"));
  }
  int applied = 0;
  for (const Migration& migration : Migrations()) {
    bool ran = false;
    RETURN_IF_ERROR(db.Transaction([&](SqlExecutor& tx) -> absl::Status {
      ran = false;
      RETURN_IF_ERROR(LockSchema(tx));
      ASSIGN_OR_RETURN(
          SqlRows done,
          tx.Exec("SELECT version FROM schema_migrations WHERE version = $1", {migration.version}));
      if (!done.empty()) return absl::OkStatus();
      for (const std::string& statement : migration.statements) {
        RETURN_IF_ERROR(StatusWithContext(tx.Exec(statement).status(),
                                          absl::StrCat("schema migration ", migration.version)));
      }
      const int64_t now_ms = std::chrono::duration_cast<std::chrono::milliseconds>(
                                 std::chrono::system_clock::now().time_since_epoch())
                                 .count();
      ran = true;
      return Run(tx, "INSERT INTO schema_migrations (version, applied_ms) VALUES ($1, $2)",
                 {migration.version, now_ms});
    }));
    if (ran) ++applied;
  }
  return applied;
}

// -- SqlJobStore -------------------------------------------------------------------

absl::StatusOr<std::unique_ptr<SqlJobStore>> SqlJobStore::Open(std::unique_ptr<SqlDatabase> db,
                                                               const StoreOptions& options) {
  if (options.max_attempts < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("max_attempts: must be at least 1, got ", options.max_attempts));
  }
  if (options.lease_duration_ms < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("lease_duration_ms: must be positive, got ", options.lease_duration_ms));
  }
  RETURN_IF_ERROR(ApplyMigrations(*db).status());
  return std::unique_ptr<SqlJobStore>(new SqlJobStore(std::move(db), options));
}

absl::StatusOr<CreateSceneOutcome> SqlJobStore::CreateSceneJob(
    const std::string& scene_id, const std::string& content_hash, const std::string& description,
    const std::string& request_id, const std::string& request, const std::string& work,
    const std::string& owner, int64_t now_ms) {
  if (scene_id.empty()) return absl::InvalidArgumentError("scene_id: must not be empty");
  CreateSceneOutcome outcome;
  RETURN_IF_ERROR(db_->Transaction([&](SqlExecutor& tx) -> absl::Status {
    outcome = CreateSceneOutcome();
    ASSIGN_OR_RETURN(std::optional<JobRecord> same,
                     FindJobByRequest(tx, JobKind::kReconstruct, request_id));
    if (same) {
      outcome.kind = CreateSceneOutcome::Kind::kSameRequest;
      outcome.job = *std::move(same);
      ASSIGN_OR_RETURN(std::optional<SceneRecord> scene,
                       FindScene(tx, outcome.job.scene_id, RowLock::kNone));
      if (scene) {
        outcome.scene = *std::move(scene);
      } else {  // Deleted since.
        outcome.scene.id = outcome.job.scene_id;
        outcome.scene.state = SceneState::kFailed;
        outcome.scene.job_id = outcome.job.id;
        outcome.scene.error = "the scene was deleted";
      }
      return absl::OkStatus();
    }

    ASSIGN_OR_RETURN(std::optional<SceneRecord> scene, FindScene(tx, scene_id, RowLock::kUpdate));
    if (scene && scene->state != SceneState::kFailed) {
      outcome.kind = scene->state == SceneState::kReady ? CreateSceneOutcome::Kind::kCacheHit
                                                        : CreateSceneOutcome::Kind::kJoined;
      ASSIGN_OR_RETURN(outcome.job, LoadJob(tx, scene->job_id));
      outcome.scene = *std::move(scene);
      if (outcome.kind == CreateSceneOutcome::Kind::kCacheHit) {
        RETURN_IF_ERROR(TouchScene(tx, scene_id, now_ms));
      }
      return GrantSceneAccess(tx, owner, scene_id);
    }

    // Absent or FAILED: a new reconstruction job with its one task.
    JobRecord job;
    job.id = NewId();
    job.kind = JobKind::kReconstruct;
    job.state = JobState::kQueued;
    job.request_id = request_id;
    job.scene_id = scene_id;
    job.request = request;
    job.owner = owner;
    job.create_time_ms = now_ms;
    RETURN_IF_ERROR(InsertJob(tx, job));
    RETURN_IF_ERROR(InsertTask(tx, job.id, JobKind::kReconstruct, 0, TaskState::kQueued, scene_id,
                               NewTask{.work = work}));
    if (scene) {
      RETURN_IF_ERROR(Run(tx,
                          R"sql(UPDATE scenes SET state = 'CREATING', job_id = $2,
                                                  content_hash = $3, description = $4,
                                                  error = '', update_time_ms = $5
                                 WHERE id = $1)sql",
                          {scene_id, job.id, content_hash, description, now_ms}));
    } else {
      RETURN_IF_ERROR(Run(tx,
                          R"sql(INSERT INTO scenes (id, state, job_id, content_hash, description,
                                                    create_time_ms, update_time_ms, seq)
                                VALUES ($1, 'CREATING', $2, $3, $4, $5, $5,
                                        (SELECT COALESCE(MAX(seq), 0) + 1 FROM scenes)))sql",
                          {scene_id, job.id, content_hash, description, now_ms}));
    }
    RETURN_IF_ERROR(GrantSceneAccess(tx, owner, scene_id));
    outcome.kind = CreateSceneOutcome::Kind::kCreated;
    ASSIGN_OR_RETURN(outcome.job, LoadJob(tx, job.id));
    ASSIGN_OR_RETURN(std::optional<SceneRecord> created, FindScene(tx, scene_id, RowLock::kNone));
    outcome.scene = *std::move(created);
    return absl::OkStatus();
  }));
  return outcome;
}

absl::StatusOr<SceneRecord> SqlJobStore::GetScene(const std::string& scene_id) {
  ASSIGN_OR_RETURN(std::optional<SceneRecord> scene, FindScene(*db_, scene_id, RowLock::kNone));
  if (!scene) return absl::NotFoundError(absl::StrCat("scene ", scene_id, " not found"));
  return *std::move(scene);
}

absl::StatusOr<Page<SceneRecord>> SqlJobStore::ListScenes(int page_size,
                                                          const std::string& page_token) {
  return ListScenesFor(*db_, std::nullopt, page_size, page_token);
}

absl::Status SqlJobStore::DeleteScene(const std::string& scene_id, int64_t now_ms) {
  return db_->Transaction([&](SqlExecutor& tx) -> absl::Status {
    ASSIGN_OR_RETURN(std::optional<SceneRecord> scene, FindScene(tx, scene_id, RowLock::kUpdate));
    if (!scene) return absl::NotFoundError(absl::StrCat("scene ", scene_id, " not found"));
    if (scene->state == SceneState::kCreating) {
      RETURN_IF_ERROR(EndJob(tx, scene->job_id, JobKind::kReconstruct, scene_id,
                             JobState::kCancelled, absl::StatusCode::kCancelled,
                             "cancelled: the scene was deleted", now_ms));
    }
    return Run(tx, "DELETE FROM scenes WHERE id = $1", {scene_id});
  });
}

absl::StatusOr<JobRecord> SqlJobStore::CreateRenderJob(const std::string& scene_id,
                                                       const std::string& request_id,
                                                       const std::string& request, int frames_total,
                                                       const std::vector<NewTask>& tasks,
                                                       const std::string& owner, int64_t now_ms,
                                                       bool* same_request) {
  if (tasks.empty()) return absl::InvalidArgumentError("tasks: a render job needs at least one");
  int views = 0;
  for (size_t i = 0; i < tasks.size(); ++i) {
    if (tasks[i].view_count < 1 || tasks[i].first_view < 0) {
      return absl::InvalidArgumentError(
          absl::StrCat("tasks[", i, "]: first_view ", tasks[i].first_view, " and view_count ",
                       tasks[i].view_count, " do not name at least one view"));
    }
    views += tasks[i].view_count;
  }
  if (views != frames_total) {
    return absl::InvalidArgumentError(
        absl::StrCat("frames_total: ", frames_total, " but the tasks cover ", views, " views"));
  }
  JobRecord result;
  bool found_same = false;
  RETURN_IF_ERROR(db_->Transaction([&](SqlExecutor& tx) -> absl::Status {
    found_same = false;
    ASSIGN_OR_RETURN(std::optional<JobRecord> same,
                     FindJobByRequest(tx, JobKind::kRender, request_id));
    if (same) {
      found_same = true;
      result = *std::move(same);
      return absl::OkStatus();
    }
    // Shared: the scene cannot become READY or FAILED, or be deleted, until
    // this job is in, so the job's state matches the scene's.
    ASSIGN_OR_RETURN(std::optional<SceneRecord> scene, FindScene(tx, scene_id, RowLock::kShare));
    if (!scene) return absl::NotFoundError(absl::StrCat("scene ", scene_id, " not found"));
    if (scene->state == SceneState::kFailed) {
      return absl::FailedPreconditionError(
          absl::StrCat("scene ", scene_id, " failed: ", scene->error));
    }
    const bool ready = scene->state == SceneState::kReady;
    JobRecord job;
    job.id = NewId();
    job.kind = JobKind::kRender;
    job.state = ready ? JobState::kQueued : JobState::kWaitingForScene;
    job.request_id = request_id;
    job.scene_id = scene_id;
    job.request = request;
    job.owner = owner;
    job.frames_total = frames_total;
    job.create_time_ms = now_ms;
    RETURN_IF_ERROR(InsertJob(tx, job));
    for (size_t i = 0; i < tasks.size(); ++i) {
      RETURN_IF_ERROR(InsertTask(tx, job.id, JobKind::kRender, static_cast<int>(i),
                                 ready ? TaskState::kQueued : TaskState::kWaitingForScene, scene_id,
                                 tasks[i]));
    }
    RETURN_IF_ERROR(GrantSceneAccess(tx, owner, scene_id));
    ASSIGN_OR_RETURN(result, LoadJob(tx, job.id));
    return absl::OkStatus();
  }));
  if (same_request != nullptr) *same_request = found_same;
  return result;
}

absl::StatusOr<JobRecord> SqlJobStore::GetJob(const std::string& job_id) {
  return LoadJob(*db_, job_id);
}

absl::StatusOr<Page<JobRecord>> SqlJobStore::ListJobs(std::optional<JobKind> kind, int page_size,
                                                      const std::string& page_token) {
  return ListJobsFor(*db_, std::nullopt, kind, page_size, page_token);
}

absl::StatusOr<TaskRecord> SqlJobStore::GetTask(const std::string& task_id) {
  TaskRecord task;
  RETURN_IF_ERROR(db_->Transaction([&](SqlExecutor& tx) -> absl::Status {
    ASSIGN_OR_RETURN(task, LoadTask(tx, task_id, /*lock=*/false));
    return absl::OkStatus();
  }));
  return task;
}

absl::StatusOr<std::vector<TaskRecord>> SqlJobStore::ListTasks(const std::string& job_id) {
  std::vector<TaskRecord> tasks;
  RETURN_IF_ERROR(db_->Transaction([&](SqlExecutor& tx) -> absl::Status {
    tasks.clear();
    ASSIGN_OR_RETURN(std::optional<JobRecord> job, FindJob(tx, job_id));
    if (!job) return absl::NotFoundError(absl::StrCat("job ", job_id, " not found"));
    ASSIGN_OR_RETURN(SqlRows rows, tx.Exec(absl::StrCat("SELECT ", kTaskColumns,
                                                        " FROM tasks WHERE job_id = $1"
                                                        " ORDER BY task_index"),
                                           {job_id}));
    for (const SqlRow& row : rows) {
      ASSIGN_OR_RETURN(TaskRecord task, TaskFromRow(row));
      tasks.push_back(std::move(task));
    }
    ASSIGN_OR_RETURN(SqlRows attempts,
                     tx.Exec(absl::StrCat("SELECT ", kAttemptColumns, R"sql( FROM attempts
                    WHERE task_id IN (SELECT id FROM tasks WHERE job_id = $1)
                    ORDER BY task_id, number)sql"),
                             {job_id}));
    for (const SqlRow& row : attempts) {
      const std::string task_id = row[0].AsString();
      for (TaskRecord& task : tasks) {
        if (task.id == task_id) task.attempts.push_back(AttemptFromRow(row));
      }
    }
    return absl::OkStatus();
  }));
  return tasks;
}

absl::StatusOr<JobRecord> SqlJobStore::CancelJob(const std::string& job_id, int64_t now_ms) {
  JobRecord result;
  RETURN_IF_ERROR(db_->Transaction([&](SqlExecutor& tx) -> absl::Status {
    RETURN_IF_ERROR(
        Run(tx, absl::StrCat("SELECT id FROM jobs WHERE id = $1", ForUpdate(tx)), {job_id}));
    ASSIGN_OR_RETURN(JobRecord job, LoadJob(tx, job_id));
    if (!IsTerminal(job.state)) {
      RETURN_IF_ERROR(EndJob(tx, job.id, job.kind, job.scene_id, JobState::kCancelled,
                             absl::StatusCode::kCancelled, "cancelled", now_ms));
    }
    ASSIGN_OR_RETURN(result, LoadJob(tx, job_id));
    return absl::OkStatus();
  }));
  return result;
}

absl::StatusOr<std::optional<TaskLease>> SqlJobStore::LeaseTask(
    const std::string& worker_id, const std::vector<std::string>& cached_scenes, int64_t now_ms) {
  // Oldest first, render tasks of cached scenes before all others.
  std::string sql = "SELECT id FROM tasks WHERE state = 'QUEUED' ORDER BY ";
  std::vector<SqlValue> params;
  if (!cached_scenes.empty()) {
    std::vector<std::string> placeholders;
    for (const std::string& scene : cached_scenes) {
      params.push_back(scene);
      placeholders.push_back(absl::StrCat("$", params.size()));
    }
    absl::StrAppend(&sql, "CASE WHEN kind = 'render' AND scene_id IN (",
                    absl::StrJoin(placeholders, ", "), ") THEN 0 ELSE 1 END, ");
  }
  absl::StrAppend(&sql, "job_seq, task_index LIMIT 1");
  // Concurrent servers on PostgreSQL each take a different task.
  if (db_->dialect() == SqlDialect::kPostgres) absl::StrAppend(&sql, " FOR UPDATE SKIP LOCKED");

  std::optional<TaskLease> lease;
  RETURN_IF_ERROR(db_->Transaction([&](SqlExecutor& tx) -> absl::Status {
    lease.reset();
    ASSIGN_OR_RETURN(SqlRows rows, tx.Exec(sql, params));
    if (rows.empty()) return absl::OkStatus();
    const std::string task_id = rows[0][0].AsString();
    RETURN_IF_ERROR(Run(tx,
                        R"sql(UPDATE tasks SET state = 'LEASED', attempt = attempt + 1,
                                               worker_id = $2, lease_deadline_ms = $3,
                                               fraction = 0, frames_done = 0
                               WHERE id = $1)sql",
                        {task_id, worker_id, now_ms + options_.lease_duration_ms}));
    RETURN_IF_ERROR(Run(tx,
                        R"sql(INSERT INTO attempts (task_id, number, worker_id, outcome, start_ms)
                              SELECT id, attempt, worker_id, 'running', $2 FROM tasks
                               WHERE id = $1)sql",
                        {task_id, now_ms}));
    ASSIGN_OR_RETURN(TaskRecord task, LoadTask(tx, task_id, /*lock=*/false));
    if (task.kind == JobKind::kRender) RETURN_IF_ERROR(TouchScene(tx, task.scene_id, now_ms));
    RETURN_IF_ERROR(Run(tx,
                        R"sql(UPDATE jobs SET state = 'RUNNING', update_time_ms = $2
                               WHERE id = $1 AND state = 'QUEUED')sql",
                        {task.job_id, now_ms}));
    ASSIGN_OR_RETURN(JobRecord job, LoadJob(tx, task.job_id));
    lease = TaskLease{std::move(task), std::move(job)};
    return absl::OkStatus();
  }));
  return lease;
}

absl::StatusOr<bool> SqlJobStore::Heartbeat(const std::string& task_id, int attempt,
                                            const std::string& stage, double fraction,
                                            int frames_done, int64_t now_ms, int64_t* deadline_ms) {
  bool cancelled = false;
  int64_t deadline = 0;
  RETURN_IF_ERROR(db_->Transaction([&](SqlExecutor& tx) -> absl::Status {
    ASSIGN_OR_RETURN(TaskRecord task, LoadTask(tx, task_id, /*lock=*/true));
    // The holder of a task cancelled under it is told to stop.
    cancelled = task.state == TaskState::kCancelled && task.attempt == attempt;
    if (cancelled) {
      deadline = task.lease_deadline_ms;
      return absl::OkStatus();
    }
    RETURN_IF_ERROR(CheckHoldsLease(task, attempt));
    deadline = now_ms + options_.lease_duration_ms;
    return Run(tx,
               R"sql(UPDATE tasks SET lease_deadline_ms = $2, stage = $3, fraction = $4,
                                      frames_done = $5, heartbeat_ms = $6
                      WHERE id = $1)sql",
               {task_id, deadline, stage, std::clamp(fraction, 0.0, 1.0),
                std::clamp(frames_done, 0, task.view_count), now_ms});
  }));
  if (deadline_ms != nullptr) *deadline_ms = deadline;
  return cancelled;
}

absl::Status SqlJobStore::CompleteTask(const std::string& task_id, int attempt,
                                       const std::string& result,
                                       const std::string& scene_description, int64_t now_ms) {
  return db_->Transaction([&](SqlExecutor& tx) -> absl::Status {
    ASSIGN_OR_RETURN(TaskRecord task, LoadLeasedTask(tx, task_id, attempt));
    // Completions of one job's tasks take turns on the job's row. Under
    // READ COMMITTED two of them running at once would each count the
    // other's task as not yet done, and neither would end the job; the
    // second now waits here and its count below sees the first's commit.
    RETURN_IF_ERROR(
        Run(tx, absl::StrCat("SELECT id FROM jobs WHERE id = $1", ForUpdate(tx)), {task.job_id}));
    RETURN_IF_ERROR(Run(tx,
                        R"sql(UPDATE tasks SET state = 'DONE', result = $2, fraction = 1,
                                               frames_done = view_count, lease_deadline_ms = 0
                               WHERE id = $1)sql",
                        {task_id, result}));
    RETURN_IF_ERROR(EndAttempt(tx, task_id, attempt, "succeeded", now_ms));
    ASSIGN_OR_RETURN(
        SqlRows left,
        tx.Exec("SELECT COUNT(*) FROM tasks WHERE job_id = $1 AND state <> 'DONE'", {task.job_id}));
    if (left[0][0].AsInt() > 0) {
      return Run(tx, "UPDATE jobs SET update_time_ms = $2 WHERE id = $1", {task.job_id, now_ms});
    }
    RETURN_IF_ERROR(Run(tx,
                        "UPDATE jobs SET state = 'SUCCEEDED', update_time_ms = $2 WHERE id = $1",
                        {task.job_id, now_ms}));
    if (task.kind != JobKind::kReconstruct) return absl::OkStatus();

    // The scene is READY; render jobs waiting for it join the queue.
    RETURN_IF_ERROR(
        Run(tx,
            scene_description.empty() ? "UPDATE scenes SET state = 'READY', update_time_ms = $3"
                                        " WHERE id = $1 AND job_id = $2"
                                      : "UPDATE scenes SET state = 'READY', update_time_ms = $3,"
                                        " description = $4 WHERE id = $1 AND job_id = $2",
            scene_description.empty()
                ? std::vector<SqlValue>{task.scene_id, task.job_id, now_ms}
                : std::vector<SqlValue>{task.scene_id, task.job_id, now_ms, scene_description}));
    RETURN_IF_ERROR(Run(tx,
                        R"sql(UPDATE tasks SET state = 'QUEUED'
                               WHERE state = 'WAITING_FOR_SCENE' AND job_id IN
                                     (SELECT id FROM jobs
                                       WHERE scene_id = $1 AND state = 'WAITING_FOR_SCENE'))sql",
                        {task.scene_id}));
    return Run(tx,
               R"sql(UPDATE jobs SET state = 'QUEUED', update_time_ms = $2
                      WHERE scene_id = $1 AND state = 'WAITING_FOR_SCENE')sql",
               {task.scene_id, now_ms});
  });
}

absl::Status SqlJobStore::FailTask(const std::string& task_id, int attempt,
                                   const std::string& reason, bool permanent, int64_t now_ms) {
  return db_->Transaction([&](SqlExecutor& tx) -> absl::Status {
    ASSIGN_OR_RETURN(TaskRecord task, LoadLeasedTask(tx, task_id, attempt));
    return FailAttempt(tx, options_, task, absl::StrCat("failed: ", reason), permanent, now_ms);
  });
}

absl::StatusOr<int> SqlJobStore::ExpireLeases(int64_t now_ms) {
  int expired = 0;
  RETURN_IF_ERROR(db_->Transaction([&](SqlExecutor& tx) -> absl::Status {
    expired = 0;
    ASSIGN_OR_RETURN(
        SqlRows rows,
        tx.Exec(
            absl::StrCat("SELECT id FROM tasks WHERE state = 'LEASED' AND lease_deadline_ms < $1"
                         " ORDER BY job_seq, task_index",
                         tx.dialect() == SqlDialect::kPostgres ? " FOR UPDATE SKIP LOCKED" : ""),
            {now_ms}));
    for (const SqlRow& row : rows) {
      ASSIGN_OR_RETURN(TaskRecord task, LoadTask(tx, row[0].AsString(), /*lock=*/false));
      // An earlier expiry in this loop may have failed its job already.
      if (task.state != TaskState::kLeased) continue;
      RETURN_IF_ERROR(
          FailAttempt(tx, options_, task, "lease expired", /*permanent=*/false, now_ms));
      ++expired;
    }
    return absl::OkStatus();
  }));
  return expired;
}

absl::StatusOr<int> SqlJobStore::CountQueuedTasks(JobKind kind) {
  ASSIGN_OR_RETURN(SqlRows rows,
                   db_->Exec("SELECT COUNT(*) FROM tasks WHERE state = 'QUEUED' AND kind = $1",
                             {JobKindName(kind)}));
  return static_cast<int>(rows[0][0].AsInt());
}

absl::StatusOr<int> SqlJobStore::CountJobs(JobKind kind, JobState state) {
  ASSIGN_OR_RETURN(SqlRows rows,
                   db_->Exec("SELECT COUNT(*) FROM jobs WHERE state = $1 AND kind = $2",
                             {JobStateName(state), JobKindName(kind)}));
  return static_cast<int>(rows[0][0].AsInt());
}

absl::StatusOr<int> SqlJobStore::CountUnfinishedJobs(const std::string& owner) {
  ASSIGN_OR_RETURN(SqlRows rows, db_->Exec(R"sql(SELECT COUNT(*) FROM jobs
                       WHERE owner = $1 AND state IN ('WAITING_FOR_SCENE', 'QUEUED', 'RUNNING'))sql",
                                           {owner}));
  return static_cast<int>(rows[0][0].AsInt());
}

absl::StatusOr<SceneRecord> SqlJobStore::RebuildScene(const std::string& scene_id,
                                                      const std::string& reason,
                                                      const std::string& description,
                                                      int64_t now_ms) {
  SceneRecord result;
  RETURN_IF_ERROR(db_->Transaction([&](SqlExecutor& tx) -> absl::Status {
    ASSIGN_OR_RETURN(std::optional<SceneRecord> scene, FindScene(tx, scene_id, RowLock::kUpdate));
    if (!scene) return absl::NotFoundError(absl::StrCat("scene ", scene_id, " not found"));
    if (scene->state == SceneState::kFailed) {
      return absl::FailedPreconditionError(
          absl::StrCat("scene ", scene_id, " failed and cannot be rebuilt: ", scene->error));
    }
    if (scene->state == SceneState::kReady) {
      // A new reconstruction with the work of the job that built the scene.
      ASSIGN_OR_RETURN(const JobRecord built, LoadJob(tx, scene->job_id));
      ASSIGN_OR_RETURN(SqlRows work, tx.Exec(R"sql(SELECT work FROM tasks
                                                    WHERE job_id = $1 AND kind = 'reconstruct'
                                                    ORDER BY task_index LIMIT 1)sql",
                                             {built.id}));
      if (work.empty()) {
        return absl::InternalError(absl::StrCat("scene ", scene_id, ": its reconstruction job ",
                                                built.id, " has no task to repeat"));
      }
      JobRecord job;
      job.id = NewId();
      job.kind = JobKind::kReconstruct;
      job.state = JobState::kQueued;
      job.scene_id = scene_id;
      job.request = built.request;
      job.owner = built.owner;
      job.create_time_ms = now_ms;
      RETURN_IF_ERROR(InsertJob(tx, job));
      RETURN_IF_ERROR(InsertTask(tx, job.id, JobKind::kReconstruct, 0, TaskState::kQueued, scene_id,
                                 NewTask{.work = work[0][0].AsString()}));
      RETURN_IF_ERROR(Run(tx,
                          R"sql(UPDATE scenes SET state = 'CREATING', job_id = $2, description = $3,
                                                  error = '', update_time_ms = $4
                                 WHERE id = $1)sql",
                          {scene_id, job.id, description, now_ms}));
    }
    // Render chunks of the scene wait for it; leased ones lose their lease.
    ASSIGN_OR_RETURN(SqlRows leased, tx.Exec(R"sql(SELECT id, attempt FROM tasks
                                                    WHERE scene_id = $1 AND kind = 'render'
                                                      AND state = 'LEASED')sql",
                                             {scene_id}));
    for (const SqlRow& row : leased) {
      RETURN_IF_ERROR(EndAttempt(tx, row[0].AsString(), static_cast<int>(row[1].AsInt()),
                                 absl::StrCat("scene file corrupt: ", reason), now_ms));
    }
    RETURN_IF_ERROR(Run(tx,
                        R"sql(UPDATE tasks SET state = 'WAITING_FOR_SCENE', worker_id = '',
                                               lease_deadline_ms = 0, fraction = 0, frames_done = 0
                               WHERE scene_id = $1 AND kind = 'render'
                                 AND state IN ('QUEUED', 'LEASED'))sql",
                        {scene_id}));
    RETURN_IF_ERROR(Run(tx,
                        R"sql(UPDATE jobs SET state = 'WAITING_FOR_SCENE', update_time_ms = $2
                               WHERE scene_id = $1 AND kind = 'render'
                                 AND state IN ('QUEUED', 'RUNNING'))sql",
                        {scene_id, now_ms}));
    ASSIGN_OR_RETURN(std::optional<SceneRecord> now, FindScene(tx, scene_id, RowLock::kNone));
    result = *std::move(now);
    return absl::OkStatus();
  }));
  return result;
}

absl::StatusOr<bool> SqlJobStore::HasSceneAccess(const std::string& owner,
                                                 const std::string& scene_id) {
  ASSIGN_OR_RETURN(SqlRows rows,
                   db_->Exec("SELECT 1 FROM scene_access WHERE owner = $1 AND scene_id = $2",
                             {owner, scene_id}));
  return !rows.empty();
}

absl::StatusOr<Page<SceneRecord>> SqlJobStore::ListScenesOf(const std::string& owner, int page_size,
                                                            const std::string& page_token) {
  return ListScenesFor(*db_, owner, page_size, page_token);
}

absl::StatusOr<Page<JobRecord>> SqlJobStore::ListJobsOf(const std::string& owner,
                                                        std::optional<JobKind> kind, int page_size,
                                                        const std::string& page_token) {
  return ListJobsFor(*db_, owner, kind, page_size, page_token);
}

absl::StatusOr<std::optional<SceneRecord>> SqlJobStore::EvictLeastRecentlyUsedScene() {
  std::optional<SceneRecord> evicted;
  RETURN_IF_ERROR(db_->Transaction([&](SqlExecutor& tx) -> absl::Status {
    evicted.reset();
    // Candidates oldest use first; each is locked and checked again, as a
    // render job may have come for it meanwhile.
    ASSIGN_OR_RETURN(SqlRows candidates, tx.Exec(R"sql(SELECT s.id FROM scenes s
                       WHERE s.state = 'READY' AND NOT EXISTS
                             (SELECT 1 FROM jobs j
                               WHERE j.scene_id = s.id AND j.kind = 'render'
                                 AND j.state IN ('WAITING_FOR_SCENE', 'QUEUED', 'RUNNING'))
                       ORDER BY s.update_time_ms, s.id LIMIT 8)sql",
                                                 {}));
    for (const SqlRow& candidate : candidates) {
      const std::string scene_id = candidate[0].AsString();
      ASSIGN_OR_RETURN(std::optional<SceneRecord> scene, FindScene(tx, scene_id, RowLock::kUpdate));
      if (!scene || scene->state != SceneState::kReady) continue;
      ASSIGN_OR_RETURN(SqlRows in_use, tx.Exec(R"sql(SELECT COUNT(*) FROM jobs
                         WHERE scene_id = $1 AND kind = 'render'
                           AND state IN ('WAITING_FOR_SCENE', 'QUEUED', 'RUNNING'))sql",
                                               {scene_id}));
      if (in_use[0][0].AsInt() > 0) continue;
      RETURN_IF_ERROR(Run(tx, "DELETE FROM scenes WHERE id = $1", {scene_id}));
      evicted = *std::move(scene);
      return absl::OkStatus();
    }
    return absl::OkStatus();
  }));
  return evicted;
}

}  // namespace pf
