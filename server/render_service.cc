// RenderService: CreateRenderJob (optionally creating its scene first),
// GetRenderJob, ListRenderJobs.
#include <algorithm>
#include <optional>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "common/status_macros.h"
#include "engine/render/render_outputs.h"
#include "engine/render/views.h"
#include "google/longrunning/operations.pb.h"
#include "pointforward/v1/service.pb.h"
#include "rpc/grpc_status.h"
#include "server/ownership.h"
#include "server/services.h"
#include "spdlog/spdlog.h"

namespace pf {
namespace {

namespace v1 = pointforward::v1;

// The fewest feature channels a scene has: what a view's memory is
// estimated with before the scene is READY (the worker checks again with
// the real count).
constexpr int kMinSceneChannels = 3;

// Checks what needs no scene: the number of views and sweeps, each camera's
// pixels and estimated memory with `num_features` feature channels, and
// each sweep's rays.
absl::Status CheckViewLimits(const v1::RenderViews& views, const OutputChannels& channels,
                             int num_features, int max_views, const RenderLimits& limits) {
  const int64_t items = RenderItemCount(views);
  if (items == 0) return absl::InvalidArgumentError("views.views: no views or lidars to render");
  if (items > max_views) {
    const std::string what = views.lidars_size() == 0
                                 ? absl::StrCat("views.views: ", views.views_size(), " views")
                                 : absl::StrCat("views: ", views.views_size(), " views and ",
                                                views.lidars_size(), " lidars");
    return absl::InvalidArgumentError(absl::StrCat(what, " exceed the limit of ", max_views,
                                                   " per render job (pf-server --max-views)"));
  }
  return CheckRenderLimits(views, channels, num_features, limits, "views.");
}

// Checks the views against what is known of the scene: everything when it
// is READY; all but the instances named by edits while it is being created
// (the worker checks those against the scene it renders).
absl::Status CheckViews(const v1::RenderViews& views, const OutputChannels& channels,
                        const v1::Scene& scene, int max_views, const RenderLimits& limits) {
  const int num_features =
      scene.state() == v1::Scene::READY ? scene.num_channels() : kMinSceneChannels;
  RETURN_IF_ERROR(CheckViewLimits(views, channels, num_features, max_views, limits));
  std::optional<std::vector<std::string>> instances;
  if (scene.state() == v1::Scene::READY) {
    instances.emplace(scene.instances().begin(), scene.instances().end());
  }
  absl::StatusOr<RenderRequest> parsed = RenderRequestFromProto(views, instances);
  if (!parsed.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("views.", parsed.status().message()));
  }
  return absl::OkStatus();
}

}  // namespace

grpc::Status RenderServiceImpl::CreateRenderJob(grpc::ServerContext* context,
                                                const v1::CreateRenderJobRequest* request,
                                                google::longrunning::Operation* response) {
  absl::StatusOr<Caller> caller = core_->CallerOf(*context);
  if (!caller.ok()) return ToGrpc(caller.status());
  if (request->request_id().size() > 128) {
    return ToGrpc(absl::InvalidArgumentError("request_id: longer than 128 characters"));
  }
  const absl::StatusOr<OutputChannels> channels =
      ParseOutputChannels({request->outputs().begin(), request->outputs().end()});
  if (!channels.ok()) {
    return ToGrpc(
        absl::InvalidArgumentError(absl::StrCat("outputs: ", channels.status().message())));
  }
  if (request->chunk_frames() < 0) {
    return ToGrpc(absl::InvalidArgumentError(
        absl::StrCat("chunk_frames: must be >= 0, got ", request->chunk_frames())));
  }

  // Limits first: nothing is created for a request that exceeds them.
  if (absl::Status limits = CheckViewLimits(request->views(), *channels, kMinSceneChannels,
                                            core_->options().max_views, core_->render_limits());
      !limits.ok()) {
    return ToGrpc(limits);
  }
  if (absl::Status limit = core_->CheckJobLimit(caller->owner); !limit.ok()) return ToGrpc(limit);

  // The scene: named, or created from a clip (or found in the cache).
  std::string scene_id;
  switch (request->target_case()) {
    case v1::CreateRenderJobRequest::kScene: {
      absl::StatusOr<std::string> id = ParseResourceName(request->scene(), "scenes", "scene");
      if (!id.ok()) return ToGrpc(id.status());
      scene_id = *id;
      if (absl::Status ok = CheckCanUseScene(*caller, scene_id, core_->store(), request->scene());
          !ok.ok()) {
        return ToGrpc(NotFoundOrStatus(ok, "scene", request->scene()));
      }
      break;
    }
    case v1::CreateRenderJobRequest::kCreateScene: {
      absl::StatusOr<CreateSceneOutcome> outcome =
          core_->CreateScene(request->create_scene(), caller->owner);
      if (!outcome.ok()) {
        return ToGrpc(absl::Status(outcome.status().code(),
                                   absl::StrCat("create_scene.", outcome.status().message())));
      }
      scene_id = outcome->scene.id.empty() ? outcome->job.scene_id : outcome->scene.id;
      break;
    }
    default:
      return ToGrpc(absl::InvalidArgumentError("scene: missing; set scene or create_scene"));
  }
  absl::StatusOr<SceneRecord> scene = core_->store().GetScene(scene_id);
  if (!scene.ok()) {
    return ToGrpc(NotFoundOrStatus(scene.status(), "scene", absl::StrCat("scenes/", scene_id)));
  }
  absl::StatusOr<v1::Scene> scene_proto = core_->SceneFor(*scene);
  if (!scene_proto.ok()) return ToGrpc(scene_proto.status());
  if (absl::Status checked = CheckViews(request->views(), *channels, *scene_proto,
                                        core_->options().max_views, core_->render_limits());
      !checked.ok()) {
    return ToGrpc(checked);
  }

  // Chunks of frames: the views, then the LiDAR sweeps.
  const int total = static_cast<int>(RenderItemCount(request->views()));
  const int chunk =
      request->chunk_frames() > 0 ? request->chunk_frames() : core_->options().chunk_frames;
  std::vector<NewTask> tasks;
  for (int first = 0; first < total; first += chunk) {
    NewTask task;
    task.first_view = first;
    task.view_count = std::min(chunk, total - first);
    v1::Task work;
    v1::RenderWork* render = work.mutable_render();
    render->set_scene(absl::StrCat("scenes/", scene_id));
    render->set_first_view(task.first_view);
    render->set_view_count(task.view_count);
    task.work = ToJson(work);
    tasks.push_back(std::move(task));
  }
  v1::CreateRenderJobRequest stored = *request;
  stored.set_scene(absl::StrCat("scenes/", scene_id));  // Replaces create_scene.
  bool same_request = false;
  absl::StatusOr<JobRecord> job =
      core_->store().CreateRenderJob(scene_id, request->request_id(), ToJson(stored), total, tasks,
                                     caller->owner, core_->NowMs(), &same_request);
  if (!job.ok()) {
    return ToGrpc(
        absl::Status(job.status().code(), absl::StrCat("scene: ", job.status().message())));
  }
  if (same_request && !CheckCanCancelJob(*caller, *job, "").ok()) {
    return ToGrpc(absl::PermissionDeniedError(absl::StrCat("request_id: '", request->request_id(),
                                                           "' names a request of another owner")));
  }
  spdlog::info("CreateRenderJob renderJobs/{}: {} views of scenes/{} in {} chunks{}", job->id,
               total, scene_id, tasks.size(), same_request ? " (same request_id as before)" : "");
  absl::StatusOr<google::longrunning::Operation> op = core_->OperationFor(*job);
  if (!op.ok()) return ToGrpc(op.status());
  *response = *std::move(op);
  return grpc::Status::OK;
}

grpc::Status RenderServiceImpl::GetRenderJob(grpc::ServerContext* context,
                                             const v1::GetRenderJobRequest* request,
                                             v1::RenderJob* response) {
  absl::StatusOr<Caller> caller = core_->CallerOf(*context);
  if (!caller.ok()) return ToGrpc(caller.status());
  absl::StatusOr<std::string> id = ParseResourceName(request->name(), "renderJobs", "name");
  if (!id.ok()) return ToGrpc(id.status());
  absl::StatusOr<JobRecord> job = core_->store().GetJob(*id);
  if (job.ok() && job->kind != JobKind::kRender) {
    job = absl::NotFoundError(absl::StrCat(request->name(), " not found"));
  }
  // A render job is seen by its owner only, as it is cancelled.
  if (absl::Status ok = job.ok() ? CheckCanCancelJob(*caller, *job, request->name()) : job.status();
      !ok.ok()) {
    return ToGrpc(NotFoundOrStatus(ok, "name", request->name()));
  }
  absl::StatusOr<v1::RenderJob> out = core_->RenderJobFor(*job);
  if (!out.ok()) return ToGrpc(out.status());
  *response = *std::move(out);
  return grpc::Status::OK;
}

grpc::Status RenderServiceImpl::ListRenderJobs(grpc::ServerContext* context,
                                               const v1::ListRenderJobsRequest* request,
                                               v1::ListRenderJobsResponse* response) {
  absl::StatusOr<Caller> caller = core_->CallerOf(*context);
  if (!caller.ok()) return ToGrpc(caller.status());
  absl::StatusOr<int> page_size = PageSize(request->page_size());
  if (!page_size.ok()) return ToGrpc(page_size.status());
  absl::StatusOr<Page<JobRecord>> page =
      caller->admin() ? core_->store().ListJobs(JobKind::kRender, *page_size, request->page_token())
                      : core_->store().ListJobsOf(caller->owner, JobKind::kRender, *page_size,
                                                  request->page_token());
  if (!page.ok()) return ToGrpc(page.status());
  for (const JobRecord& job : page->items) {
    absl::StatusOr<v1::RenderJob> out = core_->RenderJobFor(job);
    if (!out.ok()) return ToGrpc(out.status());
    *response->add_render_jobs() = *std::move(out);
  }
  response->set_next_page_token(page->next_page_token);
  return grpc::Status::OK;
}

}  // namespace pf
