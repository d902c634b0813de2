// Enum names and OpenJobStore, which turns a --store spec into a store.
#include "server/store/job_store.h"

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "common/status_macros.h"
#include "server/store/postgres_database.h"
#include "server/store/sql_job_store.h"
#include "server/store/sqlite_database.h"

namespace pf {

const char* JobKindName(JobKind kind) {
  switch (kind) {
    case JobKind::kReconstruct:
      return "reconstruct";
    case JobKind::kRender:
      return "render";
  }
  return "unknown";
}

const char* JobStateName(JobState state) {
  switch (state) {
    case JobState::kWaitingForScene:
      return "WAITING_FOR_SCENE";
    case JobState::kQueued:
      return "QUEUED";
    case JobState::kRunning:
      return "RUNNING";
    case JobState::kSucceeded:
      return "SUCCEEDED";
    case JobState::kFailed:
      return "FAILED";
    case JobState::kCancelled:
      return "CANCELLED";
  }
  return "UNKNOWN";
}

const char* TaskStateName(TaskState state) {
  switch (state) {
    case TaskState::kWaitingForScene:
      return "WAITING_FOR_SCENE";
    case TaskState::kQueued:
      return "QUEUED";
    case TaskState::kLeased:
      return "LEASED";
    case TaskState::kDone:
      return "DONE";
    case TaskState::kFailed:
      return "FAILED";
    case TaskState::kCancelled:
      return "CANCELLED";
  }
  return "UNKNOWN";
}

const char* SceneStateName(SceneState state) {
  switch (state) {
    case SceneState::kCreating:
      return "CREATING";
    case SceneState::kReady:
      return "READY";
    case SceneState::kFailed:
      return "FAILED";
  }
  return "UNKNOWN";
}

bool IsTerminal(JobState state) {
  return state == JobState::kSucceeded || state == JobState::kFailed ||
         state == JobState::kCancelled;
}

absl::StatusOr<std::unique_ptr<JobStore>> OpenJobStore(const std::string& spec,
                                                       const StoreOptions& options) {
  constexpr absl::string_view kSqlitePrefix = "sqlite:";
  if (absl::StartsWith(spec, kSqlitePrefix)) {
    const std::string path = spec.substr(kSqlitePrefix.size());
    if (path.empty()) {
      return absl::InvalidArgumentError(
          absl::StrCat("store '", spec, "': the SQLite file path is empty (use sqlite:PATH)"));
    }
    ASSIGN_OR_RETURN(std::unique_ptr<SqliteDatabase> db, SqliteDatabase::Open(path));
    ASSIGN_OR_RETURN(std::unique_ptr<SqlJobStore> store, SqlJobStore::Open(std::move(db), options));
    return std::unique_ptr<JobStore>(std::move(store));
  }
  if (absl::StartsWith(spec, "postgresql://") || absl::StartsWith(spec, "postgres://")) {
    // Errors name the spec with its password redacted.
    absl::StatusOr<std::unique_ptr<PostgresDatabase>> db = PostgresDatabase::Open(spec);
    if (!db.ok()) return StatusWithContext(db.status(), "store");
    absl::StatusOr<std::unique_ptr<SqlJobStore>> store = SqlJobStore::Open(*std::move(db), options);
    if (!store.ok()) {
      return StatusWithContext(store.status(),
                               absl::StrCat("store '", RedactPostgresConnection(spec), "'"));
    }
    return std::unique_ptr<JobStore>(*std::move(store));
  }
  return absl::InvalidArgumentError(
      absl::StrCat("store '", RedactPostgresConnection(spec),
                   "': unknown kind of store; accepted forms: sqlite:PATH, "
                   "postgresql://USER:PASS@HOST:PORT/DB"));
}

}  // namespace pf
