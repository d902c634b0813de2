// google.longrunning.Operations over the job store: every job is an
// operation named "operations/{job_id}".
#include <google/protobuf/util/time_util.h>

#include <algorithm>
#include <chrono>
#include <optional>
#include <string>
#include <thread>

#include "absl/strings/str_cat.h"
#include "google/longrunning/operations.pb.h"
#include "rpc/grpc_status.h"
#include "server/ownership.h"
#include "server/services.h"
#include "spdlog/spdlog.h"

namespace pf {
namespace {

using google::longrunning::Operation;

constexpr int64_t kMaxWaitMs = 60000;
// The store is read again after kFirstPollInterval, then each interval
// half as long again as the one before, up to kMaxPollInterval.
constexpr auto kFirstPollInterval = std::chrono::milliseconds(100);
constexpr auto kMaxPollInterval = std::chrono::milliseconds(1000);

absl::StatusOr<std::optional<JobKind>> ParseFilter(const std::string& filter) {
  if (filter.empty()) return std::optional<JobKind>();
  if (filter == "kind=reconstruct") return std::optional<JobKind>(JobKind::kReconstruct);
  if (filter == "kind=render") return std::optional<JobKind>(JobKind::kRender);
  return absl::InvalidArgumentError(absl::StrCat("filter: unsupported filter '", filter,
                                                 "'; expected kind=reconstruct or kind=render"));
}

}  // namespace

grpc::Status OperationsServiceImpl::ListOperations(
    grpc::ServerContext* context, const google::longrunning::ListOperationsRequest* request,
    google::longrunning::ListOperationsResponse* response) {
  absl::StatusOr<Caller> caller = core_->CallerOf(*context);
  if (!caller.ok()) return ToGrpc(caller.status());
  absl::StatusOr<std::optional<JobKind>> kind = ParseFilter(request->filter());
  if (!kind.ok()) return ToGrpc(kind.status());
  absl::StatusOr<int> page_size = PageSize(request->page_size());
  if (!page_size.ok()) return ToGrpc(page_size.status());
  // An admin lists every operation; anyone else those it may see.
  absl::StatusOr<Page<JobRecord>> page =
      caller->admin()
          ? core_->store().ListJobs(*kind, *page_size, request->page_token())
          : core_->store().ListJobsOf(caller->owner, *kind, *page_size, request->page_token());
  if (!page.ok()) return ToGrpc(page.status());
  for (const JobRecord& job : page->items) {
    absl::StatusOr<Operation> op = core_->OperationFor(job);
    if (!op.ok()) return ToGrpc(op.status());
    *response->add_operations() = *std::move(op);
  }
  response->set_next_page_token(page->next_page_token);
  return grpc::Status::OK;
}

grpc::Status OperationsServiceImpl::GetOperation(
    grpc::ServerContext* context, const google::longrunning::GetOperationRequest* request,
    Operation* response) {
  absl::StatusOr<Caller> caller = core_->CallerOf(*context);
  if (!caller.ok()) return ToGrpc(caller.status());
  absl::StatusOr<std::string> id = ParseResourceName(request->name(), "operations", "name");
  if (!id.ok()) return ToGrpc(id.status());
  absl::StatusOr<JobRecord> job = core_->store().GetJob(*id);
  if (absl::Status ok =
          job.ok() ? CheckCanSeeJob(*caller, *job, core_->store(), request->name()) : job.status();
      !ok.ok()) {
    return ToGrpc(NotFoundOrStatus(ok, "name", request->name()));
  }
  absl::StatusOr<Operation> op = core_->OperationFor(*job);
  if (!op.ok()) return ToGrpc(op.status());
  *response = *std::move(op);
  return grpc::Status::OK;
}

grpc::Status OperationsServiceImpl::DeleteOperation(
    grpc::ServerContext* context, const google::longrunning::DeleteOperationRequest*,
    google::protobuf::Empty*) {
  absl::StatusOr<Caller> caller = core_->CallerOf(*context);
  if (!caller.ok()) return ToGrpc(caller.status());
  return ToGrpc(absl::UnimplementedError(
      "DeleteOperation: operations live as long as their scene or render job"));
}

grpc::Status OperationsServiceImpl::CancelOperation(
    grpc::ServerContext* context, const google::longrunning::CancelOperationRequest* request,
    google::protobuf::Empty*) {
  absl::StatusOr<Caller> caller = core_->CallerOf(*context);
  if (!caller.ok()) return ToGrpc(caller.status());
  absl::StatusOr<std::string> id = ParseResourceName(request->name(), "operations", "name");
  if (!id.ok()) return ToGrpc(id.status());
  absl::StatusOr<JobRecord> owned = core_->store().GetJob(*id);
  if (absl::Status ok =
          owned.ok() ? CheckCanCancelJob(*caller, *owned, request->name()) : owned.status();
      !ok.ok()) {
    return ToGrpc(NotFoundOrStatus(ok, "name", request->name()));
  }
  absl::StatusOr<JobRecord> job = core_->store().CancelJob(*id, core_->NowMs());
  if (!job.ok()) return ToGrpc(NotFoundOrStatus(job.status(), "name", request->name()));
  spdlog::info("CancelOperation {}: now {}", request->name(), JobStateName(job->state));
  return grpc::Status::OK;
}

grpc::Status OperationsServiceImpl::WaitOperation(
    grpc::ServerContext* context, const google::longrunning::WaitOperationRequest* request,
    Operation* response) {
  absl::StatusOr<Caller> caller = core_->CallerOf(*context);
  if (!caller.ok()) return ToGrpc(caller.status());
  absl::StatusOr<std::string> id = ParseResourceName(request->name(), "operations", "name");
  if (!id.ok()) return ToGrpc(id.status());
  {
    absl::StatusOr<JobRecord> job = core_->store().GetJob(*id);
    if (absl::Status ok = job.ok() ? CheckCanSeeJob(*caller, *job, core_->store(), request->name())
                                   : job.status();
        !ok.ok()) {
      return ToGrpc(NotFoundOrStatus(ok, "name", request->name()));
    }
  }
  // Each long poll holds a thread: capped per caller and in all.
  absl::StatusOr<LongPollLimiter::Slot> slot =
      core_->long_polls().Acquire(ServiceCore::CallerKey(*caller, *context));
  if (!slot.ok()) return ToGrpc(slot.status());
  int64_t wait_ms = kMaxWaitMs;
  if (request->has_timeout()) {
    wait_ms = std::clamp<int64_t>(
        google::protobuf::util::TimeUtil::DurationToMilliseconds(request->timeout()), 0,
        kMaxWaitMs);
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(wait_ms);
  auto interval = std::chrono::duration_cast<std::chrono::milliseconds>(kFirstPollInterval);
  while (true) {
    absl::StatusOr<JobRecord> job = core_->store().GetJob(*id);
    if (!job.ok()) return ToGrpc(NotFoundOrStatus(job.status(), "name", request->name()));
    if (IsTerminal(job->state) || std::chrono::steady_clock::now() >= deadline ||
        context->IsCancelled()) {
      absl::StatusOr<Operation> op = core_->OperationFor(*job);
      if (!op.ok()) return ToGrpc(op.status());
      *response = *std::move(op);
      return grpc::Status::OK;
    }
    std::this_thread::sleep_for(std::min(
        interval, std::chrono::duration_cast<std::chrono::milliseconds>(
                      deadline - std::chrono::steady_clock::now() + std::chrono::milliseconds(1))));
    interval = std::min<std::chrono::milliseconds>(interval * 3 / 2, kMaxPollInterval);
  }
}

}  // namespace pf
