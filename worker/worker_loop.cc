// pf-worker's loop: lease, run on a task thread while heartbeating, report.
#include "worker/worker_loop.h"

#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <system_error>
#include <thread>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "common/elapsed.h"
#include "common/file_util.h"
#include "common/logging.h"
#include "common/metrics.h"
#include "common/status_macros.h"
#include "engine/recon/compute_device.h"
#include "engine/render/device_renderer.h"
#include "engine/render/scene_source.h"
#include "pointforward/v1/worker.grpc.pb.h"
#include "pointforward/v1/worker.pb.h"
#include "rpc/blob_transfer.h"
#include "rpc/grpc_status.h"
#include "spdlog/spdlog.h"
#include "worker/scene_cache.h"
#include "worker/task_runner.h"

namespace pf {
namespace {

namespace fs = std::filesystem;
namespace pb = ::pointforward::v1;
using Clock = std::chrono::steady_clock;

constexpr auto kRetryInterval = std::chrono::seconds(1);
// How long CompleteTask / FailTask keep retrying while the server is down.
constexpr auto kReportRetryFor = std::chrono::minutes(2);
constexpr auto kCallDeadline = std::chrono::seconds(30);

// Returns `s` with characters other than letters, digits, '-', '_' and '.'
// replaced, for use as a directory name.
std::string FileNameSafe(const std::string& s) {
  std::string out = s;
  for (char& c : out) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '-' || c == '_' || c == '.';
    if (!ok) c = '_';
  }
  return out.empty() || out == "." || out == ".." ? "_" + out : out;
}

// "operations/abc" -> "renderJobs/abc", for log lines.
std::string RenderJobName(const std::string& operation) {
  const std::string prefix = "operations/";
  if (operation.rfind(prefix, 0) == 0) return "renderJobs/" + operation.substr(prefix.size());
  return operation;
}

bool IsPermanent(absl::StatusCode code) {
  return code == absl::StatusCode::kInvalidArgument ||
         code == absl::StatusCode::kFailedPrecondition || code == absl::StatusCode::kNotFound;
}

bool IsServerDown(grpc::StatusCode code) {
  return code == grpc::StatusCode::UNAVAILABLE || code == grpc::StatusCode::DEADLINE_EXCEEDED;
}

void SetDeadline(grpc::ClientContext* context, std::chrono::milliseconds timeout) {
  context->set_deadline(std::chrono::system_clock::now() + timeout);
}

// What the task thread and the loop thread share while a task runs.
struct TaskState {
  std::mutex mu;
  std::condition_variable cv;
  bool done = false;      // Guarded by mu.
  pb::Progress progress;  // Guarded by mu.
  std::atomic<bool> cancel{false};
  // Written by the task thread before `done`.
  absl::Status status;
  pb::CompleteTaskRequest completion;
};

class Worker {
 public:
  Worker(const WorkerOptions& options, std::atomic<bool>* stop)
      : options_(options),
        stop_(stop),
        channel_(MakeChannel(options.server, options.channel)),
        stub_(pb::WorkerService::NewStub(channel_)),
        blobs_(channel_),
        cache_(options.cache_bytes) {}

  int Run();

 private:
  absl::Status EmptyWorkDir();
  std::optional<pb::Task> Lease();
  void RunTask(const pb::Task& task);
  void Execute(const pb::Task& task, const std::string& dir, spdlog::logger& log, TaskState* state);
  absl::Status Reconstruct(const pb::Task& task, const std::string& dir, spdlog::logger& log,
                           TaskState* state);
  absl::Status Render(const pb::Task& task, const std::string& dir, spdlog::logger& log,
                      TaskState* state);
  // Sends CompleteTask or FailTask, retrying while the server is down.
  void Report(const pb::Task& task, TaskState* state, spdlog::logger& log);
  // Reports `stage`/`fraction` or `frames_done` for the next heartbeat;
  // sleeps options_.stage_delay_ms when the stage or frame count changed.
  void SetProgress(TaskState* state, const std::string& stage, double fraction,
                   int frames_done) const;

  // Logs the first failure of a run of failures to reach the server.
  void ServerDown(const grpc::Status& status);
  void ServerUp();
  // Sleeps `duration` unless the stop flag turns true first.
  void SleepUnlessStopped(std::chrono::milliseconds duration) const;
  // Cancels the LeaseTask in flight once the stop flag is set.
  void WatchStop();

  const WorkerOptions options_;
  std::atomic<bool>* const stop_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<pb::WorkerService::Stub> stub_;
  BlobClient blobs_;
  SceneCache cache_;
  // On a GPU worker, the scene rendered last, kept on the GPU (tasks run one
  // at a time): its name, the cached host scene it was made from, and it.
  std::string gpu_scene_name_;
  std::shared_ptr<const OpenedScene> gpu_scene_host_;
  std::unique_ptr<DeviceRenderer> gpu_scene_;
  std::atomic<bool> server_down_{false};
  std::atomic<bool> finished_{false};
  std::mutex lease_mu_;
  grpc::ClientContext* lease_context_ = nullptr;  // Guarded by lease_mu_.
};

// pf-worker's Prometheus metrics (docs/DEPLOY.md).
struct WorkerMetrics {
  explicit WorkerMetrics(MetricsRegistry& registry)
      : cache_hits(registry.Counter("pf_scene_cache_hits_total",
                                    "Render chunks whose scene was already in memory.")),
        cache_misses(registry.Counter("pf_scene_cache_misses_total",
                                      "Render chunks that had to download and open their scene.")),
        heartbeats(registry.Counter("pf_worker_heartbeats_total", "Heartbeats sent.")),
        busy(registry.Gauge("pf_worker_busy", "1 while the worker runs a task, else 0.")) {}
  pf::Counter& Tasks(const pb::Task& task, const std::string& outcome) {
    return DefaultMetrics().Counter(
        "pf_worker_tasks_total", "Tasks this worker ran, by outcome.",
        {{"kind", task.has_reconstruct() ? "reconstruct" : "render"}, {"outcome", outcome}});
  }
  pf::Counter& cache_hits;
  pf::Counter& cache_misses;
  pf::Counter& heartbeats;
  pf::Gauge& busy;
};

WorkerMetrics& Metrics() {
  static WorkerMetrics* metrics = new WorkerMetrics(DefaultMetrics());
  return *metrics;
}

// Creates every metric up front, so a scrape of an idle worker lists them.
void RegisterWorkerMetrics() {
  WorkerMetrics& metrics = Metrics();
  pb::Task reconstruct;
  reconstruct.mutable_reconstruct();
  pb::Task render;
  render.mutable_render();
  for (const pb::Task* task : {&reconstruct, &render}) {
    for (const char* outcome : {"succeeded", "failed", "dropped"}) metrics.Tasks(*task, outcome);
  }
}

int Worker::Run() {
  RegisterWorkerMetrics();
  DefaultMetrics().CallbackGauge("pf_scene_cache_bytes", "Bytes of scenes held in memory.", {},
                                 [this] { return static_cast<double>(cache_.bytes()); });
  if (const absl::Status status = EmptyWorkDir(); !status.ok()) {
    spdlog::error("work dir {}: {}", options_.work_dir, std::string(status.message()));
    return 1;
  }
  spdlog::info("pf-worker {} serving {} on {}: scene cache {} MiB, work dir {}", options_.worker_id,
               options_.server, options_.device, options_.cache_bytes >> 20, options_.work_dir);
  std::thread watcher([this] { WatchStop(); });
  while (!stop_->load()) {
    std::optional<pb::Task> task = Lease();
    if (task.has_value()) RunTask(*task);
  }
  finished_ = true;
  watcher.join();
  spdlog::info("pf-worker {} stopped ({} scene cache hits, {} misses)", options_.worker_id,
               cache_.hits(), cache_.misses());
  return 0;
}

absl::Status Worker::EmptyWorkDir() {
  RETURN_IF_ERROR(MakeDirs(options_.work_dir));
  std::error_code error;
  int removed = 0;
  for (const fs::directory_entry& entry : fs::directory_iterator(options_.work_dir, error)) {
    fs::remove_all(entry.path(), error);
    if (error) {
      return absl::InternalError(
          absl::StrCat("cannot remove ", entry.path().string(), ": ", error.message()));
    }
    ++removed;
  }
  if (error) return absl::InternalError(absl::StrCat("cannot list: ", error.message()));
  if (removed > 0) {
    spdlog::info("removed {} leftovers of a previous run from {}", removed, options_.work_dir);
  }
  return absl::OkStatus();
}

void Worker::WatchStop() {
  while (!finished_.load()) {
    if (stop_->load()) {
      std::lock_guard<std::mutex> lock(lease_mu_);
      if (lease_context_ != nullptr) lease_context_->TryCancel();
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
}

void Worker::SleepUnlessStopped(std::chrono::milliseconds duration) const {
  const auto until = Clock::now() + duration;
  while (!stop_->load() && Clock::now() < until)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
}

void Worker::ServerDown(const grpc::Status& status) {
  if (!server_down_.exchange(true)) {
    spdlog::warn("server {} unavailable ({}); retrying every second", options_.server,
                 status.error_message());
  }
  // Without this, gRPC's reconnect backoff grows to minutes while the server
  // is down and the worker would be slow to notice it coming back.
  grpc::experimental::ChannelResetConnectionBackoff(channel_.get());
}

void Worker::ServerUp() {
  if (server_down_.exchange(false)) spdlog::info("server {} is back", options_.server);
}

std::optional<pb::Task> Worker::Lease() {
  pb::LeaseTaskRequest request;
  request.set_worker_id(options_.worker_id);
  for (const std::string& name : cache_.Names()) request.add_cached_scenes(name);
  request.mutable_wait()->set_seconds(options_.lease_wait_ms / 1000);
  request.mutable_wait()->set_nanos((options_.lease_wait_ms % 1000) * 1000000);
  request.set_device(options_.device);

  grpc::ClientContext context;
  SetDeadline(&context, std::chrono::milliseconds(options_.lease_wait_ms) + kCallDeadline);
  {
    std::lock_guard<std::mutex> lock(lease_mu_);
    if (stop_->load()) return std::nullopt;
    lease_context_ = &context;
  }
  pb::LeaseTaskResponse response;
  const grpc::Status status = stub_->LeaseTask(&context, request, &response);
  {
    std::lock_guard<std::mutex> lock(lease_mu_);
    lease_context_ = nullptr;
  }
  if (status.ok()) {
    ServerUp();
    if (!response.has_task()) return std::nullopt;
    return response.task();
  }
  if (stop_->load()) return std::nullopt;  // Cancelled by WatchStop.
  if (IsServerDown(status.error_code())) {
    ServerDown(status);
  } else {
    spdlog::warn("LeaseTask failed: {}", FromGrpc(status).ToString());
  }
  SleepUnlessStopped(kRetryInterval);
  return std::nullopt;
}

void Worker::SetProgress(TaskState* state, const std::string& stage, double fraction,
                         int frames_done) const {
  bool step = false;  // A new stage or another frame, not just a finer fraction.
  {
    std::lock_guard<std::mutex> lock(state->mu);
    step = stage != state->progress.stage() || frames_done != state->progress.frames_done();
    state->progress.set_stage(stage);
    state->progress.set_fraction(fraction);
    state->progress.set_frames_done(frames_done);
  }
  if (step && options_.stage_delay_ms > 0) {
    std::this_thread::sleep_for(std::chrono::milliseconds(options_.stage_delay_ms));
  }
}

void Worker::RunTask(const pb::Task& task) {
  const auto log = JobLogger(task.task_id());
  if (task.has_reconstruct()) {
    log->info("leased {} attempt {}: reconstruct {}", task.task_id(), task.attempt(),
              task.reconstruct().scene());
  } else if (task.has_render()) {
    const pb::RenderWork& work = task.render();
    log->info("leased {} attempt {}: render views {}-{} of {} ({})", task.task_id(), task.attempt(),
              work.first_view(), work.first_view() + work.view_count() - 1,
              RenderJobName(task.operation()), work.scene());
  } else {
    log->info("leased {} attempt {}: no work in it", task.task_id(), task.attempt());
  }
  const std::string dir =
      absl::StrCat(options_.work_dir, "/", FileNameSafe(task.task_id()), "-", task.attempt());

  TaskState state;
  Metrics().busy.Set(1);
  std::thread runner([&] {
    Execute(task, dir, *log, &state);
    std::lock_guard<std::mutex> lock(state.mu);
    state.done = true;
    state.cv.notify_all();
  });

  // Heartbeats until the task thread is done; a dropped task gets none.
  bool dropped = false;
  const auto heartbeat_every = std::chrono::milliseconds(options_.heartbeat_ms);
  std::unique_lock<std::mutex> lock(state.mu);
  while (!state.cv.wait_for(lock, heartbeat_every, [&] { return state.done; })) {
    if (dropped) continue;
    pb::HeartbeatRequest request;
    request.set_worker_id(options_.worker_id);
    request.set_task_id(task.task_id());
    request.set_attempt(task.attempt());
    *request.mutable_progress() = state.progress;
    lock.unlock();
    grpc::ClientContext context;
    SetDeadline(&context,
                std::max<std::chrono::milliseconds>(2 * heartbeat_every, std::chrono::seconds(5)));
    pb::HeartbeatResponse response;
    const grpc::Status status = stub_->Heartbeat(&context, request, &response);
    Metrics().heartbeats.Inc();
    if (status.ok()) {
      ServerUp();
      if (response.cancelled()) {
        log->info("task {} attempt {} cancelled, dropped", task.task_id(), task.attempt());
        dropped = true;
      }
    } else if (status.error_code() == grpc::StatusCode::FAILED_PRECONDITION) {
      log->info("task {} attempt {} lost its lease ({}), dropped", task.task_id(), task.attempt(),
                status.error_message());
      dropped = true;
    } else if (IsServerDown(status.error_code())) {
      ServerDown(status);
    } else {
      log->warn("heartbeat of {} attempt {} failed: {}", task.task_id(), task.attempt(),
                FromGrpc(status).ToString());
    }
    if (dropped) state.cancel = true;
    lock.lock();
  }
  lock.unlock();
  runner.join();

  if (!dropped) {
    Report(task, &state, *log);
  } else {
    Metrics().Tasks(task, "dropped").Inc();
  }
  std::error_code error;
  fs::remove_all(dir, error);
  if (error) log->warn("cannot remove {}: {}", dir, error.message());
  Metrics().busy.Set(0);
}

void Worker::Execute(const pb::Task& task, const std::string& dir, spdlog::logger& log,
                     TaskState* state) {
  absl::Status status = MakeDirs(dir);
  if (status.ok()) {
    if (task.has_reconstruct()) {
      status = Reconstruct(task, dir, log, state);
    } else if (task.has_render()) {
      status = Render(task, dir, log, state);
    } else {
      status = absl::InvalidArgumentError("work: the task has neither reconstruct nor render");
    }
  }
  // What the server (and whoever reads the job) sees names files by their
  // place in the task, not by this machine's directories.
  if (!status.ok()) {
    std::string message = HideDirectory(std::string(status.message()), dir);
    message = HideDirectory(message, options_.work_dir, "<work>");
    status = absl::Status(status.code(), message);
  }
  state->status = status;
}

absl::Status Worker::Reconstruct(const pb::Task& task, const std::string& dir, spdlog::logger& log,
                                 TaskState* state) {
  const pb::ReconstructWork& work = task.reconstruct();
  const FetchBlobFn fetch = [this](const std::string& sha256, const std::string& path) {
    return blobs_.DownloadToFile(sha256, path);
  };
  const StageProgressFn progress = [this, state](const std::string& stage, double fraction) {
    SetProgress(state, stage, fraction, 0);
  };
  const CancelledFn cancelled = [state] { return state->cancel.load(); };
  ASSIGN_OR_RETURN(ComputeDevice device, ParseComputeDevice(options_.device, "--device"));
  if (absl::Status fusion = CheckComputeDevice(device, "--device"); !fusion.ok()) {
    // A GPU worker whose LibTorch cannot use the GPU renders there but fuses
    // on the CPU.
    log.info("fusion runs on the CPU: {}", std::string(fusion.message()));
    device = ComputeDevice{};
  }
  ASSIGN_OR_RETURN(ReconstructOutput out,
                   RunReconstruction(work, fetch, dir, progress, cancelled, device));
  SetProgress(state, "upload", 1.0, 0);
  ASSIGN_OR_RETURN(*out.scene.mutable_scene_file(), blobs_.UploadFile(out.scene_path));
  log.info("reconstructed {}: {} gaussians in {:.2f} s", work.scene(), out.scene.gaussians(),
           out.seconds);

  // Keep the new scene: its render chunks will come here first.
  absl::StatusOr<OpenedScene> opened = OpenScene(out.scene_path);
  if (opened.ok()) {
    cache_.Put(work.scene(), *std::move(opened));
  } else {
    log.warn("cannot cache {}: {}", work.scene(), opened.status().ToString());
  }
  *state->completion.mutable_reconstruct()->mutable_scene() = std::move(out.scene);
  return absl::OkStatus();
}

absl::Status Worker::Render(const pb::Task& task, const std::string& dir, spdlog::logger& log,
                            TaskState* state) {
  const pb::RenderWork& work = task.render();
  const auto start = Clock::now();
  std::shared_ptr<const OpenedScene> scene = cache_.Get(work.scene());
  if (scene != nullptr) {
    Metrics().cache_hits.Inc();
    log.info("scene cache hit {}", work.scene());
  } else {
    if (work.scene_file().sha256().empty()) {
      return absl::InvalidArgumentError("scene_file: no digest of the scene file");
    }
    SetProgress(state, "download", 0.0, 0);
    const std::string path = dir + "/scene.pfs";
    RETURN_IF_ERROR(
        StatusWithContext(blobs_.DownloadToFile(work.scene_file().sha256(), path), "scene_file"));
    ASSIGN_OR_RETURN(OpenedScene opened, OpenScene(path));
    const size_t gaussians = opened.scene.size();
    scene = cache_.Put(work.scene(), std::move(opened));
    Metrics().cache_misses.Inc();
    log.info("scene cache miss {}: downloaded and opened {} gaussians in {:.2f} s", work.scene(),
             gaussians, SecondsSince(start));
  }

  const int total = work.view_count();
  const FramesDoneFn on_frame = [this, state, total](int frames_done) {
    SetProgress(state, "render", total > 0 ? double(frames_done) / total : 1.0, frames_done);
  };
  const CancelledFn cancelled = [state] { return state->cancel.load(); };
  ASSIGN_OR_RETURN(const ComputeDevice device, ParseComputeDevice(options_.device, "--device"));
  if (device.kind == ComputeDevice::Kind::kCuda && gpu_scene_name_ != work.scene()) {
    // The hot scene moves to the GPU; the one before leaves it.
    gpu_scene_.reset();
    gpu_scene_host_.reset();
    gpu_scene_name_.clear();
    const auto upload_start = Clock::now();
    ASSIGN_OR_RETURN(gpu_scene_, DeviceRenderer::Create(&scene->scene, device, "--device"));
    gpu_scene_host_ = scene;
    gpu_scene_name_ = work.scene();
    log.info("scene {} uploaded to {} in {:.2f} s", work.scene(), device.ToString(),
             SecondsSince(upload_start));
  }
  SetProgress(state, "render", 0.0, 0);
  ASSIGN_OR_RETURN(
      const RenderChunkOutput chunk,
      RenderChunk(work, *scene, dir + "/out", on_frame, cancelled,
                  device.kind == ComputeDevice::Kind::kCuda ? gpu_scene_.get() : nullptr));

  pb::RenderResult* result = state->completion.mutable_render();
  for (const RenderedFile& file : chunk.files) {
    pb::OutputFile* output = result->add_files();
    output->set_name(file.name);
    output->set_view(file.view);
    ASSIGN_OR_RETURN(*output->mutable_digest(), blobs_.UploadFile(file.path));
  }
  result->set_manifest_views_json(chunk.manifest_views_json);
  result->set_manifest_lidars_json(chunk.manifest_lidars_json);
  log.info("rendered chunk frames {}-{} of {} in {:.2f} s", work.first_view(),
           work.first_view() + work.view_count() - 1, RenderJobName(task.operation()),
           SecondsSince(start));
  return absl::OkStatus();
}

void Worker::Report(const pb::Task& task, TaskState* state, spdlog::logger& log) {
  const absl::Status& outcome = state->status;
  if (!outcome.ok()) {
    log.warn("task {} attempt {} failed ({}): {}", task.task_id(), task.attempt(),
             IsPermanent(outcome.code()) ? "permanent" : "the server may retry it",
             outcome.ToString());
  }
  const auto give_up = Clock::now() + kReportRetryFor;
  while (true) {
    grpc::ClientContext context;
    SetDeadline(&context, kCallDeadline);
    grpc::Status status;
    if (outcome.ok()) {
      pb::CompleteTaskRequest request = state->completion;
      request.set_worker_id(options_.worker_id);
      request.set_task_id(task.task_id());
      request.set_attempt(task.attempt());
      pb::CompleteTaskResponse response;
      status = stub_->CompleteTask(&context, request, &response);
    } else {
      pb::FailTaskRequest request;
      request.set_worker_id(options_.worker_id);
      request.set_task_id(task.task_id());
      request.set_attempt(task.attempt());
      request.mutable_error()->set_code(static_cast<int>(outcome.code()));
      request.mutable_error()->set_message(std::string(outcome.message()));
      pb::FailTaskResponse response;
      status = stub_->FailTask(&context, request, &response);
    }
    if (status.ok()) {
      ServerUp();
      if (outcome.ok()) log.info("task {} attempt {} completed", task.task_id(), task.attempt());
      Metrics().Tasks(task, outcome.ok() ? "succeeded" : "failed").Inc();
      return;
    }
    if (status.error_code() == grpc::StatusCode::FAILED_PRECONDITION) {
      log.info("task {} attempt {} lost its lease ({}), dropped", task.task_id(), task.attempt(),
               status.error_message());
      return;
    }
    if (!IsServerDown(status.error_code()) || Clock::now() > give_up) {
      log.error(
          "cannot report task {} attempt {}: {}; the server will retry it when its lease "
          "expires",
          task.task_id(), task.attempt(), FromGrpc(status).ToString());
      return;
    }
    ServerDown(status);
    std::this_thread::sleep_for(kRetryInterval);
  }
}

}  // namespace

std::string DefaultWorkerId() {
  char host[256] = {};
  if (gethostname(host, sizeof(host) - 1) != 0 || host[0] == '\0') {
    std::snprintf(host, sizeof(host), "worker");
  }
  return absl::StrCat(host, "-", getpid());
}

WorkerOptions WithDefaults(WorkerOptions options) {
  if (options.worker_id.empty()) options.worker_id = DefaultWorkerId();
  if (options.work_dir.empty()) {
    options.work_dir = absl::StrCat("/tmp/pf-worker-", FileNameSafe(options.worker_id));
  }
  if (options.device.empty()) options.device = "cpu";
  return options;
}

int RunWorker(const WorkerOptions& options, std::atomic<bool>* stop) {
  Worker worker(WithDefaults(options), stop);
  return worker.Run();
}

}  // namespace pf
