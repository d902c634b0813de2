// The gRPC services pf-server registers, each a thin layer over
// ServiceCore: it checks the request, calls the store, converts the result.
// Errors carry the field at fault ("views.views[2].camera: ...").
#ifndef POINTFORWARD_SERVER_SERVICES_H_
#define POINTFORWARD_SERVER_SERVICES_H_

#include "google/longrunning/operations.grpc.pb.h"
#include "pointforward/v1/service.grpc.pb.h"
#include "pointforward/v1/worker.grpc.pb.h"
#include "server/service_core.h"

namespace pf {

class SceneServiceImpl final : public pointforward::v1::SceneService::Service {
 public:
  explicit SceneServiceImpl(ServiceCore* core) : core_(core) {}

  grpc::Status CreateScene(grpc::ServerContext* context,
                           const pointforward::v1::CreateSceneRequest* request,
                           google::longrunning::Operation* response) override;
  grpc::Status GetScene(grpc::ServerContext* context,
                        const pointforward::v1::GetSceneRequest* request,
                        pointforward::v1::Scene* response) override;
  grpc::Status ListScenes(grpc::ServerContext* context,
                          const pointforward::v1::ListScenesRequest* request,
                          pointforward::v1::ListScenesResponse* response) override;
  grpc::Status DeleteScene(grpc::ServerContext* context,
                           const pointforward::v1::DeleteSceneRequest* request,
                           google::protobuf::Empty* response) override;
  grpc::Status ExportScene(grpc::ServerContext* context,
                           const pointforward::v1::ExportSceneRequest* request,
                           grpc::ServerWriter<pointforward::v1::ExportSceneChunk>* writer) override;

 private:
  ServiceCore* core_;
};

class RenderServiceImpl final : public pointforward::v1::RenderService::Service {
 public:
  explicit RenderServiceImpl(ServiceCore* core) : core_(core) {}

  grpc::Status CreateRenderJob(grpc::ServerContext* context,
                               const pointforward::v1::CreateRenderJobRequest* request,
                               google::longrunning::Operation* response) override;
  grpc::Status GetRenderJob(grpc::ServerContext* context,
                            const pointforward::v1::GetRenderJobRequest* request,
                            pointforward::v1::RenderJob* response) override;
  grpc::Status ListRenderJobs(grpc::ServerContext* context,
                              const pointforward::v1::ListRenderJobsRequest* request,
                              pointforward::v1::ListRenderJobsResponse* response) override;

 private:
  ServiceCore* core_;
};

// google.longrunning.Operations over the store's jobs. ListOperations takes
// the filter "kind=reconstruct" or "kind=render" (or none).
class OperationsServiceImpl final : public google::longrunning::Operations::Service {
 public:
  explicit OperationsServiceImpl(ServiceCore* core) : core_(core) {}

  grpc::Status ListOperations(grpc::ServerContext* context,
                              const google::longrunning::ListOperationsRequest* request,
                              google::longrunning::ListOperationsResponse* response) override;
  grpc::Status GetOperation(grpc::ServerContext* context,
                            const google::longrunning::GetOperationRequest* request,
                            google::longrunning::Operation* response) override;
  grpc::Status DeleteOperation(grpc::ServerContext* context,
                               const google::longrunning::DeleteOperationRequest* request,
                               google::protobuf::Empty* response) override;
  grpc::Status CancelOperation(grpc::ServerContext* context,
                               const google::longrunning::CancelOperationRequest* request,
                               google::protobuf::Empty* response) override;
  // Waits until the operation is done or `timeout` (default and at most
  // 60 s) passes, and returns it either way. RESOURCE_EXHAUSTED when the
  // caller, or the server, holds as many of these as it may
  // (--max-long-polls-per-caller, --max-long-polls).
  grpc::Status WaitOperation(grpc::ServerContext* context,
                             const google::longrunning::WaitOperationRequest* request,
                             google::longrunning::Operation* response) override;

 private:
  ServiceCore* core_;
};

class WorkerServiceImpl final : public pointforward::v1::WorkerService::Service {
 public:
  explicit WorkerServiceImpl(ServiceCore* core) : core_(core) {}

  grpc::Status LeaseTask(grpc::ServerContext* context,
                         const pointforward::v1::LeaseTaskRequest* request,
                         pointforward::v1::LeaseTaskResponse* response) override;
  grpc::Status Heartbeat(grpc::ServerContext* context,
                         const pointforward::v1::HeartbeatRequest* request,
                         pointforward::v1::HeartbeatResponse* response) override;
  grpc::Status CompleteTask(grpc::ServerContext* context,
                            const pointforward::v1::CompleteTaskRequest* request,
                            pointforward::v1::CompleteTaskResponse* response) override;
  grpc::Status FailTask(grpc::ServerContext* context,
                        const pointforward::v1::FailTaskRequest* request,
                        pointforward::v1::FailTaskResponse* response) override;

 private:
  ServiceCore* core_;
};

}  // namespace pf

#endif  // POINTFORWARD_SERVER_SERVICES_H_
