// What the four gRPC services of pf-server share: the job store, the blob
// store, the server's options, and the conversions from store records to
// the API's resources (Scene, RenderJob, google.longrunning.Operation).
#ifndef POINTFORWARD_SERVER_SERVICE_CORE_H_
#define POINTFORWARD_SERVER_SERVICE_CORE_H_

#include <atomic>
#include <cstdint>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "engine/render/render_outputs.h"
#include "google/longrunning/operations.pb.h"
#include "pointforward/v1/resources.pb.h"
#include "pointforward/v1/service.pb.h"
#include "pointforward/v1/worker.pb.h"
#include "server/auth.h"
#include "server/blobs/blob_store.h"
#include "server/clip_intake.h"
#include "server/long_polls.h"
#include "server/store/job_store.h"

namespace pf {

struct ServerOptions {
  std::vector<std::string> trusted_roots;  // Directories file:// clips may come from.
  int chunk_frames = 4;                    // Views per render chunk by default.
  int max_views = 10000;                   // Views per render job.
  int64_t max_upload_bytes = int64_t{1} << 30;
  ClipLimits clip_limits;              // --max-images-per-clip, --max-pixels-per-image.
  int64_t max_gaussians = 20'000'000;  // Per scene; the worker checks (0: none).
  // Estimated memory of one view's render (--max-render-bytes; 0: none);
  // checked at intake and by the worker, as the pixels per view are
  // (clip_limits.max_pixels_per_image).
  int64_t max_render_bytes = int64_t{4} << 30;
  int64_t max_jobs_per_owner = 100;        // Unfinished jobs per owner (0: none).
  int64_t max_lease_wait_ms = 10000;       // Longest LeaseTask long-poll.
  int max_long_polls = 64;                 // WaitOperation calls in flight (0: no cap).
  int max_long_polls_per_caller = 8;       // The same, per caller (0: no cap).
  std::string scratch_dir;                 // Staging of clips being checked.
  Authenticator* authenticator = nullptr;  // --auth-token-file; null: authentication off.
  // --tls-worker-ca: WorkerService calls must come over a connection whose
  // client certificate the TLS handshake verified.
  bool worker_certificate_required = false;
};

class ServiceCore {
 public:
  ServiceCore(JobStore* store, BlobStore* blobs, ServerOptions options);

  JobStore& store() { return *store_; }
  BlobStore& blobs() { return *blobs_; }
  const ServerOptions& options() const { return options_; }
  LongPollLimiter& long_polls() { return long_polls_; }
  // The limits on one view's render.
  RenderLimits render_limits() const {
    return {options_.clip_limits.max_pixels_per_image, options_.max_render_bytes};
  }
  int64_t NowMs() const;

  // Who `caller` is for per-caller limits: its owner when authentication
  // is on, else the address it calls from (without the port).
  static std::string CallerKey(const Caller& caller, const grpc::ServerContext& context);

  // Who makes the call (auth.h): UNAUTHENTICATED without a valid token when
  // authentication is on; Caller{"", admin} when it is off. Every handler
  // starts with it.
  absl::StatusOr<Caller> CallerOf(const grpc::ServerContext& context);

  // CreateScene: checks the clip and options, computes the cache key, and
  // finds or starts the reconstruction.
  absl::StatusOr<CreateSceneOutcome> CreateScene(
      const pointforward::v1::CreateSceneRequest& request, const std::string& owner);

  // The Operation of `job`; `cache_hit` sets metadata.cache_hit.
  absl::StatusOr<google::longrunning::Operation> OperationFor(const JobRecord& job,
                                                              bool cache_hit = false);
  // A scene whose stored description cannot be read comes out FAILED with
  // DATA_LOSS.
  absl::StatusOr<pointforward::v1::Scene> SceneFor(const SceneRecord& record);
  // For a SUCCEEDED job, lists every output and writes the merged
  // manifest.json to the blob store. A job whose stored results cannot be
  // read back comes out FAILED with DATA_LOSS and no files.
  absl::StatusOr<pointforward::v1::RenderJob> RenderJobFor(const JobRecord& job);

  // The task a worker receives for `lease`: the stored work plus, for render
  // chunks, the job's views, the scene file and the limits on a view.
  absl::StatusOr<pointforward::v1::Task> TaskFor(const TaskLease& lease);

  // Removes what servers that ended left in the scratch directory: the
  // staging directories of this machine's ended processes, and any older
  // than an hour (another machine's, sharing the volume). Returns how many.
  int RemoveStaleScratch();

  // RESOURCE_EXHAUSTED naming --max-jobs-per-owner when `owner` ("" when
  // authentication is off) has that many unfinished jobs already.
  absl::Status CheckJobLimit(const std::string& owner);

  // Integrity of READY scene `scene_id`'s file `scene_file`, checked against
  // its hash at most once per process (then the workers' download check is
  // relied on). OK when intact; when it is corrupt or missing, the file is
  // dropped, the scene rebuilt (RebuildScene) and DATA_LOSS returned.
  absl::Status CheckSceneFile(const std::string& scene_id,
                              const pointforward::v1::Digest& scene_file);
  // A worker failed a render chunk of `scene_id` with DATA_LOSS or
  // NOT_FOUND (its scene file could not be downloaded intact). Checks the
  // server's copy again: true when it is corrupt or gone and the scene is
  // being rebuilt (the chunk's attempt ended, the chunk waits for the
  // scene); false when the file is intact or the scene is not READY.
  absl::StatusOr<bool> RebuildIfSceneFileLost(const std::string& scene_id);

 private:
  std::string NewScratchDir();
  // Adds a SUCCEEDED render job's files to `out` and writes its merged
  // manifest.json; DATA_LOSS when a stored result cannot be read back.
  absl::Status AddRenderOutputs(const JobRecord& job, pointforward::v1::RenderJob* out);
  // Puts scene `scene_id` back to CREATING under a new reconstruction.
  absl::Status RebuildScene(const std::string& scene_id, const std::string& reason);

  JobStore* store_;
  BlobStore* blobs_;
  ServerOptions options_;
  std::atomic<int64_t> scratch_counter_{0};
  LongPollLimiter long_polls_;
  std::mutex verified_mu_;
  std::set<std::string> verified_scene_files_;  // SHA-256s checked intact this process.
};

// "scenes/X" -> X; INVALID_ARGUMENT naming `field` when malformed.
absl::StatusOr<std::string> ParseResourceName(const std::string& name,
                                              const std::string& collection,
                                              const std::string& field);

// A List call's page size: 0 means 50, more than 1000 means 1000;
// INVALID_ARGUMENT naming page_size when negative.
absl::StatusOr<int> PageSize(int requested);

// proto3 JSON helpers; errors name `what`. FromJson reads what the store
// holds (bounded: ParseBoundedProtoJson) and fails with DATA_LOSS.
std::string ToJson(const google::protobuf::Message& message);
absl::Status FromJson(const std::string& json, google::protobuf::Message* message,
                      const std::string& what);

// A task's label in attempts and errors: "reconstruction", "chunk 2 (views 4-5)".
std::string TaskLabel(const TaskRecord& task);

}  // namespace pf

#endif  // POINTFORWARD_SERVER_SERVICE_CORE_H_
