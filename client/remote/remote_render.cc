// pf --server ADDR render SCENE --cameras VIEWS.json [--out DIR --wait]
//     [--outputs LIST] [--chunk-frames N] [--request-id ID]
// pf --server ADDR render --clip CLIP.json [recon flags] --cameras VIEWS.json ...
// Submits a render job for views of a scene on the server (or of the scene
// of a clip, reconstructed first when the server has not cached it). With
// --wait, waits for it and downloads every file it produced into DIR.
#include <cstdio>
#include <set>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/commands.h"
#include "client/remote/clip_upload.h"
#include "client/remote/operation_wait.h"
#include "client/remote/output_files.h"
#include "client/remote/remote_commands.h"
#include "client/remote/resource_names.h"
#include "common/bounded_json.h"
#include "common/command_line.h"
#include "common/file_util.h"
#include "common/status_macros.h"
#include "engine/recon/recon_option_table.h"
#include "engine/render/views.h"
#include "google/longrunning/operations.pb.h"
#include "pointforward/v1/service.grpc.pb.h"
#include "pointforward/v1/views.pb.h"
#include "rpc/grpc_status.h"

namespace pf {

namespace v1 = pointforward::v1;
namespace lro = google::longrunning;

namespace {

constexpr char kRemoteRenderUsage[] =
    "usage: pf --server ADDR render SCENE --cameras VIEWS.json [--out DIR --wait] "
    "[--outputs rgb,alpha,depth,features,instance,filled] [--chunk-frames N] [--request-id ID]\n"
    "       pf --server ADDR render --clip CLIP.json [--model M] [--ns N] [--nd N] [--fusion F] "
    "[--lifespan] [--device D] [--refine N] [--splat-sigma S] [--low-pass PX2] "
    "[--order-band B] [--fade-frames F] [--hidden-band PX] [--colour-fit-memory GB] "
    "[--no-ground-fill] "
    "[--no-facades] [--no-stereo] "
    "[--no-ego-layer] [--render-blur PX] [--render-blur-growth G] [--still-rig-density F] "
    "[--colour gradients|flat] "
    "[--completion nearest|ip-basic] [--working-space srgb|linear] "
    "[--optimize-steps N [--optimize-seconds S] [--optimize-poses] [--optimize-densify]] --cameras "
    "VIEWS.json [--out DIR --wait] "
    "...";

// Reads VIEWS.json as pointforward.v1.RenderViews; errors name the file.
absl::StatusOr<v1::RenderViews> LoadViews(const std::string& path) {
  ASSIGN_OR_RETURN(const std::string json, ReadFileToString(path));
  v1::RenderViews views;
  if (const absl::Status parsed = ParseBoundedProtoJson(json, &views); !parsed.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": not a RenderViews JSON: ", parsed.message()));
  }
  if (RenderItemCount(views) == 0) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": views: no views or lidars to render"));
  }
  return views;
}

// Where the render target comes from: a scene name or a clip to upload.
struct RenderTarget {
  std::string scene;  // "scenes/X"; empty when `clip` is used.
  ClipInput clip;
};

absl::StatusOr<RenderTarget> TargetFromFlags(const CommandLine& cl) {
  RenderTarget target;
  if (cl.Has("clip")) {
    if (!cl.positional().empty()) {
      return absl::InvalidArgumentError(
          absl::StrCat("give a SCENE or --clip, not both\n", kRemoteRenderUsage));
    }
    ASSIGN_OR_RETURN(target.clip, PrepareClipInput(cl.Get("clip")));
    return target;
  }
  if (cl.positional().size() != 1) return absl::InvalidArgumentError(kRemoteRenderUsage);
  ASSIGN_OR_RETURN(target.scene, SceneNameFor(cl.positional()[0]));
  return target;
}

}  // namespace

absl::Status DownloadRenderResult(RemoteContext& ctx, const lro::Operation& operation,
                                  const std::string& out_dir) {
  v1::RenderJob job;
  if (!operation.response().UnpackTo(&job)) {
    // Not in the response: ask for the job itself.
    v1::GetRenderJobRequest request;
    request.set_name(MetadataOf(operation).target());
    if (request.name().empty()) {
      return absl::InternalError(absl::StrCat(operation.name(), ": names no render job"));
    }
    grpc::ClientContext call;
    ctx.PrepareCall(call);
    RETURN_IF_ERROR(FromGrpc(ctx.renders().GetRenderJob(&call, request, &job)));
  }
  ASSIGN_OR_RETURN(const int files, DownloadOutputs(ctx.blobs(), job, out_dir));
  std::fprintf(ctx.out(), "downloaded %d files to %s\n", files, out_dir.c_str());
  return absl::OkStatus();
}

absl::StatusOr<int> RunRemoteRender(RemoteContext& ctx, const std::vector<std::string>& args) {
  if (WantsHelp(args)) {
    std::fprintf(ctx.out(), "%s\n", kRemoteRenderUsage);
    return kExitOk;
  }
  std::set<std::string> value_flags = ReconValueFlags();
  value_flags.insert({"cameras", "out", "outputs", "chunk-frames", "request-id", "clip"});
  std::set<std::string> bool_flags = ReconSwitchFlags();
  bool_flags.insert("wait");
  ASSIGN_OR_RETURN(const CommandLine cl, CommandLine::Parse(args, value_flags, bool_flags));
  RETURN_IF_ERROR(cl.Require({"cameras"}, kRemoteRenderUsage));
  if (cl.Has("wait") && !cl.Has("out")) {
    return absl::InvalidArgumentError("--wait needs --out DIR to download the outputs into");
  }

  ASSIGN_OR_RETURN(const RenderTarget target, TargetFromFlags(cl));
  if (!target.scene.empty()) {
    // A scene exists already: how it was reconstructed is settled.
    for (const std::set<std::string>& flags : {ReconValueFlags(), ReconSwitchFlags()}) {
      for (const std::string& flag : flags) {
        if (cl.Has(flag)) {
          return absl::InvalidArgumentError(absl::StrCat(
              "--", flag, ": a reconstruction flag, only for render --clip; ", target.scene,
              " is reconstructed already (its options are in scene get)"));
        }
      }
    }
  }
  v1::CreateRenderJobRequest request;
  ASSIGN_OR_RETURN(*request.mutable_views(), LoadViews(cl.Get("cameras")));
  for (const std::string& output : cl.GetList("outputs")) request.add_outputs(output);
  request.set_request_id(cl.Get("request-id"));
  ASSIGN_OR_RETURN(const int64_t chunk_frames, cl.GetInt("chunk-frames", 0));
  if (chunk_frames < 0 || chunk_frames > (1 << 30)) {
    return absl::InvalidArgumentError("--chunk-frames: must be a positive number of views");
  }
  request.set_chunk_frames(static_cast<int32_t>(chunk_frames));
  if (target.scene.empty()) {
    ASSIGN_OR_RETURN(*request.mutable_create_scene()->mutable_options(),
                     ReconstructionOptionsFromFlags(cl));
  }

  // Where the outputs go is checked before anything is sent, not after the
  // job has rendered.
  if (cl.Has("out")) RETURN_IF_ERROR(CheckWritableDir("--out", cl.Get("out")));
  RETURN_IF_ERROR(ctx.Connect());
  if (target.scene.empty()) {
    ASSIGN_OR_RETURN(*request.mutable_create_scene()->mutable_clip(),
                     SendClipInput(target.clip, ctx.blobs()));
  } else {
    request.set_scene(target.scene);
  }
  lro::Operation operation;
  grpc::ClientContext call;
  ctx.PrepareCall(call);
  RETURN_IF_ERROR(FromGrpc(ctx.renders().CreateRenderJob(&call, request, &operation)));
  std::fprintf(ctx.out(), "%s\n", operation.name().c_str());
  if (!cl.Has("wait")) {
    if (cl.Has("out")) {
      std::fprintf(stderr,
                   "pf render: not waiting; `pf --server %s jobs wait %s --out %s` "
                   "downloads the outputs\n",
                   ctx.address().c_str(), operation.name().c_str(), cl.Get("out").c_str());
    }
    return ReportOperationFailure(operation) ? kExitFailed : kExitOk;
  }

  if (!operation.done()) {
    ASSIGN_OR_RETURN(operation, WaitForOperation(ctx, operation.name()));
  }
  if (ReportOperationFailure(operation)) return kExitFailed;
  RETURN_IF_ERROR(DownloadRenderResult(ctx, operation, cl.Get("out")));
  return kExitOk;
}

}  // namespace pf
