// The job store: the only state pf-server keeps. Scenes, jobs (a scene
// reconstruction or a render job; one google.longrunning.Operation each) and
// their tasks (the reconstruction, or one frame chunk of a render job), with
// the leases workers hold on tasks.
//
// Every method is one transaction: a crash between two calls leaves the
// store consistent, and several pf-server processes may share one store
// (PostgreSQL). Times are milliseconds since the Unix epoch, passed in by
// the caller so tests control the clock.
//
//   std::unique_ptr<JobStore> store = ...;  // OpenJobStore("sqlite:/var/pf/jobs.db")
//   ASSIGN_OR_RETURN(CreateSceneOutcome o, store->CreateSceneJob(...));
//   ASSIGN_OR_RETURN(std::optional<TaskLease> lease, store->LeaseTask(...));
//
// Payloads (requests, task work, results, scene descriptions) are opaque
// strings to the store: the service keeps proto3 JSON in them.
#ifndef POINTFORWARD_SERVER_STORE_JOB_STORE_H_
#define POINTFORWARD_SERVER_STORE_JOB_STORE_H_

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace pf {

enum class JobKind { kReconstruct, kRender };

enum class JobState {
  kWaitingForScene,  // Render job whose scene is still being created.
  kQueued,           // No task leased yet.
  kRunning,          // At least one task leased or done.
  kSucceeded,
  kFailed,
  kCancelled,
};

enum class TaskState {
  kWaitingForScene,
  kQueued,
  kLeased,
  kDone,
  kFailed,
  kCancelled,
};

enum class SceneState { kCreating, kReady, kFailed };

const char* JobKindName(JobKind kind);         // "reconstruct", "render".
const char* JobStateName(JobState state);      // "WAITING_FOR_SCENE", "QUEUED", ...
const char* TaskStateName(TaskState state);    // "WAITING_FOR_SCENE", "QUEUED", "LEASED", ...
const char* SceneStateName(SceneState state);  // "CREATING", "READY", "FAILED".
bool IsTerminal(JobState state);

// One try at a task.
struct AttemptRecord {
  int number = 0;  // 1-based.
  std::string worker_id;
  std::string outcome;  // "running", "succeeded", "failed: <reason>", "lease expired", "cancelled".
  int64_t start_ms = 0;
  int64_t end_ms = 0;  // 0 while running.
};

struct SceneRecord {
  std::string id;  // The scene id (without "scenes/").
  SceneState state = SceneState::kCreating;
  std::string job_id;        // The reconstruction job that creates or created it.
  std::string content_hash;  // Cache key.
  std::string description;   // Scene proto JSON as the last writer left it.
  std::string error;         // When kFailed.
  int64_t create_time_ms = 0;
  int64_t update_time_ms = 0;
};

struct JobRecord {
  std::string id;
  JobKind kind = JobKind::kRender;
  JobState state = JobState::kQueued;
  std::string request_id;  // Idempotency key; may be empty.
  std::string scene_id;    // The scene it builds (reconstruct) or renders (render).
  std::string request;     // CreateSceneRequest / CreateRenderJobRequest JSON.
  int error_code = 0;      // absl::StatusCode when kFailed / kCancelled.
  std::string error_message;
  std::string owner;     // Who submitted it (the token's owner; "" with authentication off).
  int frames_total = 0;  // Render: views; reconstruct: 0.
  // Aggregated over the tasks on every read:
  int frames_done = 0;  // Done chunks' views + progress of leased chunks.
  int tasks_total = 0;
  int tasks_done = 0;
  std::string stage;    // Latest stage reported by a heartbeat.
  double fraction = 0;  // 0..1 of the whole job.
  int64_t create_time_ms = 0;
  int64_t update_time_ms = 0;
};

struct TaskRecord {
  std::string id;
  std::string job_id;
  JobKind kind = JobKind::kRender;
  int index = 0;  // Chunk number within the job, from 0.
  TaskState state = TaskState::kQueued;
  std::string scene_id;
  int first_view = 0;  // Render chunks: views [first_view, first_view + view_count).
  int view_count = 0;
  std::string work;       // What a worker needs (WorkerService Task.work as JSON).
  std::string result;     // What CompleteTask stored.
  int attempt = 0;        // Number of the current or last attempt; 0 before the first lease.
  std::string worker_id;  // Holder of the current lease.
  int64_t lease_deadline_ms = 0;
  std::string stage;
  double fraction = 0;
  int frames_done = 0;
  std::vector<AttemptRecord> attempts;
};

// A task handed to a worker.
struct TaskLease {
  TaskRecord task;  // state kLeased, attempt incremented, attempts includes the new one.
  JobRecord job;
};

// A new task as CreateRenderJob builds it.
struct NewTask {
  int first_view = 0;
  int view_count = 0;
  std::string work;
};

struct CreateSceneOutcome {
  enum class Kind {
    kCreated,      // A new scene row and reconstruction job (with one task).
    kCacheHit,     // The scene was READY: `job` is the job that built it.
    kJoined,       // The scene is being created: `job` is that job.
    kSameRequest,  // `request_id` was seen before: `job` is that request's job.
  };
  Kind kind = Kind::kCreated;
  JobRecord job;
  SceneRecord scene;
};

// Paging: `page_token` is what the previous page returned ("" first);
// an empty next_page_token means the last page.
template <typename T>
struct Page {
  std::vector<T> items;
  std::string next_page_token;
};

struct StoreOptions {
  int max_attempts = 3;  // Attempts before a task, and its job, fail.
  int64_t lease_duration_ms = 30000;
};

class JobStore {
 public:
  virtual ~JobStore() = default;

  // -- Scenes and their reconstruction -------------------------------------

  // Finds or starts the reconstruction of scene `scene_id` (cache key
  // `content_hash`), in this order:
  //  - a job with `request_id` (non-empty) exists: kSameRequest;
  //  - the scene is READY: kCacheHit;
  //  - the scene is CREATING: kJoined;
  //  - otherwise (absent, or FAILED: retried): kCreated, with a scene row in
  //    CREATING, a job in QUEUED with `request` and a task in QUEUED with
  //    `work`. `description` is the scene's initial JSON.
  virtual absl::StatusOr<CreateSceneOutcome> CreateSceneJob(
      const std::string& scene_id, const std::string& content_hash, const std::string& description,
      const std::string& request_id, const std::string& request, const std::string& work,
      const std::string& owner, int64_t now_ms) = 0;

  virtual absl::StatusOr<SceneRecord> GetScene(const std::string& scene_id) = 0;  // NOT_FOUND.
  // Newest first.
  virtual absl::StatusOr<Page<SceneRecord>> ListScenes(int page_size,
                                                       const std::string& page_token) = 0;
  // Removes the scene. A scene still CREATING has its job cancelled (and
  // render jobs waiting for it fail). NOT_FOUND if absent.
  virtual absl::Status DeleteScene(const std::string& scene_id, int64_t now_ms) = 0;

  // -- Render jobs -----------------------------------------------------------

  // Creates a render job of `frames_total` views over `tasks` (frame chunks)
  // on scene `scene_id`. A job with `request_id` (non-empty) already
  // existing is returned instead (`*same_request` set). The job starts
  // QUEUED when the scene is READY, WAITING_FOR_SCENE when it is CREATING;
  // NOT_FOUND when the scene is absent, FAILED_PRECONDITION when it failed.
  virtual absl::StatusOr<JobRecord> CreateRenderJob(const std::string& scene_id,
                                                    const std::string& request_id,
                                                    const std::string& request, int frames_total,
                                                    const std::vector<NewTask>& tasks,
                                                    const std::string& owner, int64_t now_ms,
                                                    bool* same_request) = 0;

  // -- Jobs (both kinds) -----------------------------------------------------

  virtual absl::StatusOr<JobRecord> GetJob(const std::string& job_id) = 0;  // NOT_FOUND.
  // Newest first; `kind` filters when set.
  virtual absl::StatusOr<Page<JobRecord>> ListJobs(std::optional<JobKind> kind, int page_size,
                                                   const std::string& page_token) = 0;
  // One task with its attempts; NOT_FOUND when absent.
  virtual absl::StatusOr<TaskRecord> GetTask(const std::string& task_id) = 0;
  // The job's tasks in index order, with their attempts.
  virtual absl::StatusOr<std::vector<TaskRecord>> ListTasks(const std::string& job_id) = 0;
  // Cancels a job that has not ended: job CANCELLED, its unfinished tasks
  // CANCELLED (a worker holding one learns it at its next heartbeat). A
  // reconstruction's scene becomes FAILED ("cancelled") and render jobs
  // waiting for it fail. Returns the job as it now is (unchanged if it had
  // already ended).
  virtual absl::StatusOr<JobRecord> CancelJob(const std::string& job_id, int64_t now_ms) = 0;

  // -- Workers ---------------------------------------------------------------

  // Leases the oldest QUEUED task to `worker_id`, preferring render tasks of
  // scenes in `cached_scenes`: task LEASED, attempt + 1, deadline now +
  // lease duration; its job RUNNING. nullopt when nothing is queued.
  virtual absl::StatusOr<std::optional<TaskLease>> LeaseTask(
      const std::string& worker_id, const std::vector<std::string>& cached_scenes,
      int64_t now_ms) = 0;

  // Extends the lease of (`task_id`, `attempt`) and records progress.
  // Returns true when the job was cancelled (the worker must stop).
  // FAILED_PRECONDITION when that attempt no longer holds the lease.
  // Also sets *deadline_ms to the new deadline when non-null.
  virtual absl::StatusOr<bool> Heartbeat(const std::string& task_id, int attempt,
                                         const std::string& stage, double fraction, int frames_done,
                                         int64_t now_ms, int64_t* deadline_ms) = 0;

  // Marks the task DONE with `result`; the job SUCCEEDS when it was its last
  // task. For a reconstruction, the scene becomes READY with
  // `scene_description`, and render jobs waiting for it are QUEUED.
  // FAILED_PRECONDITION when that attempt no longer holds the lease (its
  // result is dropped).
  virtual absl::Status CompleteTask(const std::string& task_id, int attempt,
                                    const std::string& result, const std::string& scene_description,
                                    int64_t now_ms) = 0;

  // Records the attempt as failed with `reason`. `permanent` (bad input) or
  // the attempt limit reached: the task FAILS and so does its job, with an
  // error listing every attempt's reason (a reconstruction's scene FAILS
  // and render jobs waiting for it fail). Otherwise the task is QUEUED again.
  // FAILED_PRECONDITION when that attempt no longer holds the lease.
  virtual absl::Status FailTask(const std::string& task_id, int attempt, const std::string& reason,
                                bool permanent, int64_t now_ms) = 0;

  // Treats every lease whose deadline has passed as a failed attempt
  // ("lease expired (worker W)"), as FailTask does with permanent = false.
  // Returns how many leases expired.
  virtual absl::StatusOr<int> ExpireLeases(int64_t now_ms) = 0;

  // Counts for metrics and tests: queued tasks by kind.
  virtual absl::StatusOr<int> CountQueuedTasks(JobKind kind) = 0;
  // Jobs of `kind` in `state` (metrics: running jobs).
  virtual absl::StatusOr<int> CountJobs(JobKind kind, JobState state) = 0;

  // -- Owners (authentication) -----------------------------------------------
  //
  // An owner has access to a scene once CreateSceneJob (any outcome but
  // kSameRequest, whose job is already the owner's) or CreateRenderJob was
  // called on it with that owner: submitting the clip proves the owner holds
  // the data the scene is made of. Access outlives a deletion of the scene
  // (the same content makes the same scene id again).

  virtual absl::StatusOr<bool> HasSceneAccess(const std::string& owner,
                                              const std::string& scene_id) = 0;
  // ListScenes restricted to the scenes `owner` has access to.
  virtual absl::StatusOr<Page<SceneRecord>> ListScenesOf(const std::string& owner, int page_size,
                                                         const std::string& page_token) = 0;
  // ListJobs restricted to what `owner` may see: its own jobs, and the
  // reconstructions of the scenes it has access to.
  virtual absl::StatusOr<Page<JobRecord>> ListJobsOf(const std::string& owner,
                                                     std::optional<JobKind> kind, int page_size,
                                                     const std::string& page_token) = 0;

  // -- Limits and integrity ----------------------------------------------------

  // Jobs of either kind submitted by `owner` ("" when authentication is
  // off) that have not ended: the --max-jobs-per-owner limit.
  virtual absl::StatusOr<int> CountUnfinishedJobs(const std::string& owner) = 0;

  // Rebuilds scene `scene_id` whose scene file was found corrupt or missing
  // (`reason` says how). A READY scene goes back to CREATING under a new
  // reconstruction job (QUEUED, its task with the work of the job that
  // built it, no request_id); then, READY or already CREATING, every
  // unfinished render job of the scene waits for it (WAITING_FOR_SCENE)
  // and so do its unfinished chunks: a leased chunk's attempt ends as
  // "scene file corrupt: <reason>" and its worker loses the lease. Returns
  // the scene as it now is. NOT_FOUND when absent; FAILED_PRECONDITION when
  // the scene FAILED. `description` replaces the scene's JSON while it is
  // rebuilt (what CreateSceneJob was given: no statistics of the old build).
  virtual absl::StatusOr<SceneRecord> RebuildScene(const std::string& scene_id,
                                                   const std::string& reason,
                                                   const std::string& description,
                                                   int64_t now_ms) = 0;

  // The scene cache's eviction (--max-blob-bytes): removes the row of the
  // least recently used READY scene that no unfinished render job needs
  // and returns it (the caller removes its scene file); nullopt when every
  // scene is in use or being created. A scene's use (its update time) is
  // its creation, a cache hit of CreateSceneJob, and each lease of one of
  // its render chunks. Jobs and their outputs are never touched.
  virtual absl::StatusOr<std::optional<SceneRecord>> EvictLeastRecentlyUsedScene() = 0;
};

// Opens the store a --store flag names: "sqlite:PATH" (created if absent,
// WAL mode) or "postgresql://USER:PASS@HOST:PORT/DB" (also postgres://; an
// existing database, whose schema is created or migrated here).
// INVALID_ARGUMENT for an unknown scheme; UNAVAILABLE when PostgreSQL cannot
// be reached. Messages never show the password.
absl::StatusOr<std::unique_ptr<JobStore>> OpenJobStore(const std::string& spec,
                                                       const StoreOptions& options);

}  // namespace pf

#endif  // POINTFORWARD_SERVER_STORE_JOB_STORE_H_
