// What the four gRPC services of pf-server share: the job store, the blob
// store, the server's options, and the conversions from store records to
// the API's resources (Scene, RenderJob, google.longrunning.Operation).
#ifndef POINTFORWARD_SERVER_SERVICE_CORE_H_
#define POINTFORWARD_SERVER_SERVICE_CORE_H_

#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

#include "google/longrunning/operations.pb.h"
#include "pointforward/v1/resources.pb.h"
#include "pointforward/v1/service.pb.h"
#include "pointforward/v1/worker.pb.h"
#include "absl/status/statusor.h"
#include "server/blobs/blob_store.h"
#include "server/store/job_store.h"

namespace pf {

struct ServerOptions {
  std::vector<std::string> trusted_roots;  // Directories file:// clips may come from.
  int chunk_frames = 4;                    // Views per render chunk by default.
  int max_views = 10000;                   // Views per render job.
  int64_t max_upload_bytes = int64_t{1} << 30;
  int64_t max_lease_wait_ms = 10000;  // Longest LeaseTask long-poll.
  std::string scratch_dir;            // Staging of clips being checked.
};

class ServiceCore {
 public:
  ServiceCore(JobStore* store, BlobStore* blobs, ServerOptions options);

  JobStore& store() { return *store_; }
  BlobStore& blobs() { return *blobs_; }
  const ServerOptions& options() const { return options_; }
  int64_t NowMs() const;

  // CreateScene: checks the clip and options, computes the cache key, and
  // finds or starts the reconstruction.
  absl::StatusOr<CreateSceneOutcome> CreateScene(const pointforward::v1::CreateSceneRequest& request,
                                                 const std::string& owner);

  // The Operation of `job`; `cache_hit` sets metadata.cache_hit.
  absl::StatusOr<google::longrunning::Operation> OperationFor(const JobRecord& job,
                                                              bool cache_hit = false);
  absl::StatusOr<pointforward::v1::Scene> SceneFor(const SceneRecord& record);
  // For a SUCCEEDED job, lists every output and writes the merged
  // manifest.json to the blob store.
  absl::StatusOr<pointforward::v1::RenderJob> RenderJobFor(const JobRecord& job);

  // The task a worker receives for `lease`: the stored work plus, for render
  // chunks, the job's views and the scene file.
  absl::StatusOr<pointforward::v1::Task> TaskFor(const TaskLease& lease);

 private:
  std::string NewScratchDir();

  JobStore* store_;
  BlobStore* blobs_;
  ServerOptions options_;
  std::atomic<int64_t> scratch_counter_{0};
};

// "scenes/X" -> X; INVALID_ARGUMENT naming `field` when malformed.
absl::StatusOr<std::string> ParseResourceName(const std::string& name, const std::string& collection,
                                              const std::string& field);

// A List call's page size: 0 means 50, more than 1000 means 1000;
// INVALID_ARGUMENT naming page_size when negative.
absl::StatusOr<int> PageSize(int requested);

// proto3 JSON helpers; errors name `what`.
std::string ToJson(const google::protobuf::Message& message);
absl::Status FromJson(const std::string& json, google::protobuf::Message* message,
                      const std::string& what);

// A task's label in attempts and errors: "reconstruction", "chunk 2 (views 4-5)".
std::string TaskLabel(const TaskRecord& task);

}  // namespace pf

#endif  // POINTFORWARD_SERVER_SERVICE_CORE_H_
