// pf --server ADDR jobs list [--kind reconstruct|render]
// pf --server ADDR jobs get ID | cancel ID | wait ID [--out DIR]
// The server's jobs, through google.longrunning.Operations. ID is
// "operations/X", "renderJobs/X" or "X".
#include <cstdio>
#include <set>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/commands.h"
#include "client/remote/operation_wait.h"
#include "client/remote/remote_commands.h"
#include "client/remote/resource_names.h"
#include "common/command_line.h"
#include "common/file_util.h"
#include "common/status_macros.h"
#include "google/longrunning/operations.grpc.pb.h"
#include "google/protobuf/empty.pb.h"
#include "rpc/grpc_status.h"

namespace pf {

namespace v1 = pointforward::v1;
namespace lro = google::longrunning;

namespace {

constexpr char kRemoteJobsUsage[] =
    "usage: pf --server ADDR jobs list [--kind reconstruct|render]\n"
    "       pf --server ADDR jobs get ID | cancel ID | wait ID [--out DIR]";

constexpr int32_t kListPageSize = 100;

// Returns the state to show: the metadata's, else what `done` implies.
std::string StateOf(const lro::Operation& operation, const v1::OperationMetadata& metadata) {
  if (!metadata.state().empty()) return metadata.state();
  if (!operation.done()) return "RUNNING";
  return operation.has_error() ? "FAILED" : "SUCCEEDED";
}

absl::StatusOr<int> List(RemoteContext& ctx, const CommandLine& cl) {
  if (!cl.positional().empty()) return absl::InvalidArgumentError(kRemoteJobsUsage);
  const std::string kind = cl.Get("kind");
  if (!kind.empty() && kind != "reconstruct" && kind != "render") {
    return absl::InvalidArgumentError(
        absl::StrCat("--kind: '", kind, "' is not one of reconstruct, render"));
  }
  RETURN_IF_ERROR(ctx.Connect());
  lro::ListOperationsRequest request;
  request.set_name("operations");
  request.set_page_size(kListPageSize);
  std::set<std::string> tokens_seen;
  do {
    lro::ListOperationsResponse response;
    grpc::ClientContext call;
    ctx.PrepareCall(call);
    RETURN_IF_ERROR(FromGrpc(ctx.operations().ListOperations(&call, request, &response)));
    for (const lro::Operation& operation : response.operations()) {
      const v1::OperationMetadata metadata = MetadataOf(operation);
      if (!kind.empty() && metadata.kind() != kind) continue;
      const std::string frames =
          metadata.frames_total() > 0
              ? absl::StrCat(metadata.frames_done(), "/", metadata.frames_total(), " frames")
              : "-";
      std::fprintf(ctx.out(), "%-32s %-11s %-17s %-16s%s\n", operation.name().c_str(),
                   metadata.kind().empty() ? "-" : metadata.kind().c_str(),
                   StateOf(operation, metadata).c_str(), frames.c_str(),
                   metadata.cache_hit() ? " cache hit" : "");
    }
    if (!response.next_page_token().empty() &&
        !tokens_seen.insert(response.next_page_token()).second) {
      return absl::InternalError("ListOperations returned the same page token twice");
    }
    request.set_page_token(response.next_page_token());
  } while (!request.page_token().empty());
  return kExitOk;
}

absl::StatusOr<int> Get(RemoteContext& ctx, const std::string& name) {
  RETURN_IF_ERROR(ctx.Connect());
  lro::GetOperationRequest request;
  request.set_name(name);
  lro::Operation operation;
  grpc::ClientContext call;
  ctx.PrepareCall(call);
  RETURN_IF_ERROR(FromGrpc(ctx.operations().GetOperation(&call, request, &operation)));
  ASSIGN_OR_RETURN(const std::string json, ToJson(operation));
  std::fprintf(ctx.out(), "%s\n", json.c_str());
  return kExitOk;
}

absl::StatusOr<int> Cancel(RemoteContext& ctx, const std::string& name) {
  RETURN_IF_ERROR(ctx.Connect());
  lro::CancelOperationRequest request;
  request.set_name(name);
  google::protobuf::Empty empty;
  grpc::ClientContext call;
  ctx.PrepareCall(call);
  RETURN_IF_ERROR(FromGrpc(ctx.operations().CancelOperation(&call, request, &empty)));
  std::fprintf(ctx.out(), "cancel requested: %s\n", name.c_str());
  return kExitOk;
}

absl::StatusOr<int> Wait(RemoteContext& ctx, const std::string& name, const CommandLine& cl) {
  if (cl.Has("out")) RETURN_IF_ERROR(CheckWritableDir("--out", cl.Get("out")));
  RETURN_IF_ERROR(ctx.Connect());
  ASSIGN_OR_RETURN(const lro::Operation operation, WaitForOperation(ctx, name));
  if (ReportOperationFailure(operation)) return kExitFailed;
  const v1::OperationMetadata metadata = MetadataOf(operation);
  v1::Scene scene;
  if (operation.response().UnpackTo(&scene)) {
    PrintSceneSummary(ctx.out(), scene);
    return kExitOk;
  }
  if (cl.Has("out")) {
    RETURN_IF_ERROR(DownloadRenderResult(ctx, operation, cl.Get("out")));
    return kExitOk;
  }
  v1::RenderJob job;
  const int files = operation.response().UnpackTo(&job) ? job.files_size() : 0;
  std::fprintf(ctx.out(), "%s %s: %d files (add --out DIR to download them)\n",
               DisplayName(operation).c_str(), StateOf(operation, metadata).c_str(), files);
  return kExitOk;
}

}  // namespace

absl::StatusOr<int> RunRemoteJobs(RemoteContext& ctx, const std::vector<std::string>& args) {
  if (WantsHelp(args)) {
    std::fprintf(ctx.out(), "%s\n", kRemoteJobsUsage);
    return kExitOk;
  }
  if (args.empty()) return absl::InvalidArgumentError(kRemoteJobsUsage);
  const std::string& verb = args[0];
  const std::vector<std::string> words(args.begin() + 1, args.end());
  if (verb == "list") {
    ASSIGN_OR_RETURN(const CommandLine cl, CommandLine::Parse(words, {"kind"}));
    return List(ctx, cl);
  }
  if (verb != "get" && verb != "cancel" && verb != "wait") {
    return absl::InvalidArgumentError(
        absl::StrCat("unknown jobs command '", verb, "'\n", kRemoteJobsUsage));
  }
  ASSIGN_OR_RETURN(const CommandLine cl,
                   CommandLine::Parse(words, verb == "wait" ? std::set<std::string>{"out"}
                                                            : std::set<std::string>{}));
  if (cl.positional().size() != 1) return absl::InvalidArgumentError(kRemoteJobsUsage);
  ASSIGN_OR_RETURN(const std::string name, OperationNameFor(cl.positional()[0]));
  if (verb == "get") return Get(ctx, name);
  if (verb == "cancel") return Cancel(ctx, name);
  return Wait(ctx, name, cl);
}

}  // namespace pf
