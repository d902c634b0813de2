// JobStore over any SqlDatabase: the whole job, task and scene logic in
// portable SQL, written once for SQLite and PostgreSQL.
//
//   ASSIGN_OR_RETURN(std::unique_ptr<SqliteDatabase> db, SqliteDatabase::Open(path));
//   ASSIGN_OR_RETURN(std::unique_ptr<SqlJobStore> store, SqlJobStore::Open(std::move(db), {}));
//
// The schema is versioned: Open applies, in order, every migration step the
// database's schema_migrations table does not list yet, each in its own
// transaction. New steps are appended to the list in sql_job_store.cc; a
// step is never edited once released.
//
// Failure codes stored on a job (JobRecord::error_code):
//   - a task failed with `permanent` set (bad input): INVALID_ARGUMENT;
//   - a task ran out of attempts (crashes, expired leases): ABORTED;
//   - a render job whose scene could not be created: FAILED_PRECONDITION;
//   - CancelJob: CANCELLED.
// The message of a task failure lists every attempt, e.g.
//   "chunk 2 (views 4-5) failed after 3 attempts: attempt 1 on worker w1:
//    lease expired; attempt 2 on worker w2: failed: out of memory; ..."
#ifndef POINTFORWARD_SERVER_STORE_SQL_JOB_STORE_H_
#define POINTFORWARD_SERVER_STORE_SQL_JOB_STORE_H_

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "server/store/job_store.h"
#include "server/store/sql_database.h"

namespace pf {

// Applies the migration steps `db` has not recorded yet; returns how many it
// applied (0 when the schema is current). FAILED_PRECONDITION when the
// database records a version newer than this binary knows.
absl::StatusOr<int> ApplyMigrations(SqlDatabase& db);

// The schema version the last migration step produces.
int LatestSchemaVersion();

class SqlJobStore : public JobStore {
 public:
  // Migrates `db` and returns a store over it. INVALID_ARGUMENT for options
  // out of range (max_attempts < 1, lease_duration_ms < 1).
  static absl::StatusOr<std::unique_ptr<SqlJobStore>> Open(std::unique_ptr<SqlDatabase> db,
                                                           const StoreOptions& options);

  absl::StatusOr<CreateSceneOutcome> CreateSceneJob(
      const std::string& scene_id, const std::string& content_hash, const std::string& description,
      const std::string& request_id, const std::string& request, const std::string& work,
      const std::string& owner, int64_t now_ms) override;
  absl::StatusOr<SceneRecord> GetScene(const std::string& scene_id) override;
  absl::StatusOr<Page<SceneRecord>> ListScenes(int page_size,
                                               const std::string& page_token) override;
  absl::Status DeleteScene(const std::string& scene_id, int64_t now_ms) override;

  absl::StatusOr<JobRecord> CreateRenderJob(const std::string& scene_id,
                                            const std::string& request_id,
                                            const std::string& request, int frames_total,
                                            const std::vector<NewTask>& tasks,
                                            const std::string& owner, int64_t now_ms,
                                            bool* same_request) override;

  absl::StatusOr<JobRecord> GetJob(const std::string& job_id) override;
  absl::StatusOr<Page<JobRecord>> ListJobs(std::optional<JobKind> kind, int page_size,
                                           const std::string& page_token) override;
  absl::StatusOr<TaskRecord> GetTask(const std::string& task_id) override;
  absl::StatusOr<std::vector<TaskRecord>> ListTasks(const std::string& job_id) override;
  absl::StatusOr<JobRecord> CancelJob(const std::string& job_id, int64_t now_ms) override;

  absl::StatusOr<std::optional<TaskLease>> LeaseTask(const std::string& worker_id,
                                                     const std::vector<std::string>& cached_scenes,
                                                     int64_t now_ms) override;
  absl::StatusOr<bool> Heartbeat(const std::string& task_id, int attempt, const std::string& stage,
                                 double fraction, int frames_done, int64_t now_ms,
                                 int64_t* deadline_ms) override;
  absl::Status CompleteTask(const std::string& task_id, int attempt, const std::string& result,
                            const std::string& scene_description, int64_t now_ms) override;
  absl::Status FailTask(const std::string& task_id, int attempt, const std::string& reason,
                        bool permanent, int64_t now_ms) override;
  absl::StatusOr<int> ExpireLeases(int64_t now_ms) override;
  absl::StatusOr<int> CountQueuedTasks(JobKind kind) override;
  absl::StatusOr<int> CountJobs(JobKind kind, JobState state) override;
  absl::StatusOr<bool> HasSceneAccess(const std::string& owner,
                                      const std::string& scene_id) override;
  absl::StatusOr<Page<SceneRecord>> ListScenesOf(const std::string& owner, int page_size,
                                                 const std::string& page_token) override;
  absl::StatusOr<Page<JobRecord>> ListJobsOf(const std::string& owner, std::optional<JobKind> kind,
                                             int page_size, const std::string& page_token) override;
  absl::StatusOr<int> CountUnfinishedJobs(const std::string& owner) override;
  absl::StatusOr<SceneRecord> RebuildScene(const std::string& scene_id, const std::string& reason,
                                           const std::string& description, int64_t now_ms) override;
  absl::StatusOr<std::optional<SceneRecord>> EvictLeastRecentlyUsedScene() override;

 private:
  SqlJobStore(std::unique_ptr<SqlDatabase> db, const StoreOptions& options)
      : db_(std::move(db)), options_(options) {}

  std::unique_ptr<SqlDatabase> db_;
  const StoreOptions options_;
};

}  // namespace pf

#endif  // POINTFORWARD_SERVER_STORE_SQL_JOB_STORE_H_
