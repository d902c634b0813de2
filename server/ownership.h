// Who may see and change which jobs and scenes, once a caller is
// authenticated (auth.h). Admins may do everything. Otherwise:
//  - a render job, or any job's CancelOperation: only its owner;
//  - a scene (GetScene, ExportScene, DeleteScene, rendering it): an owner
//    with access to it (job_store.h, "Owners": it submitted the scene's
//    clip, or a render job of it);
//  - a reconstruction's operation (Get/Wait): its owner, or an owner with
//    access to its scene (a CreateScene that hit the cache or joined the
//    build in flight returns the operation another owner started).
// Refusals are NOT_FOUND, worded as for a resource that does not exist
// (AIP-211: a caller cannot tell what it may not see from what is absent):
// "operations/3f2a not found"; handlers put the request's field before it
// with NotFoundOrStatus.
#ifndef POINTFORWARD_SERVER_OWNERSHIP_H_
#define POINTFORWARD_SERVER_OWNERSHIP_H_

#include <string>

#include "absl/status/status.h"
#include "server/auth.h"
#include "server/store/job_store.h"

namespace pf {

// `name` is the resource as the request named it ("operations/X").
absl::Status CheckCanSeeJob(const Caller& caller, const JobRecord& job, JobStore& store,
                            const std::string& name);
absl::Status CheckCanCancelJob(const Caller& caller, const JobRecord& job, const std::string& name);
absl::Status CheckCanUseScene(const Caller& caller, const std::string& scene_id, JobStore& store,
                              const std::string& name);
// For a lookup of resource `name` given in request field `field`: when
// `status` is NOT_FOUND (absent, or refused above), NOT_FOUND
// "<field>: <name> not found"; any other status unchanged.
absl::Status NotFoundOrStatus(const absl::Status& status, const std::string& field,
                              const std::string& name);
// WorkerService: PERMISSION_DENIED unless the caller has the worker or
// admin role.
absl::Status CheckWorker(const Caller& caller);

}  // namespace pf

#endif  // POINTFORWARD_SERVER_OWNERSHIP_H_
