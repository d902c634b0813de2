// The wait loop over google.longrunning.Operations.
#include "client/remote/operation_wait.h"

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <thread>

#include "absl/strings/str_cat.h"
#include "client/remote/progress.h"
#include "common/status_macros.h"
#include "rpc/grpc_status.h"

namespace pf {

namespace v1 = pointforward::v1;
namespace lro = google::longrunning;

namespace {

constexpr std::chrono::seconds kWaitTimeout{1};
constexpr std::chrono::milliseconds kPollInterval{500};

// Asks WaitOperation for at most kWaitTimeout.
grpc::Status CallWait(RemoteContext& ctx, const std::string& name, lro::Operation* operation) {
  lro::WaitOperationRequest request;
  request.set_name(name);
  request.mutable_timeout()->set_seconds(kWaitTimeout.count());
  grpc::ClientContext call;
  ctx.PrepareCall(call, std::chrono::seconds(30));
  return ctx.operations().WaitOperation(&call, request, operation);
}

grpc::Status CallGet(RemoteContext& ctx, const std::string& name, lro::Operation* operation) {
  lro::GetOperationRequest request;
  request.set_name(name);
  grpc::ClientContext call;
  ctx.PrepareCall(call);
  return ctx.operations().GetOperation(&call, request, operation);
}

}  // namespace

v1::OperationMetadata MetadataOf(const lro::Operation& operation) {
  v1::OperationMetadata metadata;
  if (operation.has_metadata()) operation.metadata().UnpackTo(&metadata);
  return metadata;
}

std::string DisplayName(const lro::Operation& operation) {
  const v1::OperationMetadata metadata = MetadataOf(operation);
  return metadata.target().empty() ? operation.name() : metadata.target();
}

absl::StatusOr<lro::Operation> WaitForOperation(RemoteContext& ctx, const std::string& name) {
  ProgressReporter progress(stderr, isatty(fileno(stderr)) != 0);
  bool use_wait = true;
  while (true) {
    lro::Operation operation;
    grpc::Status status =
        use_wait ? CallWait(ctx, name, &operation) : CallGet(ctx, name, &operation);
    // An older server, or one holding as many long polls as it may: poll
    // with GetOperation instead.
    if (use_wait && (status.error_code() == grpc::StatusCode::UNIMPLEMENTED ||
                     status.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED)) {
      use_wait = false;
      continue;
    }
    if (!status.ok()) {
      progress.Finish();
      return StatusWithContext(FromGrpc(status), name);
    }
    progress.Update(DisplayName(operation), MetadataOf(operation));
    if (operation.done()) {
      progress.Finish();
      return operation;
    }
    if (!use_wait) std::this_thread::sleep_for(kPollInterval);
  }
}

bool ReportOperationFailure(const lro::Operation& operation) {
  if (!operation.has_error()) return false;
  const v1::OperationMetadata metadata = MetadataOf(operation);
  const bool cancelled = operation.error().code() == static_cast<int>(grpc::StatusCode::CANCELLED);
  std::string state = metadata.state();
  if (state.empty() || state == "RUNNING") state = cancelled ? "CANCELLED" : "FAILED";
  std::fprintf(stderr, "pf: %s %s: %s\n", DisplayName(operation).c_str(), state.c_str(),
               operation.error().message().c_str());
  return true;
}

}  // namespace pf
