// The ownership rules: see ownership.h.
#include "server/ownership.h"

#include "absl/strings/str_cat.h"
#include "common/status_macros.h"

namespace pf {
namespace {

absl::Status AnotherOwners(const std::string& name) {
  return absl::NotFoundError(absl::StrCat(name, " not found"));
}

}  // namespace

absl::Status CheckCanSeeJob(const Caller& caller, const JobRecord& job, JobStore& store,
                            const std::string& name) {
  if (caller.admin() || job.owner == caller.owner) return absl::OkStatus();
  if (job.kind == JobKind::kReconstruct) {
    ASSIGN_OR_RETURN(const bool access, store.HasSceneAccess(caller.owner, job.scene_id));
    if (access) return absl::OkStatus();
  }
  return AnotherOwners(name);
}

absl::Status CheckCanCancelJob(const Caller& caller, const JobRecord& job,
                               const std::string& name) {
  if (caller.admin() || job.owner == caller.owner) return absl::OkStatus();
  return AnotherOwners(name);
}

absl::Status CheckCanUseScene(const Caller& caller, const std::string& scene_id, JobStore& store,
                              const std::string& name) {
  if (caller.admin()) return absl::OkStatus();
  ASSIGN_OR_RETURN(const bool access, store.HasSceneAccess(caller.owner, scene_id));
  if (access) return absl::OkStatus();
  return AnotherOwners(name);
}

absl::Status NotFoundOrStatus(const absl::Status& status, const std::string& field,
                              const std::string& name) {
  if (status.code() != absl::StatusCode::kNotFound) return status;
  return absl::NotFoundError(absl::StrCat(field, ": ", name, " not found"));
}

absl::Status CheckWorker(const Caller& caller) {
  if (caller.worker()) return absl::OkStatus();
  return absl::PermissionDeniedError(
      absl::StrCat("WorkerService needs a worker or admin token; the token of owner '",
                   caller.owner, "' has the ", RoleName(caller.role), " role"));
}

}  // namespace pf
