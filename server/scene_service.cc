// SceneService: CreateScene, GetScene, ListScenes, DeleteScene, ExportScene.
#include <algorithm>
#include <string>

#include "absl/strings/str_cat.h"
#include "common/hash.h"
#include "engine/render/ply_io.h"
#include "engine/render/scene_file.h"
#include "google/longrunning/operations.pb.h"
#include "pointforward/v1/service.pb.h"
#include "rpc/grpc_status.h"
#include "server/ownership.h"
#include "server/services.h"

namespace pf {
namespace {

namespace v1 = pointforward::v1;

constexpr int64_t kExportChunkBytes = 1 << 20;

// The scene request field "name" names, if `caller` may use it: NOT_FOUND
// in the same words for a scene that does not exist and one it may not see.
absl::StatusOr<SceneRecord> SceneTheCallerMaySee(ServiceCore& core, const Caller& caller,
                                                 const std::string& name) {
  absl::StatusOr<std::string> id = ParseResourceName(name, "scenes", "name");
  if (!id.ok()) return id.status();
  absl::StatusOr<SceneRecord> record = core.store().GetScene(*id);
  const absl::Status ok =
      record.ok() ? CheckCanUseScene(caller, *id, core.store(), name) : record.status();
  if (!ok.ok()) return NotFoundOrStatus(ok, "name", name);
  return record;
}

}  // namespace

grpc::Status SceneServiceImpl::CreateScene(grpc::ServerContext* context,
                                           const v1::CreateSceneRequest* request,
                                           google::longrunning::Operation* response) {
  absl::StatusOr<Caller> caller = core_->CallerOf(*context);
  if (!caller.ok()) return ToGrpc(caller.status());
  absl::StatusOr<CreateSceneOutcome> outcome = core_->CreateScene(*request, caller->owner);
  if (!outcome.ok()) return ToGrpc(outcome.status());
  if (outcome->kind == CreateSceneOutcome::Kind::kSameRequest &&
      !CheckCanSeeJob(*caller, outcome->job, core_->store(), "").ok()) {
    return ToGrpc(absl::PermissionDeniedError(absl::StrCat("request_id: '", request->request_id(),
                                                           "' names a request of another owner")));
  }
  absl::StatusOr<google::longrunning::Operation> op =
      core_->OperationFor(outcome->job, outcome->kind == CreateSceneOutcome::Kind::kCacheHit);
  if (!op.ok()) return ToGrpc(op.status());
  *response = *std::move(op);
  return grpc::Status::OK;
}

grpc::Status SceneServiceImpl::GetScene(grpc::ServerContext* context,
                                        const v1::GetSceneRequest* request, v1::Scene* response) {
  absl::StatusOr<Caller> caller = core_->CallerOf(*context);
  if (!caller.ok()) return ToGrpc(caller.status());
  absl::StatusOr<SceneRecord> record = SceneTheCallerMaySee(*core_, *caller, request->name());
  if (!record.ok()) return ToGrpc(record.status());
  absl::StatusOr<v1::Scene> scene = core_->SceneFor(*record);
  if (!scene.ok()) return ToGrpc(scene.status());
  *response = *std::move(scene);
  return grpc::Status::OK;
}

grpc::Status SceneServiceImpl::ListScenes(grpc::ServerContext* context,
                                          const v1::ListScenesRequest* request,
                                          v1::ListScenesResponse* response) {
  absl::StatusOr<Caller> caller = core_->CallerOf(*context);
  if (!caller.ok()) return ToGrpc(caller.status());
  absl::StatusOr<int> page_size = PageSize(request->page_size());
  if (!page_size.ok()) return ToGrpc(page_size.status());
  // An admin lists every scene; anyone else those it has access to.
  absl::StatusOr<Page<SceneRecord>> page =
      caller->admin()
          ? core_->store().ListScenes(*page_size, request->page_token())
          : core_->store().ListScenesOf(caller->owner, *page_size, request->page_token());
  if (!page.ok()) return ToGrpc(page.status());
  for (const SceneRecord& record : page->items) {
    absl::StatusOr<v1::Scene> scene = core_->SceneFor(record);
    if (!scene.ok()) return ToGrpc(scene.status());
    *response->add_scenes() = *std::move(scene);
  }
  response->set_next_page_token(page->next_page_token);
  return grpc::Status::OK;
}

grpc::Status SceneServiceImpl::DeleteScene(grpc::ServerContext* context,
                                           const v1::DeleteSceneRequest* request,
                                           google::protobuf::Empty*) {
  absl::StatusOr<Caller> caller = core_->CallerOf(*context);
  if (!caller.ok()) return ToGrpc(caller.status());
  absl::StatusOr<SceneRecord> record = SceneTheCallerMaySee(*core_, *caller, request->name());
  if (!record.ok()) return ToGrpc(record.status());
  return ToGrpc(NotFoundOrStatus(core_->store().DeleteScene(record->id, core_->NowMs()), "name",
                                 request->name()));
}

grpc::Status SceneServiceImpl::ExportScene(grpc::ServerContext* context,
                                           const v1::ExportSceneRequest* request,
                                           grpc::ServerWriter<v1::ExportSceneChunk>* writer) {
  absl::StatusOr<Caller> caller = core_->CallerOf(*context);
  if (!caller.ok()) return ToGrpc(caller.status());
  absl::StatusOr<SceneRecord> record = SceneTheCallerMaySee(*core_, *caller, request->name());
  if (!record.ok()) return ToGrpc(record.status());
  if (record->state != SceneState::kReady) {
    return ToGrpc(absl::FailedPreconditionError(absl::StrCat(
        "name: scene ", request->name(), " is ", SceneStateName(record->state), ", not READY")));
  }
  absl::StatusOr<v1::Scene> scene = core_->SceneFor(*record);
  if (!scene.ok()) return ToGrpc(scene.status());
  const std::string& sha = scene->scene_file().sha256();
  if (absl::Status verified = core_->blobs().Verify(sha); !verified.ok()) {
    return ToGrpc(verified);
  }
  absl::StatusOr<std::string> path = core_->blobs().PathOf(sha);
  if (!path.ok()) return ToGrpc(path.status());
  absl::StatusOr<GaussianScene> gaussians = LoadScene(*path);
  if (!gaussians.ok()) return ToGrpc(gaussians.status());
  PlyExportOptions options;
  if (request->has_time_us()) options.timestamp_us = request->time_us();
  absl::StatusOr<std::string> ply = EncodePly(*gaussians, options);
  if (!ply.ok()) return ToGrpc(ply.status());

  const std::string digest = Sha256Hex(*ply);
  for (int64_t offset = 0; offset < static_cast<int64_t>(ply->size()) || offset == 0;
       offset += kExportChunkBytes) {
    if (context->IsCancelled()) return grpc::Status::CANCELLED;
    v1::ExportSceneChunk chunk;
    chunk.set_data(ply->substr(offset, kExportChunkBytes));
    if (offset + kExportChunkBytes >= static_cast<int64_t>(ply->size())) chunk.set_sha256(digest);
    if (!writer->Write(chunk)) return grpc::Status::CANCELLED;
  }
  return grpc::Status::OK;
}

}  // namespace pf
