// pf-worker: pulls reconstruction and render tasks from pf-server and runs
// them on the engine (worker_loop.h). This file parses the flags and wires
// SIGTERM / SIGINT to a clean stop.
#include <algorithm>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "common/command_line.h"
#include "common/logging.h"
#include "common/memory_reuse.h"
#include "common/metrics_http.h"
#include "common/status_macros.h"
#include "engine/recon/compute_device.h"
#include "engine/render/cuda_rasterizer.h"
#include "worker/worker_loop.h"

namespace {

constexpr char kUsage[] = R"(usage: pf-worker --server HOST:PORT [flags]

Pulls tasks (reconstructions and render chunks) from pf-server, runs them and
uploads the results. Logs to stderr; SIGTERM or SIGINT stops it after the
running task.

  --server HOST:PORT   pf-server to pull from (default: $PF_SERVER)
  --device D           cpu, cuda or cuda:N (default cpu). On a GPU, render chunks run
                       on the CUDA rasterizer, the scene rendered last kept on the GPU,
                       and fusion runs there when the build's LibTorch has CUDA
  --cache-bytes N      memory budget of the scene cache in bytes (default 2147483648)
  --work-dir DIR       scratch directory, emptied at start; each attempt works in
                       DIR/<task>-<attempt>/ (default /tmp/pf-worker-<id>)
  --id NAME            worker id shown by the server (default <hostname>-<pid>)
  --heartbeat-ms N     milliseconds between heartbeats of a running task (default 1000)
  --lease-wait-ms N    how long one lease request waits for work (default 5000)
  --stage-delay-ms N   test hook: sleep N ms at every progress report of a task, so a
                       test can stop a worker in the middle of one (default 0)
  --metrics-listen H:P serve Prometheus metrics on http://H:P/metrics (default off)
  --tls-ca PEM         connect with TLS, trusting this CA (PF_TLS_CA; default plaintext)
  --tls-cert PEM       client certificate for mutual TLS, with --tls-key (PF_TLS_CERT)
  --tls-key PEM        the client certificate's private key (PF_TLS_KEY)
  --token-file PATH    file holding the bearer token (a worker or admin token) sent on
                       every call (default: the token itself in PF_WORKER_TOKEN; none)
  --help               print this text

Each flag may also come from the environment: PF_SERVER, PF_DEVICE,
PF_CACHE_BYTES, PF_WORK_DIR, PF_WORKER_ID, PF_HEARTBEAT_MS, PF_LEASE_WAIT_MS,
PF_STAGE_DELAY_MS, PF_METRICS_LISTEN, PF_TLS_CA, PF_TLS_CERT, PF_TLS_KEY; the flag
wins. PF_WORKER_TOKEN holds the token itself, not a path.
)";

// Environment variables standing in for flags that were not given.
constexpr std::pair<const char*, const char*> kEnvFallbacks[] = {
    {"server", "PF_SERVER"},
    {"device", "PF_DEVICE"},
    {"cache-bytes", "PF_CACHE_BYTES"},
    {"work-dir", "PF_WORK_DIR"},
    {"id", "PF_WORKER_ID"},
    {"heartbeat-ms", "PF_HEARTBEAT_MS"},
    {"lease-wait-ms", "PF_LEASE_WAIT_MS"},
    {"stage-delay-ms", "PF_STAGE_DELAY_MS"},
    {"metrics-listen", "PF_METRICS_LISTEN"}};

// `words` with "--flag value" appended for every fallback variable set
// whose flag is absent.
std::vector<std::string> WithEnvironment(std::vector<std::string> words) {
  for (const auto& [flag, env] : kEnvFallbacks) {
    const std::string dashed = absl::StrCat("--", flag);
    const bool given = std::any_of(words.begin(), words.end(), [&](const std::string& w) {
      return w == dashed || absl::StartsWith(w, dashed + "=");
    });
    const char* value = std::getenv(env);
    if (!given && value != nullptr && *value != '\0') {
      words.push_back(dashed);
      words.push_back(value);
    }
  }
  return words;
}

std::atomic<bool> g_stop{false};

void OnSignal(int) { g_stop.store(true); }

// Returns the value of integer flag `name` in [min, max].
absl::StatusOr<int64_t> IntFlag(const pf::CommandLine& cl, const std::string& name,
                                int64_t fallback, int64_t min, int64_t max) {
  ASSIGN_OR_RETURN(const int64_t value, cl.GetInt(name, fallback));
  if (value < min || value > max) {
    return absl::InvalidArgumentError(
        absl::StrCat("--", name, ": must be in [", min, ", ", max, "], got ", cl.Get(name)));
  }
  return value;
}

absl::StatusOr<pf::WorkerOptions> ParseFlags(const pf::CommandLine& cl) {
  if (!cl.positional().empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("unexpected argument '", cl.positional()[0], "'"));
  }
  pf::WorkerOptions options;
  options.server = cl.Get("server");
  if (options.server.empty()) {
    return absl::InvalidArgumentError(
        "--server: required (or set PF_SERVER), e.g. localhost:50051");
  }
  ASSIGN_OR_RETURN(const pf::ComputeDevice device,
                   pf::ParseComputeDevice(cl.Get("device", "cpu"), "--device"));
  // A GPU serves if fusion (LibTorch) or the CUDA rasterizer can use it.
  if (absl::Status fusion = pf::CheckComputeDevice(device, "--device"); !fusion.ok()) {
    if (absl::Status raster = pf::CheckCudaDevice(device.index); !raster.ok()) {
      return absl::FailedPreconditionError(absl::StrCat(
          fusion.message(), "; and the CUDA rasterizer cannot use it either: ", raster.message()));
    }
  }
  options.device = device.ToString();
  ASSIGN_OR_RETURN(options.cache_bytes,
                   IntFlag(cl, "cache-bytes", options.cache_bytes, 0, int64_t{1} << 50));
  options.work_dir = cl.Get("work-dir");
  if (cl.Has("work-dir") && options.work_dir.empty()) {
    return absl::InvalidArgumentError("--work-dir: must not be empty");
  }
  if (options.work_dir == "/") {
    return absl::InvalidArgumentError("--work-dir: '/' would be emptied; name a scratch directory");
  }
  options.worker_id = cl.Get("id");
  if (cl.Has("id") && options.worker_id.empty()) {
    return absl::InvalidArgumentError("--id: must not be empty");
  }
  ASSIGN_OR_RETURN(options.heartbeat_ms,
                   IntFlag(cl, "heartbeat-ms", options.heartbeat_ms, 10, 600000));
  ASSIGN_OR_RETURN(options.lease_wait_ms,
                   IntFlag(cl, "lease-wait-ms", options.lease_wait_ms, 0, 600000));
  ASSIGN_OR_RETURN(options.stage_delay_ms,
                   IntFlag(cl, "stage-delay-ms", options.stage_delay_ms, 0, 600000));
  ASSIGN_OR_RETURN(options.channel, pf::LoadChannelOptions({.tls_ca = cl.Get("tls-ca"),
                                                            .tls_cert = cl.Get("tls-cert"),
                                                            .tls_key = cl.Get("tls-key"),
                                                            .token_file = cl.Get("token-file")},
                                                           {"PF_WORKER_TOKEN"}));
  return options;
}

}  // namespace

int main(int argc, char** argv) {
  // Reconstructions free and allocate gigabytes; reusing the freed memory
  // saves its page faults, and a worker's next job needs it again anyway
  // (common/memory_reuse.h).
  pf::KeepFreedMemoryForReuse();
  const std::vector<std::string> words = WithEnvironment({argv + 1, argv + argc});
  absl::StatusOr<pf::CommandLine> cl = pf::CommandLine::Parse(
      words,
      {"server", "device", "cache-bytes", "work-dir", "id", "heartbeat-ms", "lease-wait-ms",
       "stage-delay-ms", "metrics-listen", "tls-ca", "tls-cert", "tls-key", "token-file"},
      {"help"});
  if (cl.ok() && cl->Has("help")) {
    std::fputs(kUsage, stdout);
    return 0;
  }
  absl::StatusOr<pf::WorkerOptions> options =
      cl.ok() ? ParseFlags(*cl) : absl::StatusOr<pf::WorkerOptions>(cl.status());
  if (!options.ok()) {
    std::fprintf(stderr, "pf-worker: %s\n(pf-worker --help lists the flags)\n",
                 std::string(options.status().message()).c_str());
    return 2;
  }
  pf::InitLogging();
  std::unique_ptr<pf::MetricsHttpServer> metrics;
  if (cl->Has("metrics-listen")) {
    metrics = std::make_unique<pf::MetricsHttpServer>(cl->Get("metrics-listen"));
    if (const absl::Status started = metrics->Start(); !started.ok()) {
      std::fprintf(stderr, "pf-worker: %s\n", std::string(started.message()).c_str());
      return 2;
    }
  }
  std::signal(SIGTERM, OnSignal);
  std::signal(SIGINT, OnSignal);
  return pf::RunWorker(*options, &g_stop);
}
