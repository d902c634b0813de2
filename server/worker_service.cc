// WorkerService: workers lease tasks (long poll), heartbeat, complete and
// fail them. Every call after the lease names (task, attempt); the store
// refuses calls of an attempt that lost its lease.
#include <google/protobuf/util/time_util.h>

#include <algorithm>
#include <chrono>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "common/status_macros.h"
#include "pointforward/v1/worker.pb.h"
#include "rpc/grpc_status.h"
#include "server/ownership.h"
#include "server/server_metrics.h"
#include "server/services.h"
#include "server/task_results.h"
#include "spdlog/spdlog.h"

namespace pf {
namespace {

namespace v1 = pointforward::v1;
using google::protobuf::util::TimeUtil;

constexpr auto kLeasePollInterval = std::chrono::milliseconds(100);

absl::Status CheckWorkerId(const std::string& worker_id) {
  if (worker_id.empty() || worker_id.size() > 128) {
    return absl::InvalidArgumentError("worker_id: must be 1 to 128 characters");
  }
  return absl::OkStatus();
}

// The blob `digest` names was uploaded, is intact and has the size it says.
absl::Status CheckBlob(BlobStore& blobs, const v1::Digest& digest, const std::string& field) {
  if (!IsValidSha256Hex(digest.sha256()) || !blobs.Contains(digest.sha256())) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": blob '", digest.sha256(), "' was not uploaded"));
  }
  RETURN_IF_ERROR(blobs.Verify(digest.sha256()));
  ASSIGN_OR_RETURN(const int64_t size, blobs.SizeOf(digest.sha256()));
  if (size != digest.size_bytes()) {
    return absl::InvalidArgumentError(absl::StrCat(field, ".size_bytes: ", digest.size_bytes(),
                                                   ", but the blob has ", size, " bytes"));
  }
  return absl::OkStatus();
}

// FAILED_PRECONDITION unless `task` is leased, in attempt `attempt`, to
// `worker_id`: only the lease holder may heartbeat, complete or fail it.
// Another attempt is left to the store, which refuses it the same way.
absl::Status CheckLeaseHolder(const TaskRecord& task, int attempt, const std::string& worker_id) {
  if (task.state == TaskState::kLeased && task.attempt == attempt && task.worker_id != worker_id) {
    return absl::FailedPreconditionError(absl::StrCat(
        "task ", task.id, " attempt ", attempt, " is not leased to worker '", worker_id, "'"));
  }
  return absl::OkStatus();
}

// Checks a render chunk's result against the chunk's views and the blob
// store: the names of its views' and sweeps' files, each uploaded with its
// size.
absl::Status CheckRenderCompletion(ServiceCore& core, const TaskRecord& task,
                                   const v1::RenderResult& result) {
  ASSIGN_OR_RETURN(const JobRecord job, core.store().GetJob(task.job_id));
  v1::CreateRenderJobRequest request;
  RETURN_IF_ERROR(FromJson(job.request, &request, "stored render request"));
  ASSIGN_OR_RETURN(const RenderChunkNames names,
                   ChunkOutputNames(request.views(), task.first_view, task.view_count));
  RETURN_IF_ERROR(CheckRenderResult(result, names));
  for (int i = 0; i < result.files_size(); ++i) {
    RETURN_IF_ERROR(CheckBlob(core.blobs(), result.files(i).digest(),
                              absl::StrCat("render.files[", i, "].digest")));
  }
  return absl::OkStatus();
}

// Only tokens with the worker or admin role may act as a worker, and with
// --tls-worker-ca only over a connection that presented a client certificate
// signed by that CA (the handshake verified it; here it must be there).
absl::Status AuthorizeWorker(ServiceCore& core, const grpc::ServerContext& context) {
  if (core.options().worker_certificate_required) {
    const std::shared_ptr<const grpc::AuthContext> auth = context.auth_context();
    if (auth == nullptr || !auth->IsPeerAuthenticated()) {
      return absl::UnauthenticatedError(
          "WorkerService needs a client certificate signed by the server's --tls-worker-ca "
          "(pf-worker --tls-cert/--tls-key)");
    }
  }
  absl::StatusOr<Caller> caller = core.CallerOf(context);
  if (!caller.ok()) return caller.status();
  return CheckWorker(*caller);
}

bool IsPermanent(int code) {
  const auto status_code = static_cast<absl::StatusCode>(code);
  return status_code == absl::StatusCode::kInvalidArgument ||
         status_code == absl::StatusCode::kFailedPrecondition ||
         status_code == absl::StatusCode::kNotFound;
}

}  // namespace

grpc::Status WorkerServiceImpl::LeaseTask(grpc::ServerContext* context,
                                          const v1::LeaseTaskRequest* request,
                                          v1::LeaseTaskResponse* response) {
  if (absl::Status ok = AuthorizeWorker(*core_, *context); !ok.ok()) return ToGrpc(ok);
  if (absl::Status ok = CheckWorkerId(request->worker_id()); !ok.ok()) return ToGrpc(ok);
  std::vector<std::string> cached;
  for (const std::string& name : request->cached_scenes()) {
    if (absl::StartsWith(name, "scenes/")) cached.push_back(name.substr(7));
  }
  const int64_t wait_ms = std::clamp<int64_t>(
      request->has_wait() ? TimeUtil::DurationToMilliseconds(request->wait()) : 0, 0,
      core_->options().max_lease_wait_ms);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(wait_ms);
  while (true) {
    // A worker that went away during the long poll gets no task: it could not
    // receive it, and the task would sit leased until its lease expired.
    if (context->IsCancelled()) return grpc::Status::CANCELLED;
    absl::StatusOr<std::optional<TaskLease>> lease =
        core_->store().LeaseTask(request->worker_id(), cached, core_->NowMs());
    if (!lease.ok()) return ToGrpc(lease.status());
    if (lease->has_value()) {
      const TaskLease& leased = **lease;
      absl::StatusOr<v1::Task> task = core_->TaskFor(leased);
      if (!task.ok()) {
        // The stored work cannot be turned into a task: fail it for good
        // rather than hand it out again.
        (void)core_->store().FailTask(leased.task.id, leased.task.attempt,
                                      std::string(task.status().message()), true, core_->NowMs());
        return ToGrpc(task.status());
      }
      // A scene file found corrupt is never handed out: the scene is
      // rebuilt, this chunk waits for it, and another task is leased.
      if (task->has_render()) {
        const absl::Status intact =
            core_->CheckSceneFile(leased.task.scene_id, task->render().scene_file());
        if (intact.code() == absl::StatusCode::kDataLoss) continue;
        if (!intact.ok()) {
          (void)core_->store().FailTask(leased.task.id, leased.task.attempt,
                                        std::string(intact.message()), true, core_->NowMs());
          return ToGrpc(intact);
        }
      }
      spdlog::info("leased {} of operations/{} (attempt {}) to worker {}", TaskLabel(leased.task),
                   leased.job.id, leased.task.attempt, request->worker_id());
      *response->mutable_task() = *std::move(task);
      return grpc::Status::OK;
    }
    if (std::chrono::steady_clock::now() >= deadline || context->IsCancelled()) {
      return grpc::Status::OK;
    }
    std::this_thread::sleep_for(kLeasePollInterval);
  }
}

grpc::Status WorkerServiceImpl::Heartbeat(grpc::ServerContext* context,
                                          const v1::HeartbeatRequest* request,
                                          v1::HeartbeatResponse* response) {
  if (absl::Status ok = AuthorizeWorker(*core_, *context); !ok.ok()) return ToGrpc(ok);
  if (absl::StatusOr<TaskRecord> task = core_->store().GetTask(request->task_id()); task.ok()) {
    const absl::Status holder = CheckLeaseHolder(*task, request->attempt(), request->worker_id());
    if (!holder.ok()) {
      spdlog::warn("heartbeat refused: {}", std::string(holder.message()));
      return ToGrpc(holder);
    }
  }
  int64_t deadline_ms = 0;
  absl::StatusOr<bool> cancelled =
      core_->store().Heartbeat(request->task_id(), request->attempt(), request->progress().stage(),
                               request->progress().fraction(), request->progress().frames_done(),
                               core_->NowMs(), &deadline_ms);
  if (!cancelled.ok()) return ToGrpc(cancelled.status());
  GetServerMetrics().heartbeats->Inc();
  response->set_cancelled(*cancelled);
  *response->mutable_lease_deadline() = TimeUtil::MillisecondsToTimestamp(deadline_ms);
  return grpc::Status::OK;
}

grpc::Status WorkerServiceImpl::CompleteTask(grpc::ServerContext* context,
                                             const v1::CompleteTaskRequest* request,
                                             v1::CompleteTaskResponse*) {
  if (absl::Status ok = AuthorizeWorker(*core_, *context); !ok.ok()) return ToGrpc(ok);
  absl::StatusOr<TaskRecord> task = core_->store().GetTask(request->task_id());
  if (!task.ok()) return ToGrpc(task.status());
  if (absl::Status holder = CheckLeaseHolder(*task, request->attempt(), request->worker_id());
      !holder.ok()) {
    spdlog::warn("completion refused: {}", std::string(holder.message()));
    return ToGrpc(holder);
  }
  std::string result;
  std::string scene_description;
  absl::Status checked;
  if (request->has_reconstruct() && task->kind == JobKind::kReconstruct) {
    checked = CheckReconstructResult(request->reconstruct());
    if (checked.ok()) {
      checked = CheckBlob(core_->blobs(), request->reconstruct().scene().scene_file(),
                          "reconstruct.scene.scene_file");
    }
  } else if (request->has_render() && task->kind == JobKind::kRender) {
    checked = CheckRenderCompletion(*core_, *task, request->render());
  } else {
    checked = absl::InvalidArgumentError(absl::StrCat(
        "result: missing; set ", task->kind == JobKind::kRender ? "render" : "reconstruct"));
  }
  if (!checked.ok()) {
    // A result that does not fit its task ends the attempt (retried like any
    // failure) if it is the current one; the store refuses other attempts.
    spdlog::warn("task {} attempt {} from worker {}: result refused: {}", request->task_id(),
                 request->attempt(), request->worker_id(), std::string(checked.message()));
    (void)core_->store().FailTask(request->task_id(), request->attempt(),
                                  absl::StrCat("result refused: ", checked.message()),
                                  /*permanent=*/false, core_->NowMs());
    return ToGrpc(checked);
  }
  if (request->has_reconstruct()) {
    const v1::Scene& scene = request->reconstruct().scene();
    // The stored description keeps what CreateScene wrote (options, key)
    // and takes the worker's statistics.
    absl::StatusOr<SceneRecord> record = core_->store().GetScene(task->scene_id);
    if (!record.ok()) return ToGrpc(record.status());
    v1::Scene merged;
    if (absl::Status ok = FromJson(record->description, &merged, "stored scene"); !ok.ok()) {
      return ToGrpc(ok);
    }
    const v1::ReconstructionOptions options = merged.options();
    const std::string content_hash = merged.content_hash();
    merged.MergeFrom(scene);
    *merged.mutable_options() = options;
    merged.set_content_hash(content_hash);
    merged.clear_name();
    merged.clear_state();
    merged.clear_operation();
    merged.clear_create_time();
    merged.clear_error();
    result = ToJson(request->reconstruct());
    scene_description = ToJson(merged);
  } else {
    result = ToJson(request->render());
  }
  const absl::Status status = core_->store().CompleteTask(
      request->task_id(), request->attempt(), result, scene_description, core_->NowMs());
  if (status.ok()) {
    spdlog::info("{} of operations/{} (attempt {}) completed by worker {}", TaskLabel(*task),
                 task->job_id, request->attempt(), request->worker_id());
    ServerMetrics& metrics = GetServerMetrics();
    metrics.tasks_completed[static_cast<int>(task->kind)]->Inc();
    absl::StatusOr<JobRecord> job = core_->store().GetJob(task->job_id);
    if (job.ok() && job->state == JobState::kSucceeded) {
      metrics.job_seconds[static_cast<int>(job->kind)]->Observe(
          (job->update_time_ms - job->create_time_ms) / 1000.0);
    }
  } else {
    spdlog::warn("task {} attempt {} from worker {} not completed: {}", request->task_id(),
                 request->attempt(), request->worker_id(), std::string(status.message()));
  }
  return ToGrpc(status);
}

grpc::Status WorkerServiceImpl::FailTask(grpc::ServerContext* context,
                                         const v1::FailTaskRequest* request,
                                         v1::FailTaskResponse*) {
  if (absl::Status ok = AuthorizeWorker(*core_, *context); !ok.ok()) return ToGrpc(ok);
  const bool permanent = IsPermanent(request->error().code());
  absl::StatusOr<TaskRecord> task = core_->store().GetTask(request->task_id());
  if (task.ok()) {
    if (absl::Status holder = CheckLeaseHolder(*task, request->attempt(), request->worker_id());
        !holder.ok()) {
      spdlog::warn("failure report refused: {}", std::string(holder.message()));
      return ToGrpc(holder);
    }
  }
  if (task.ok()) GetServerMetrics().tasks_failed[static_cast<int>(task->kind)]->Inc();
  // A render chunk whose scene file did not arrive intact: when the
  // server's copy is corrupt or gone, the scene is rebuilt and the chunk
  // waits for it instead of failing.
  const auto code = static_cast<absl::StatusCode>(request->error().code());
  if (task.ok() && task->kind == JobKind::kRender && task->attempt == request->attempt() &&
      task->state == TaskState::kLeased &&
      (code == absl::StatusCode::kDataLoss || code == absl::StatusCode::kNotFound)) {
    absl::StatusOr<bool> rebuilding = core_->RebuildIfSceneFileLost(task->scene_id);
    if (rebuilding.ok() && *rebuilding) {
      spdlog::warn("task {} attempt {} on worker {} found scenes/{} corrupt: {}",
                   request->task_id(), request->attempt(), request->worker_id(), task->scene_id,
                   request->error().message());
      return grpc::Status::OK;
    }
    if (!rebuilding.ok()) {
      spdlog::error("checking the scene file of scenes/{}: {}", task->scene_id,
                    std::string(rebuilding.status().message()));
    }
  }
  const absl::Status status =
      core_->store().FailTask(request->task_id(), request->attempt(), request->error().message(),
                              permanent, core_->NowMs());
  spdlog::warn("task {} attempt {} failed on worker {}{}: {}", request->task_id(),
               request->attempt(), request->worker_id(), permanent ? " (permanent)" : "",
               request->error().message());
  return ToGrpc(status);
}

}  // namespace pf
