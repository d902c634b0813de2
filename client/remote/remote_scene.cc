// pf --server ADDR scene create CLIP.json [--wait] [recon flags] [--request-id ID]
// pf --server ADDR scene get NAME | list [--page-size N] | delete NAME
// pf --server ADDR scene export NAME --ply OUT.ply [--time-us T]
// Scenes on the server: reconstructing one from a clip (uploaded, or a
// file:// URI the server reads), inspecting, listing, deleting and exporting
// them as a 3DGS PLY.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/commands.h"
#include "client/remote/clip_upload.h"
#include "client/remote/operation_wait.h"
#include "client/remote/remote_commands.h"
#include "client/remote/resource_names.h"
#include "common/command_line.h"
#include "common/file_util.h"
#include "common/hash.h"
#include "common/status_macros.h"
#include "engine/recon/recon_option_table.h"
#include "google/longrunning/operations.pb.h"
#include "google/protobuf/empty.pb.h"
#include "pointforward/v1/service.grpc.pb.h"
#include "rpc/grpc_status.h"

namespace pf {

namespace v1 = pointforward::v1;
namespace lro = google::longrunning;

namespace {

constexpr char kRemoteSceneUsage[] =
    "usage: pf --server ADDR scene create CLIP.json|file:///abs/clip.json [--wait] [--model M] "
    "[--ns N] [--nd N] [--fusion F] [--lifespan] [--device D] [--request-id ID]\n"
    "         [--refine N] [--splat-sigma S] [--low-pass PX2] [--order-band B] [--fade-frames F] "
    "[--hidden-band PX] "
    "[--colour-fit-memory GB] "
    "[--no-ground-fill] "
    "[--no-facades] [--no-stereo] [--no-ego-layer] [--render-blur PX] [--render-blur-growth G] "
    "[--still-rig-density F] "
    "[--colour gradients|flat] "
    "[--completion nearest|ip-basic] [--working-space srgb|linear] "
    "[--optimize-steps N [--optimize-seconds S] [--optimize-poses] [--optimize-densify]]\n"
    "       pf --server ADDR scene get NAME | list [--page-size N [--page-token T]] | delete "
    "NAME\n"
    "       pf --server ADDR scene export NAME --ply OUT.ply [--time-us T]";

absl::Status Usage() { return absl::InvalidArgumentError(kRemoteSceneUsage); }

// Parses `words` and checks the number of positional words.
absl::StatusOr<CommandLine> ParseWords(const std::vector<std::string>& words, size_t positional,
                                       const std::set<std::string>& value_flags,
                                       const std::set<std::string>& bool_flags = {}) {
  ASSIGN_OR_RETURN(CommandLine cl, CommandLine::Parse(words, value_flags, bool_flags));
  if (cl.positional().size() != positional) return Usage();
  return cl;
}

absl::StatusOr<int> Create(RemoteContext& ctx, const std::vector<std::string>& words) {
  std::set<std::string> value_flags = ReconValueFlags();
  value_flags.insert("request-id");
  std::set<std::string> bool_flags = ReconSwitchFlags();
  bool_flags.insert("wait");
  ASSIGN_OR_RETURN(const CommandLine cl, ParseWords(words, 1, value_flags, bool_flags));
  v1::CreateSceneRequest request;
  ASSIGN_OR_RETURN(*request.mutable_options(), ReconstructionOptionsFromFlags(cl));
  request.set_request_id(cl.Get("request-id"));
  ASSIGN_OR_RETURN(const ClipInput clip, PrepareClipInput(cl.positional()[0]));

  RETURN_IF_ERROR(ctx.Connect());
  ASSIGN_OR_RETURN(*request.mutable_clip(), SendClipInput(clip, ctx.blobs()));
  lro::Operation operation;
  grpc::ClientContext call;
  ctx.PrepareCall(call);
  RETURN_IF_ERROR(FromGrpc(ctx.scenes().CreateScene(&call, request, &operation)));
  std::fprintf(ctx.out(), "%s\n", operation.name().c_str());
  const v1::OperationMetadata metadata = MetadataOf(operation);
  if (operation.done() && metadata.cache_hit()) {
    std::fprintf(ctx.out(), "cache hit: %s\n", DisplayName(operation).c_str());
  }
  if (!cl.Has("wait")) return ReportOperationFailure(operation) ? kExitFailed : kExitOk;

  if (!operation.done()) {
    ASSIGN_OR_RETURN(operation, WaitForOperation(ctx, operation.name()));
  }
  if (ReportOperationFailure(operation)) return kExitFailed;
  v1::Scene scene;
  if (!operation.response().UnpackTo(&scene)) {
    return absl::InternalError(absl::StrCat(operation.name(), ": the response is not a Scene"));
  }
  PrintSceneSummary(ctx.out(), scene);
  return kExitOk;
}

absl::StatusOr<int> Get(RemoteContext& ctx, const std::vector<std::string>& words) {
  ASSIGN_OR_RETURN(const CommandLine cl, ParseWords(words, 1, {}));
  v1::GetSceneRequest request;
  ASSIGN_OR_RETURN(*request.mutable_name(), SceneNameFor(cl.positional()[0]));
  RETURN_IF_ERROR(ctx.Connect());
  v1::Scene scene;
  grpc::ClientContext call;
  ctx.PrepareCall(call);
  RETURN_IF_ERROR(FromGrpc(ctx.scenes().GetScene(&call, request, &scene)));
  ASSIGN_OR_RETURN(const std::string json, ToJson(scene));
  std::fprintf(ctx.out(), "%s\n", json.c_str());
  return kExitOk;
}

// Without --page-size, every scene (page after page); with it, one page of
// that many, and on stderr the command that prints the next one.
absl::StatusOr<int> List(RemoteContext& ctx, const std::vector<std::string>& words) {
  ASSIGN_OR_RETURN(const CommandLine cl, ParseWords(words, 0, {"page-size", "page-token"}));
  ASSIGN_OR_RETURN(const int64_t page_size, cl.GetInt("page-size", 0));
  if (page_size < 0 || page_size > 1000) {
    return absl::InvalidArgumentError("--page-size: must be in [0, 1000]");
  }
  if (cl.Has("page-token") && !cl.Has("page-size")) {
    return absl::InvalidArgumentError("--page-token: needs --page-size");
  }
  const bool one_page = cl.Has("page-size");
  RETURN_IF_ERROR(ctx.Connect());
  v1::ListScenesRequest request;
  request.set_page_size(static_cast<int32_t>(page_size));
  request.set_page_token(cl.Get("page-token"));
  std::set<std::string> tokens_seen;
  do {
    v1::ListScenesResponse response;
    grpc::ClientContext call;
    ctx.PrepareCall(call);
    RETURN_IF_ERROR(FromGrpc(ctx.scenes().ListScenes(&call, request, &response)));
    for (const v1::Scene& scene : response.scenes()) {
      std::fprintf(ctx.out(), "%-32s %-8s %-14s %lld gaussians\n", scene.name().c_str(),
                   v1::Scene::State_Name(scene.state()).c_str(),
                   scene.model().empty() ? "-" : scene.model().c_str(),
                   static_cast<long long>(scene.gaussians()));
    }
    if (one_page) {
      if (!response.next_page_token().empty()) {
        std::fprintf(stderr, "more: pf --server %s scene list --page-size %lld --page-token %s\n",
                     ctx.address().c_str(), static_cast<long long>(page_size),
                     response.next_page_token().c_str());
      }
      return kExitOk;
    }
    if (!response.next_page_token().empty() &&
        !tokens_seen.insert(response.next_page_token()).second) {
      return absl::InternalError("ListScenes returned the same page token twice");
    }
    request.set_page_token(response.next_page_token());
  } while (!request.page_token().empty());
  return kExitOk;
}

absl::StatusOr<int> Delete(RemoteContext& ctx, const std::vector<std::string>& words) {
  ASSIGN_OR_RETURN(const CommandLine cl, ParseWords(words, 1, {}));
  v1::DeleteSceneRequest request;
  ASSIGN_OR_RETURN(*request.mutable_name(), SceneNameFor(cl.positional()[0]));
  RETURN_IF_ERROR(ctx.Connect());
  google::protobuf::Empty empty;
  grpc::ClientContext call;
  ctx.PrepareCall(call);
  RETURN_IF_ERROR(FromGrpc(ctx.scenes().DeleteScene(&call, request, &empty)));
  std::fprintf(ctx.out(), "deleted %s\n", request.name().c_str());
  return kExitOk;
}

// Streams ExportScene into `temp_path`, hashing as it goes; checks the hash
// the last chunk carries. Returns the number of bytes.
absl::StatusOr<int64_t> ReceivePly(RemoteContext& ctx, const v1::ExportSceneRequest& request,
                                   const std::string& temp_path) {
  std::ofstream file(temp_path, std::ios::binary | std::ios::trunc);
  if (!file) return absl::InternalError(absl::StrCat(temp_path, ": cannot create"));
  grpc::ClientContext call;
  ctx.PrepareCall(call, std::chrono::seconds(600));
  std::unique_ptr<grpc::ClientReader<v1::ExportSceneChunk>> reader =
      ctx.scenes().ExportScene(&call, request);
  Sha256 hasher;
  int64_t bytes = 0;
  std::string expected_sha256;
  v1::ExportSceneChunk chunk;
  while (reader->Read(&chunk)) {
    if (!expected_sha256.empty()) {
      call.TryCancel();
      reader->Finish();
      return absl::DataLossError(
          absl::StrCat(request.name(), ": ExportScene sent data after the chunk with the hash"));
    }
    hasher.Update(chunk.data());
    file.write(chunk.data().data(), static_cast<std::streamsize>(chunk.data().size()));
    bytes += static_cast<int64_t>(chunk.data().size());
    expected_sha256 = chunk.sha256();
  }
  RETURN_IF_ERROR(FromGrpc(reader->Finish()));
  file.close();
  if (!file) return absl::InternalError(absl::StrCat(temp_path, ": write failed (disk full?)"));
  if (expected_sha256.empty()) {
    return absl::DataLossError(
        absl::StrCat(request.name(), ": ExportScene ended without the file's sha256"));
  }
  const std::string actual = hasher.FinishHex();
  if (actual != expected_sha256) {
    return absl::DataLossError(absl::StrCat(request.name(), ": exported PLY has sha256 ", actual,
                                            ", the server sent ", expected_sha256));
  }
  return bytes;
}

absl::StatusOr<int> Export(RemoteContext& ctx, const std::vector<std::string>& words) {
  ASSIGN_OR_RETURN(const CommandLine cl, ParseWords(words, 1, {"ply", "time-us"}));
  if (!cl.Has("ply")) return Usage();
  v1::ExportSceneRequest request;
  ASSIGN_OR_RETURN(*request.mutable_name(), SceneNameFor(cl.positional()[0]));
  ASSIGN_OR_RETURN(const int64_t time_us, cl.GetInt("time-us", 0));
  if (cl.Has("time-us")) request.set_time_us(time_us);
  const std::string out = cl.Get("ply");
  RETURN_IF_ERROR(ctx.Connect());

  const std::filesystem::path parent = std::filesystem::path(out).parent_path();
  if (!parent.empty()) RETURN_IF_ERROR(MakeDirs(parent.string()));
  const std::string temp_path = TempPathFor(out);
  const absl::StatusOr<int64_t> bytes = ReceivePly(ctx, request, temp_path);
  if (!bytes.ok()) {
    std::error_code ignored;
    std::filesystem::remove(temp_path, ignored);
    return bytes.status();
  }
  RETURN_IF_ERROR(CommitTempFile(temp_path, out));
  // Without --time-us the server places actors at the scene's time origin,
  // which the client does not know.
  const std::string when =
      cl.Has("time-us") ? absl::StrCat(time_us, " us") : std::string("the scene's time origin");
  std::fprintf(ctx.out(), "wrote %s: %lld bytes of %s at %s (sha256 checked)\n", out.c_str(),
               static_cast<long long>(*bytes), request.name().c_str(), when.c_str());
  return kExitOk;
}

}  // namespace

absl::StatusOr<v1::ReconstructionOptions> ReconstructionOptionsFromFlags(const CommandLine& cl) {
  // Checked here as the local flags are, naming the flag; the server checks
  // them again, naming the field.
  return ReconProtoFromFlags(cl, BuiltInReconModelNames());
}

void PrintSceneSummary(std::FILE* out, const v1::Scene& scene) {
  std::fprintf(out, "scene:      %s\n", scene.name().c_str());
  std::fprintf(out, "state:      %s\n", v1::Scene::State_Name(scene.state()).c_str());
  std::fprintf(out, "model:      %s\n", scene.model().c_str());
  std::fprintf(out, "gaussians:  %lld (static %lld, dynamic %lld, far %lld)\n",
               static_cast<long long>(scene.gaussians()),
               static_cast<long long>(scene.static_gaussians()),
               static_cast<long long>(scene.dynamic_gaussians()),
               static_cast<long long>(scene.far_gaussians()));
  std::fprintf(out, "instances:  %d\n", scene.instances_size());
  std::fprintf(out, "time:       [%lld, %lld] us\n", static_cast<long long>(scene.start_time_us()),
               static_cast<long long>(scene.end_time_us()));
  std::fprintf(out, "channels:   %d\n", scene.num_channels());
  std::fprintf(out, "content:    %s\n", scene.content_hash().c_str());
}

absl::StatusOr<int> RunRemoteScene(RemoteContext& ctx, const std::vector<std::string>& args) {
  if (WantsHelp(args)) {
    std::fprintf(ctx.out(), "%s\n", kRemoteSceneUsage);
    return kExitOk;
  }
  if (args.empty()) return Usage();
  const std::string& verb = args[0];
  const std::vector<std::string> words(args.begin() + 1, args.end());
  if (verb == "create") return Create(ctx, words);
  if (verb == "get") return Get(ctx, words);
  if (verb == "list") return List(ctx, words);
  if (verb == "delete") return Delete(ctx, words);
  if (verb == "export") return Export(ctx, words);
  return absl::InvalidArgumentError(
      absl::StrCat("unknown scene command '", verb, "'\n", kRemoteSceneUsage));
}

}  // namespace pf
