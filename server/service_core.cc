// ServiceCore: see service_core.h.
#include "server/service_core.h"

#include <google/protobuf/util/json_util.h>
#include <google/protobuf/util/time_util.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <tuple>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "common/bounded_json.h"
#include "common/file_util.h"
#include "common/status_macros.h"
#include "common/version.h"
#include "engine/render/render_outputs.h"
#include "server/clip_intake.h"
#include "server/server_metrics.h"
#include "server/task_results.h"
#include "spdlog/spdlog.h"

namespace pf {
namespace {

namespace v1 = pointforward::v1;
using google::longrunning::Operation;
using google::protobuf::util::TimeUtil;

// Staging directories of clips being checked: "<scratch>/clip-<process
// token>-<n>".
constexpr char kScratchPrefix[] = "clip-";
// Age after which a staging directory is taken for a dead server's.
constexpr auto kStaleScratchAge = std::chrono::hours(1);

v1::Scene::State SceneStateProto(SceneState state) {
  switch (state) {
    case SceneState::kCreating:
      return v1::Scene::CREATING;
    case SceneState::kReady:
      return v1::Scene::READY;
    case SceneState::kFailed:
      return v1::Scene::FAILED;
  }
  return v1::Scene::STATE_UNSPECIFIED;
}

v1::RenderJob::State RenderJobStateProto(JobState state) {
  switch (state) {
    case JobState::kWaitingForScene:
      return v1::RenderJob::WAITING_FOR_SCENE;
    case JobState::kQueued:
      return v1::RenderJob::QUEUED;
    case JobState::kRunning:
      return v1::RenderJob::RUNNING;
    case JobState::kSucceeded:
      return v1::RenderJob::SUCCEEDED;
    case JobState::kFailed:
      return v1::RenderJob::FAILED;
    case JobState::kCancelled:
      return v1::RenderJob::CANCELLED;
  }
  return v1::RenderJob::STATE_UNSPECIFIED;
}

std::string TargetName(const JobRecord& job) {
  return job.kind == JobKind::kReconstruct ? absl::StrCat("scenes/", job.scene_id)
                                           : absl::StrCat("renderJobs/", job.id);
}

}  // namespace

std::string ToJson(const google::protobuf::Message& message) {
  std::string json;
  google::protobuf::util::JsonPrintOptions options;
  options.preserve_proto_field_names = false;
  (void)google::protobuf::util::MessageToJsonString(message, &json, options);
  return json;
}

absl::Status FromJson(const std::string& json, google::protobuf::Message* message,
                      const std::string& what) {
  const absl::Status status = ParseBoundedProtoJson(json, message, kStoredJsonLimits);
  if (!status.ok()) return absl::DataLossError(absl::StrCat(what, ": ", status.message()));
  return absl::OkStatus();
}

absl::StatusOr<std::string> ParseResourceName(const std::string& name,
                                              const std::string& collection,
                                              const std::string& field) {
  const std::string prefix = collection + "/";
  std::string id = absl::StartsWith(name, prefix) ? name.substr(prefix.size()) : "";
  const bool ok = !id.empty() && id.size() <= 64 && std::all_of(id.begin(), id.end(), [](char c) {
    return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'z') || c == '-';
  });
  if (!ok) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": expected '", collection, "/{id}', got '", name, "'"));
  }
  return id;
}

absl::StatusOr<int> PageSize(int requested) {
  if (requested < 0) {
    return absl::InvalidArgumentError(absl::StrCat("page_size: must be >= 0, got ", requested));
  }
  if (requested == 0) return 50;
  return std::min(requested, 1000);
}

std::string TaskLabel(const TaskRecord& task) {
  if (task.kind == JobKind::kReconstruct) return "reconstruction";
  return absl::StrCat("chunk ", task.index, " (views ", task.first_view, "-",
                      task.first_view + task.view_count - 1, ")");
}

ServiceCore::ServiceCore(JobStore* store, BlobStore* blobs, ServerOptions options)
    : store_(store),
      blobs_(blobs),
      options_(std::move(options)),
      long_polls_(options_.max_long_polls, options_.max_long_polls_per_caller) {
  if (options_.scratch_dir.empty()) options_.scratch_dir = blobs_->root() + "/scratch";
}

int64_t ServiceCore::NowMs() const {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

absl::StatusOr<Caller> ServiceCore::CallerOf(const grpc::ServerContext& context) {
  if (options_.authenticator == nullptr) return Caller{"", Role::kAdmin};
  return options_.authenticator->Authenticate(context);
}

std::string ServiceCore::CallerKey(const Caller& caller, const grpc::ServerContext& context) {
  if (!caller.owner.empty()) return absl::StrCat("owner:", caller.owner);
  // "ipv4:127.0.0.1:50000", "ipv6:[::1]:50000": the address without the port.
  const std::string peer = context.peer();
  const size_t port = peer.rfind(':');
  return absl::StrCat("peer:", port == std::string::npos ? peer : peer.substr(0, port));
}

std::string ServiceCore::NewScratchDir() {
  return absl::StrCat(options_.scratch_dir, "/", kScratchPrefix, ProcessToken(), "-",
                      scratch_counter_++);
}

int ServiceCore::RemoveStaleScratch() {
  namespace fs = std::filesystem;
  std::error_code ec;
  int removed = 0;
  const auto stale_before = fs::file_time_type::clock::now() - kStaleScratchAge;
  for (fs::directory_iterator it(options_.scratch_dir, ec); !ec && it != fs::directory_iterator();
       it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (!absl::StartsWith(name, kScratchPrefix)) continue;
    // "clip-<process token>-<counter>".
    const size_t counter = name.rfind('-');
    const std::string token = name.substr(
        std::strlen(kScratchPrefix),
        counter == std::string::npos ? std::string::npos : counter - std::strlen(kScratchPrefix));
    std::error_code time_ec;
    const bool old = fs::last_write_time(it->path(), time_ec) < stale_before && !time_ec;
    if (!ProcessTokenEnded(token) && !old) continue;
    std::error_code remove_ec;
    if (fs::remove_all(it->path(), remove_ec) > 0) ++removed;
  }
  return removed;
}

absl::StatusOr<CreateSceneOutcome> ServiceCore::CreateScene(const v1::CreateSceneRequest& request,
                                                            const std::string& owner) {
  if (request.request_id().size() > 128) {
    return absl::InvalidArgumentError("request_id: longer than 128 characters");
  }
  ASSIGN_OR_RETURN(const v1::ReconstructionOptions options, NormalizeOptions(request.options()));
  const std::string staging = NewScratchDir();
  absl::StatusOr<AcceptedClip> accepted =
      AcceptClip(request.clip(), *blobs_, options_.trusted_roots, staging, options_.clip_limits);
  if (!accepted.ok()) {
    // No server path in what the caller reads: the clip's own files by
    // their path in the clip, the blob store by name.
    std::string message = HideDirectory(std::string(accepted.status().message()), staging);
    message = HideDirectory(message, options_.scratch_dir, "<scratch>");
    message = HideDirectory(message, blobs_->root(), "<blobs>");
    return absl::Status(accepted.status().code(), message);
  }
  const AcceptedClip& clip = *accepted;
  const std::string key = SceneCacheKey(clip.uploaded, options);
  const std::string scene_id = SceneIdForKey(key);
  // A scene READY or being created adds no job; anything else may.
  if (absl::StatusOr<SceneRecord> known = store_->GetScene(scene_id);
      !known.ok() || known->state == SceneState::kFailed) {
    RETURN_IF_ERROR(CheckJobLimit(owner));
  }

  v1::Scene description;
  description.set_model(options.model());
  description.set_content_hash(key);
  *description.mutable_options() = options;

  v1::Task work;
  v1::ReconstructWork* reconstruct = work.mutable_reconstruct();
  reconstruct->set_scene(absl::StrCat("scenes/", scene_id));
  *reconstruct->mutable_clip() = clip.uploaded;
  *reconstruct->mutable_options() = options;
  reconstruct->set_max_gaussians(options_.max_gaussians);

  v1::CreateSceneRequest stored = request;
  *stored.mutable_clip()->mutable_uploaded() = clip.uploaded;
  *stored.mutable_options() = options;

  ASSIGN_OR_RETURN(CreateSceneOutcome outcome,
                   store_->CreateSceneJob(scene_id, key, ToJson(description), request.request_id(),
                                          ToJson(stored), ToJson(work), owner, NowMs()));
  if (outcome.kind == CreateSceneOutcome::Kind::kCacheHit) GetServerMetrics().cache_hits->Inc();
  if (outcome.kind == CreateSceneOutcome::Kind::kCreated) GetServerMetrics().cache_misses->Inc();
  static constexpr const char* kOutcome[] = {"new reconstruction", "cache hit",
                                             "joined the reconstruction in flight",
                                             "same request_id as before"};
  spdlog::info("CreateScene scenes/{} ({}): {}, operations/{}", scene_id, clip.summary,
               kOutcome[static_cast<int>(outcome.kind)], outcome.job.id);
  return outcome;
}

absl::StatusOr<v1::Scene> ServiceCore::SceneFor(const SceneRecord& record) {
  v1::Scene scene;
  // An unreadable description shows as a FAILED scene, not a failed call.
  const absl::Status readable = FromJson(record.description, &scene, "stored scene");
  if (!readable.ok()) {
    spdlog::error("scenes/{}: {}", record.id, std::string(readable.message()));
    scene.Clear();
  }
  scene.set_name(absl::StrCat("scenes/", record.id));
  scene.set_state(SceneStateProto(record.state));
  scene.set_content_hash(record.content_hash);
  scene.set_operation(absl::StrCat("operations/", record.job_id));
  *scene.mutable_create_time() = TimeUtil::MillisecondsToTimestamp(record.create_time_ms);
  if (record.state == SceneState::kFailed) {
    scene.mutable_error()->set_code(static_cast<int>(absl::StatusCode::kAborted));
    scene.mutable_error()->set_message(record.error);
  }
  if (!readable.ok()) {
    scene.set_state(v1::Scene::FAILED);
    scene.mutable_error()->set_code(static_cast<int>(readable.code()));
    scene.mutable_error()->set_message(std::string(readable.message()));
  }
  return scene;
}

absl::StatusOr<v1::RenderJob> ServiceCore::RenderJobFor(const JobRecord& job) {
  v1::RenderJob out;
  out.set_name(absl::StrCat("renderJobs/", job.id));
  out.set_scene(absl::StrCat("scenes/", job.scene_id));
  out.set_state(RenderJobStateProto(job.state));
  out.set_frames_total(job.frames_total);
  out.set_frames_done(job.frames_done);
  out.set_chunks(job.tasks_total);
  out.set_operation(absl::StrCat("operations/", job.id));
  *out.mutable_create_time() = TimeUtil::MillisecondsToTimestamp(job.create_time_ms);
  *out.mutable_update_time() = TimeUtil::MillisecondsToTimestamp(job.update_time_ms);
  if (job.state == JobState::kFailed || job.state == JobState::kCancelled) {
    out.mutable_error()->set_code(job.error_code);
    out.mutable_error()->set_message(job.error_message);
  }
  if (job.state != JobState::kSucceeded) return out;
  // A result that cannot be read back (a worker's, or a damaged row) shows
  // as a failed job, not a failed call: the rest of the store stays readable.
  const absl::Status outputs = AddRenderOutputs(job, &out);
  if (outputs.code() == absl::StatusCode::kDataLoss) {
    spdlog::error("renderJobs/{}: {}", job.id, std::string(outputs.message()));
    out.clear_files();
    out.set_state(v1::RenderJob::FAILED);
    out.mutable_error()->set_code(static_cast<int>(outputs.code()));
    out.mutable_error()->set_message(std::string(outputs.message()));
    return out;
  }
  RETURN_IF_ERROR(outputs);
  return out;
}

absl::Status ServiceCore::AddRenderOutputs(const JobRecord& job, v1::RenderJob* out) {
  // Outputs: each chunk's files in chunk order, then manifest.json with the
  // views and sweeps of all chunks.
  ASSIGN_OR_RETURN(const std::vector<TaskRecord> tasks, store_->ListTasks(job.id));
  v1::CreateRenderJobRequest request;
  RETURN_IF_ERROR(FromJson(job.request, &request, "stored render request"));
  const int job_views = request.views().views_size();
  nlohmann::ordered_json views = nlohmann::ordered_json::array();
  nlohmann::ordered_json lidars = nlohmann::ordered_json::array();
  for (const TaskRecord& task : tasks) {
    v1::RenderResult result;
    RETURN_IF_ERROR(FromJson(task.result, &result, absl::StrCat("result of ", TaskLabel(task))));
    for (const v1::OutputFile& file : result.files()) *out->add_files() = file;
    // The chunk's frames: its views, then its sweeps.
    const int chunk_views = std::clamp(job_views - task.first_view, 0, task.view_count);
    for (auto [json, count, all, what] :
         {std::tuple{&result.manifest_views_json(), chunk_views, &views, "views"},
          std::tuple{&result.manifest_lidars_json(), task.view_count - chunk_views, &lidars,
                     "lidars"}}) {
      if (count == 0) continue;
      absl::StatusOr<nlohmann::ordered_json> entries = ParseManifestViews(*json, count);
      if (!entries.ok()) {
        return absl::DataLossError(absl::StrCat("manifest ", what, " of ", TaskLabel(task), ": ",
                                                entries.status().message()));
      }
      for (nlohmann::ordered_json& entry : *entries) all->push_back(std::move(entry));
    }
  }
  nlohmann::ordered_json manifest;
  manifest["scene"] = {{"name", out->scene()}};
  // The scene may be gone since (deleted, or evicted from the cache).
  if (absl::StatusOr<SceneRecord> scene = store_->GetScene(job.scene_id); scene.ok()) {
    v1::Scene scene_proto;
    RETURN_IF_ERROR(FromJson(scene->description, &scene_proto, "stored scene"));
    manifest["scene"]["model"] = scene_proto.model();
    manifest["scene"]["contentHash"] = scene->content_hash;
  } else if (scene.status().code() != absl::StatusCode::kNotFound) {
    return scene.status();
  }
  manifest["renderJob"] = out->name();
  manifest["software"] = absl::StrCat("PointForward ", SoftwareVersion());
  manifest["views"] = std::move(views);
  if (!lidars.empty()) manifest["lidars"] = std::move(lidars);
  ASSIGN_OR_RETURN(const BlobDigest digest, blobs_->Put(manifest.dump(2) + "\n"));
  v1::OutputFile* file = out->add_files();
  file->set_name("manifest.json");
  file->mutable_digest()->set_sha256(digest.sha256);
  file->mutable_digest()->set_size_bytes(digest.size_bytes);
  return absl::OkStatus();
}

absl::StatusOr<Operation> ServiceCore::OperationFor(const JobRecord& job, bool cache_hit) {
  Operation op;
  op.set_name(absl::StrCat("operations/", job.id));
  v1::OperationMetadata metadata;
  metadata.set_kind(JobKindName(job.kind));
  metadata.set_target(TargetName(job));
  metadata.set_state(JobStateName(job.state));
  metadata.set_stage(job.stage);
  metadata.set_fraction(job.fraction);
  metadata.set_frames_done(job.frames_done);
  metadata.set_frames_total(job.frames_total);
  metadata.set_cache_hit(cache_hit);
  *metadata.mutable_create_time() = TimeUtil::MillisecondsToTimestamp(job.create_time_ms);
  *metadata.mutable_update_time() = TimeUtil::MillisecondsToTimestamp(job.update_time_ms);
  ASSIGN_OR_RETURN(const std::vector<TaskRecord> tasks, store_->ListTasks(job.id));
  for (const TaskRecord& task : tasks) {
    for (const AttemptRecord& attempt : task.attempts) {
      v1::Attempt* out = metadata.add_attempts();
      out->set_task(TaskLabel(task));
      out->set_number(attempt.number);
      out->set_worker(attempt.worker_id);
      out->set_outcome(attempt.outcome);
    }
  }
  op.mutable_metadata()->PackFrom(metadata);

  switch (job.state) {
    case JobState::kSucceeded:
      op.set_done(true);
      if (job.kind == JobKind::kReconstruct) {
        ASSIGN_OR_RETURN(const SceneRecord scene, store_->GetScene(job.scene_id));
        ASSIGN_OR_RETURN(const v1::Scene scene_proto, SceneFor(scene));
        op.mutable_response()->PackFrom(scene_proto);
      } else {
        ASSIGN_OR_RETURN(const v1::RenderJob render_job, RenderJobFor(job));
        if (render_job.state() == v1::RenderJob::FAILED) {
          *op.mutable_error() = render_job.error();  // Its stored result is unreadable.
        } else {
          op.mutable_response()->PackFrom(render_job);
        }
      }
      break;
    case JobState::kFailed:
    case JobState::kCancelled:
      op.set_done(true);
      op.mutable_error()->set_code(job.error_code);
      op.mutable_error()->set_message(job.error_message);
      break;
    default:
      op.set_done(false);
  }
  return op;
}

absl::StatusOr<v1::Task> ServiceCore::TaskFor(const TaskLease& lease) {
  v1::Task task;
  RETURN_IF_ERROR(FromJson(lease.task.work, &task, "stored task work"));
  task.set_task_id(lease.task.id);
  task.set_attempt(lease.task.attempt);
  task.set_operation(absl::StrCat("operations/", lease.job.id));
  *task.mutable_lease_deadline() = TimeUtil::MillisecondsToTimestamp(lease.task.lease_deadline_ms);
  if (task.has_render()) {
    v1::CreateRenderJobRequest request;
    RETURN_IF_ERROR(FromJson(lease.job.request, &request, "stored render request"));
    ASSIGN_OR_RETURN(
        *task.mutable_render()->mutable_views(),
        RenderChunkViews(request.views(), lease.task.first_view, lease.task.view_count));
    task.mutable_render()->mutable_outputs()->CopyFrom(request.outputs());
    ASSIGN_OR_RETURN(const SceneRecord scene, store_->GetScene(lease.task.scene_id));
    v1::Scene scene_proto;
    RETURN_IF_ERROR(FromJson(scene.description, &scene_proto, "stored scene"));
    *task.mutable_render()->mutable_scene_file() = scene_proto.scene_file();
    task.mutable_render()->set_max_pixels_per_view(options_.clip_limits.max_pixels_per_image);
    task.mutable_render()->set_max_render_bytes(options_.max_render_bytes);
  }
  return task;
}

absl::Status ServiceCore::CheckJobLimit(const std::string& owner) {
  if (options_.max_jobs_per_owner <= 0) return absl::OkStatus();
  ASSIGN_OR_RETURN(const int unfinished, store_->CountUnfinishedJobs(owner));
  if (unfinished < options_.max_jobs_per_owner) return absl::OkStatus();
  return absl::ResourceExhaustedError(absl::StrCat(
      "jobs: ", owner.empty() ? "this caller" : absl::StrCat("owner '", owner, "'"), " has ",
      unfinished, " unfinished jobs, the limit of ", options_.max_jobs_per_owner,
      " per owner (--max-jobs-per-owner); wait for some to end or cancel them"));
}

absl::Status ServiceCore::CheckSceneFile(const std::string& scene_id,
                                         const v1::Digest& scene_file) {
  const std::string& sha256 = scene_file.sha256();
  {
    std::lock_guard<std::mutex> lock(verified_mu_);
    if (verified_scene_files_.count(sha256) > 0) return absl::OkStatus();
  }
  absl::Status intact = IsValidSha256Hex(sha256) && blobs_->Contains(sha256)
                            ? blobs_->Verify(sha256)  // Removes a corrupt file.
                            : absl::NotFoundError(absl::StrCat("blob ", sha256, " is missing"));
  if (intact.ok()) {
    std::lock_guard<std::mutex> lock(verified_mu_);
    verified_scene_files_.insert(sha256);
    return absl::OkStatus();
  }
  const std::string reason = absl::StrCat("scene file ", sha256, ": ", intact.message());
  RETURN_IF_ERROR(RebuildScene(scene_id, reason));
  return absl::DataLossError(reason);
}

absl::StatusOr<bool> ServiceCore::RebuildIfSceneFileLost(const std::string& scene_id) {
  ASSIGN_OR_RETURN(const SceneRecord record, store_->GetScene(scene_id));
  // Not READY: already being rebuilt (another chunk told first), and this
  // chunk's lease ended with it.
  if (record.state != SceneState::kReady) return false;
  v1::Scene scene;
  RETURN_IF_ERROR(FromJson(record.description, &scene, "stored scene"));
  const std::string& sha256 = scene.scene_file().sha256();
  {
    std::lock_guard<std::mutex> lock(verified_mu_);
    verified_scene_files_.erase(sha256);  // Check again: the worker saw it bad.
  }
  const absl::Status intact = CheckSceneFile(scene_id, scene.scene_file());
  if (intact.ok()) return false;
  if (intact.code() == absl::StatusCode::kDataLoss) return true;
  return intact;
}

absl::Status ServiceCore::RebuildScene(const std::string& scene_id, const std::string& reason) {
  ASSIGN_OR_RETURN(const SceneRecord record, store_->GetScene(scene_id));
  v1::Scene old;
  RETURN_IF_ERROR(FromJson(record.description, &old, "stored scene"));
  {
    std::lock_guard<std::mutex> lock(verified_mu_);
    verified_scene_files_.erase(old.scene_file().sha256());
  }
  // What CreateScene stored before the first build: no statistics yet.
  v1::Scene description;
  description.set_model(old.model());
  description.set_content_hash(old.content_hash());
  *description.mutable_options() = old.options();
  ASSIGN_OR_RETURN(const SceneRecord rebuilt,
                   store_->RebuildScene(scene_id, reason, ToJson(description), NowMs()));
  spdlog::warn("scenes/{}: {}; rebuilding it in operations/{}, its render jobs wait for it",
               scene_id, reason, rebuilt.job_id);
  return absl::OkStatus();
}

}  // namespace pf
