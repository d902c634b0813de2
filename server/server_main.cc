// pf-server: the gRPC front end. Holds no state but its job store and blob
// store; see `pf-server --help` and docs/SERVICE.md.
#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/health_check_service_interface.h>
#include <grpcpp/security/server_credentials.h>
#include <grpcpp/server.h>
#include <grpcpp/server_builder.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "common/command_line.h"
#include "common/file_util.h"
#include "common/logging.h"
#include "common/metrics_http.h"
#include "common/status_macros.h"
#include "google/longrunning/operations.grpc.pb.h"
#include "server/auth.h"
#include "server/blob_quota.h"
#include "server/blobs/blob_service.h"
#include "server/blobs/blob_store.h"
#include "server/server_metrics.h"
#include "server/services.h"
#include "server/store/job_store.h"
#include "spdlog/spdlog.h"

namespace pf {
namespace {

constexpr char kUsage[] = R"(usage: pf-server [flags]
       pf-server hash-token < TOKEN    (prints the token file line's hash of TOKEN)

Serves SceneService, RenderService, google.longrunning.Operations,
BlobService and WorkerService on one port, with grpc.health.v1 and server
reflection. Every flag may also come from the environment variable named
beside it; the flag wins.

  --listen HOST:PORT       address to serve on (PF_LISTEN; default 127.0.0.1:50051;
                           port 0 picks a free one)
  --store SPEC             job store: sqlite:PATH (PF_STORE; default sqlite:pf-data/jobs.db)
  --blobs DIR              content-addressed blob directory (PF_BLOBS; default pf-data/blobs)
  --trusted-root DIR[,DIR] directories file:// clips may be read from (PF_TRUSTED_ROOTS;
                           default none)
  --lease-seconds N        lease a worker holds on a task between heartbeats
                           (PF_LEASE_SECONDS; default 30)
  --max-attempts N         attempts before a task and its job fail (PF_MAX_ATTEMPTS; default 3)
  --chunk-frames N         frames (views, then LiDAR sweeps) per render chunk unless the
                           request says (PF_CHUNK_FRAMES; default 4)
  --max-views N            views and LiDAR sweeps per render job (PF_MAX_VIEWS; default 10000)
  --max-upload-bytes N     largest blob one upload may carry (PF_MAX_UPLOAD_BYTES;
                           default 1073741824)
  --max-request-bytes N    largest gRPC message the server accepts; larger ones are
                           refused with RESOURCE_EXHAUSTED (PF_MAX_REQUEST_BYTES;
                           default 67108864; at least 2097152)
  --max-images-per-clip N  frames (images) one clip may hold (PF_MAX_IMAGES_PER_CLIP;
                           default 1000; 0 = no limit)
  --max-pixels-per-image N width x height of a clip's cameras, and of a render view's
                           (PF_MAX_PIXELS_PER_IMAGE; default 50000000; 0 = no limit)
  --max-render-bytes N     estimated memory one view's render may take on a worker, from
                           its pixels and outputs (PF_MAX_RENDER_BYTES; default 4294967296;
                           0 = no limit)
  --max-gaussians N        Gaussians one reconstructed scene may hold; the worker fails a
                           reconstruction over it (PF_MAX_GAUSSIANS; default 20000000;
                           0 = no limit)
  --max-jobs-per-owner N   unfinished jobs (scenes being built, render jobs) one owner may
                           have (PF_MAX_JOBS_PER_OWNER; default 100; 0 = no limit)
  --max-long-polls N       WaitOperation calls the server holds at once; more are refused
                           with RESOURCE_EXHAUSTED (PF_MAX_LONG_POLLS; default 64; 0 = no limit)
  --max-long-polls-per-caller N
                           the same per caller: a token's owner, or an address when
                           authentication is off (PF_MAX_LONG_POLLS_PER_CALLER; default 8;
                           0 = no limit)
  --max-blob-bytes N       size of the blob store; over it, least recently used scenes not
                           in use are evicted, and uploads refused when none can be
                           (PF_MAX_BLOB_BYTES; default 0 = no limit)
  --metrics-listen HOST:PORT
                           serve Prometheus metrics on http://HOST:PORT/metrics
                           (PF_METRICS_LISTEN; default off)
  --port-file PATH         write the port actually bound to PATH (for scripts and tests)
  --log-level LEVEL        trace|debug|info|warn|error (PF_LOG_LEVEL; default info)
  --auth-token-file PATH   bearer tokens callers must send, one '<sha256-hex> <owner>
                           [admin|worker]' per line, re-read within 1 s of a change
                           (PF_AUTH_TOKEN_FILE; default none: authentication off)
  --tls-cert PEM           serve TLS with this certificate chain (PF_TLS_CERT; default
                           none: plaintext); needs --tls-key
  --tls-key PEM            the certificate's private key (PF_TLS_KEY)
  --tls-client-ca PEM      mutual TLS: every client must present a certificate signed by
                           this CA (PF_TLS_CLIENT_CA; default none); needs --tls-cert
  --tls-worker-ca PEM      mutual TLS for workers only: WorkerService calls must present
                           a certificate signed by this CA, other clients may present
                           none (PF_TLS_WORKER_CA; default none); needs --tls-cert; not
                           with --tls-client-ca

Stops on SIGTERM or SIGINT within 5 s: in-flight calls get 4 s to finish, and
any still running then are abandoned (the job store is transactional).
)";

// On SIGTERM: in-flight calls get kStopGrace, the process ends by kStopLimit
// after the stop begins (within 5 s of the signal, as documented).
constexpr auto kStopGrace = std::chrono::seconds(4);
constexpr auto kStopLimit = std::chrono::milliseconds(4500);

// Blob uploads travel in 1 MiB chunks: a request limit must let one through.
constexpr int64_t kMinRequestBytes = int64_t{2} << 20;

std::atomic<bool> g_stop{false};

void OnSignal(int) { g_stop = true; }

// `pf-server hash-token`: the token file hash of the token on stdin (one
// line; surrounding whitespace ignored).
int HashTokenCommand() {
  std::string input;
  char buffer[4096];
  while (size_t read = std::fread(buffer, 1, sizeof(buffer), stdin)) input.append(buffer, read);
  const absl::string_view token = absl::StripAsciiWhitespace(input);
  absl::StatusOr<std::string> hash = HashToken(std::string_view(token.data(), token.size()));
  if (!hash.ok()) {
    std::fprintf(stderr, "pf-server hash-token: %s\n",
                 std::string(hash.status().message()).c_str());
    return 2;
  }
  std::printf("%s\n", hash->c_str());
  return 0;
}

// The flag's value, else the environment variable's, else `fallback`.
std::string Setting(const CommandLine& cl, const std::string& flag, const char* env,
                    const std::string& fallback) {
  if (cl.Has(flag)) return cl.Get(flag);
  const char* value = std::getenv(env);
  return value != nullptr && *value != '\0' ? std::string(value) : fallback;
}

absl::StatusOr<int64_t> IntSetting(const CommandLine& cl, const std::string& flag, const char* env,
                                   int64_t fallback, int64_t min_value) {
  const std::string text = Setting(cl, flag, env, absl::StrCat(fallback));
  int64_t value = 0;
  if (!absl::SimpleAtoi(text, &value) || value < min_value) {
    return absl::InvalidArgumentError(
        absl::StrCat("--", flag, ": expected an integer >= ", min_value, ", got '", text, "'"));
  }
  return value;
}

// The PEM file a --`flag` names; INVALID_ARGUMENT naming the flag when it
// cannot be read or holds no PEM block.
absl::StatusOr<std::string> ReadPem(const std::string& path, const char* flag) {
  absl::StatusOr<std::string> text = ReadFileToString(path);
  if (!text.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("--", flag, ": ", std::string(text.status().message())));
  }
  if (!absl::StrContains(*text, "-----BEGIN ")) {
    return absl::InvalidArgumentError(absl::StrCat("--", flag, ": ", path, " is not a PEM file"));
  }
  return text;
}

// The port's credentials: TLS with --tls-cert and --tls-key (mutual TLS
// with --tls-client-ca; certificates asked for, and verified when given, with
// --tls-worker-ca), plaintext without.
absl::StatusOr<std::shared_ptr<grpc::ServerCredentials>> ServerCredentialsFromSettings(
    const CommandLine& cl) {
  const std::string cert = Setting(cl, "tls-cert", "PF_TLS_CERT", "");
  const std::string key = Setting(cl, "tls-key", "PF_TLS_KEY", "");
  const std::string client_ca = Setting(cl, "tls-client-ca", "PF_TLS_CLIENT_CA", "");
  const std::string worker_ca = Setting(cl, "tls-worker-ca", "PF_TLS_WORKER_CA", "");
  if (!client_ca.empty() && !worker_ca.empty()) {
    return absl::InvalidArgumentError(
        "--tls-client-ca and --tls-worker-ca: give one (every client, or workers only)");
  }
  if (cert.empty() != key.empty()) {
    return absl::InvalidArgumentError(
        "--tls-cert and --tls-key: give both (a certificate chain and its private key) or neither");
  }
  if (cert.empty()) {
    if (!client_ca.empty()) {
      return absl::InvalidArgumentError("--tls-client-ca: needs --tls-cert and --tls-key");
    }
    if (!worker_ca.empty()) {
      return absl::InvalidArgumentError("--tls-worker-ca: needs --tls-cert and --tls-key");
    }
    return grpc::InsecureServerCredentials();
  }
  grpc::SslServerCredentialsOptions ssl;
  grpc::SslServerCredentialsOptions::PemKeyCertPair pair;
  ASSIGN_OR_RETURN(pair.cert_chain, ReadPem(cert, "tls-cert"));
  ASSIGN_OR_RETURN(pair.private_key, ReadPem(key, "tls-key"));
  ssl.pem_key_cert_pairs.push_back(std::move(pair));
  if (!client_ca.empty()) {
    ASSIGN_OR_RETURN(ssl.pem_root_certs, ReadPem(client_ca, "tls-client-ca"));
    ssl.client_certificate_request = GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY;
    ssl.force_client_auth = true;
  } else if (!worker_ca.empty()) {
    // Asked for and verified when presented; AuthorizeWorker requires one.
    ASSIGN_OR_RETURN(ssl.pem_root_certs, ReadPem(worker_ca, "tls-worker-ca"));
    ssl.client_certificate_request = GRPC_SSL_REQUEST_CLIENT_CERTIFICATE_AND_VERIFY;
  }
  spdlog::info("TLS on{}", !client_ca.empty()   ? ", client certificates required"
                           : !worker_ca.empty() ? ", client certificates required of workers"
                                                : "");
  return grpc::SslServerCredentials(ssl);
}

absl::Status Run(const CommandLine& cl) {
  const std::string listen = Setting(cl, "listen", "PF_LISTEN", "127.0.0.1:50051");
  const std::string store_spec = Setting(cl, "store", "PF_STORE", "sqlite:pf-data/jobs.db");
  const std::string blob_dir = Setting(cl, "blobs", "PF_BLOBS", "pf-data/blobs");
  StoreOptions store_options;
  ASSIGN_OR_RETURN(const int64_t lease_seconds,
                   IntSetting(cl, "lease-seconds", "PF_LEASE_SECONDS", 30, 1));
  store_options.lease_duration_ms = lease_seconds * 1000;
  ASSIGN_OR_RETURN(const int64_t max_attempts,
                   IntSetting(cl, "max-attempts", "PF_MAX_ATTEMPTS", 3, 1));
  store_options.max_attempts = static_cast<int>(max_attempts);
  ServerOptions options;
  for (absl::string_view root : absl::StrSplit(Setting(cl, "trusted-root", "PF_TRUSTED_ROOTS", ""),
                                               ',', absl::SkipEmpty())) {
    options.trusted_roots.emplace_back(root);
  }
  ASSIGN_OR_RETURN(const int64_t chunk_frames,
                   IntSetting(cl, "chunk-frames", "PF_CHUNK_FRAMES", 4, 1));
  options.chunk_frames = static_cast<int>(chunk_frames);
  ASSIGN_OR_RETURN(const int64_t max_views, IntSetting(cl, "max-views", "PF_MAX_VIEWS", 10000, 1));
  options.max_views = static_cast<int>(max_views);
  ASSIGN_OR_RETURN(options.max_upload_bytes,
                   IntSetting(cl, "max-upload-bytes", "PF_MAX_UPLOAD_BYTES", int64_t{1} << 30, 1));
  ASSIGN_OR_RETURN(const int64_t max_request_bytes,
                   IntSetting(cl, "max-request-bytes", "PF_MAX_REQUEST_BYTES", int64_t{64} << 20,
                              kMinRequestBytes));
  if (max_request_bytes > std::numeric_limits<int>::max()) {
    return absl::InvalidArgumentError(absl::StrCat("--max-request-bytes: at most ",
                                                   std::numeric_limits<int>::max(), ", got ",
                                                   max_request_bytes));
  }
  ASSIGN_OR_RETURN(options.clip_limits.max_images_per_clip,
                   IntSetting(cl, "max-images-per-clip", "PF_MAX_IMAGES_PER_CLIP", 1000, 0));
  ASSIGN_OR_RETURN(
      options.clip_limits.max_pixels_per_image,
      IntSetting(cl, "max-pixels-per-image", "PF_MAX_PIXELS_PER_IMAGE", 50'000'000, 0));
  ASSIGN_OR_RETURN(options.max_render_bytes,
                   IntSetting(cl, "max-render-bytes", "PF_MAX_RENDER_BYTES", int64_t{4} << 30, 0));
  ASSIGN_OR_RETURN(const int64_t max_long_polls,
                   IntSetting(cl, "max-long-polls", "PF_MAX_LONG_POLLS", 64, 0));
  ASSIGN_OR_RETURN(
      const int64_t max_long_polls_per_caller,
      IntSetting(cl, "max-long-polls-per-caller", "PF_MAX_LONG_POLLS_PER_CALLER", 8, 0));
  options.max_long_polls = static_cast<int>(std::min<int64_t>(max_long_polls, 1 << 20));
  options.max_long_polls_per_caller =
      static_cast<int>(std::min<int64_t>(max_long_polls_per_caller, 1 << 20));
  ASSIGN_OR_RETURN(options.max_gaussians,
                   IntSetting(cl, "max-gaussians", "PF_MAX_GAUSSIANS", 20'000'000, 0));
  ASSIGN_OR_RETURN(options.max_jobs_per_owner,
                   IntSetting(cl, "max-jobs-per-owner", "PF_MAX_JOBS_PER_OWNER", 100, 0));
  ASSIGN_OR_RETURN(const int64_t max_blob_bytes,
                   IntSetting(cl, "max-blob-bytes", "PF_MAX_BLOB_BYTES", 0, 0));

  std::unique_ptr<Authenticator> authenticator;
  if (const std::string path = Setting(cl, "auth-token-file", "PF_AUTH_TOKEN_FILE", "");
      !path.empty()) {
    ASSIGN_OR_RETURN(authenticator, Authenticator::FromFile(path));
    options.authenticator = authenticator.get();
  }
  options.worker_certificate_required =
      !Setting(cl, "tls-worker-ca", "PF_TLS_WORKER_CA", "").empty();

  if (absl::StartsWith(store_spec, "sqlite:")) {
    const std::string path = store_spec.substr(7);
    const size_t slash = path.rfind('/');
    if (slash != std::string::npos && slash > 0) RETURN_IF_ERROR(MakeDirs(path.substr(0, slash)));
  }
  ASSIGN_OR_RETURN(std::unique_ptr<JobStore> store, OpenJobStore(store_spec, store_options));
  RETURN_IF_ERROR(MakeDirs(blob_dir));
  BlobStore blobs(blob_dir);
  ServiceCore core(store.get(), &blobs, options);
  if (const int removed = core.RemoveStaleScratch(); removed > 0) {
    spdlog::info("removed {} staging directories left by servers that ended", removed);
  }
  ServerMetrics& metrics = RegisterServerMetrics(store.get());
  std::unique_ptr<MetricsHttpServer> metrics_http;
  if (const std::string address = Setting(cl, "metrics-listen", "PF_METRICS_LISTEN", "");
      !address.empty()) {
    metrics_http = std::make_unique<MetricsHttpServer>(address);
    RETURN_IF_ERROR(metrics_http->Start());
    spdlog::info("metrics on http://{}/metrics", address);
  }
  SceneServiceImpl scene_service(&core);
  RenderServiceImpl render_service(&core);
  OperationsServiceImpl operations_service(&core);
  WorkerServiceImpl worker_service(&core);
  BlobServiceImpl blob_service(&blobs, options.max_upload_bytes, authenticator.get());
  BlobQuota quota(store.get(), &blobs, max_blob_bytes);
  if (quota.max_bytes() > 0) blob_service.set_make_room([&quota] { return quota.MakeRoom(); });

  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  ASSIGN_OR_RETURN(const std::shared_ptr<grpc::ServerCredentials> credentials,
                   ServerCredentialsFromSettings(cl));

  grpc::ServerBuilder builder;
  int port = 0;
  builder.AddListeningPort(listen, credentials, &port);
  builder.SetMaxReceiveMessageSize(static_cast<int>(max_request_bytes));
  builder.SetMaxSendMessageSize(64 << 20);
  builder.RegisterService(&scene_service);
  builder.RegisterService(&render_service);
  builder.RegisterService(&operations_service);
  builder.RegisterService(&worker_service);
  builder.RegisterService(&blob_service);
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  if (server == nullptr || port == 0) {
    return absl::UnavailableError(absl::StrCat("--listen: cannot listen on ", listen));
  }
  const std::string host = listen.substr(0, listen.rfind(':'));
  spdlog::info("pf-server listening on {}:{} (store {}, blobs {}, lease {} s, {} attempts)", host,
               port, store_spec, blob_dir, lease_seconds, max_attempts);
  if (cl.Has("port-file"))
    RETURN_IF_ERROR(WriteFileAtomic(cl.Get("port-file"), absl::StrCat(port, "\n")));

  // Leases of dead workers go back to the queue.
  std::thread expirer([&] {
    while (!g_stop) {
      absl::StatusOr<int> expired = store->ExpireLeases(core.NowMs());
      if (!expired.ok()) {
        spdlog::error("expiring leases: {}", std::string(expired.status().message()));
      } else if (*expired > 0) {
        metrics.leases_expired->Inc(*expired);
        spdlog::warn("{} lease(s) expired: tasks requeued or failed", *expired);
      }
      for (int i = 0; i < 5 && !g_stop; ++i)
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  });
  while (!g_stop) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  spdlog::info("pf-server stopping");
  // A call that does not end within the grace (a long check of a large
  // clip) must not keep the process alive past kStopLimit: the store is
  // transactional, so leaving it mid-call loses nothing.
  std::atomic<bool> stopped{false};
  std::thread watchdog([&stopped] {
    const auto until = std::chrono::steady_clock::now() + kStopLimit;
    while (!stopped && std::chrono::steady_clock::now() < until) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    if (stopped) return;
    spdlog::warn("calls still running {} ms after the stop signal; exiting without them",
                 kStopLimit.count());
    spdlog::default_logger()->flush();
    std::_Exit(0);
  });
  server->Shutdown(std::chrono::system_clock::now() + kStopGrace);
  expirer.join();
  if (metrics_http) metrics_http->Stop();
  stopped = true;
  watchdog.join();
  spdlog::info("pf-server stopped");
  return absl::OkStatus();
}

}  // namespace
}  // namespace pf

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  if (!args.empty() && args[0] == "hash-token") {
    if (args.size() > 1) {
      std::fputs("pf-server hash-token: takes no arguments; the token comes on stdin\n", stderr);
      return 2;
    }
    return pf::HashTokenCommand();
  }
  for (const std::string& arg : args) {
    if (arg == "--help" || arg == "-h") {
      std::fputs(pf::kUsage, stdout);
      return 0;
    }
  }
  absl::StatusOr<pf::CommandLine> cl = pf::CommandLine::Parse(args, {"listen",
                                                                     "store",
                                                                     "blobs",
                                                                     "trusted-root",
                                                                     "lease-seconds",
                                                                     "max-attempts",
                                                                     "chunk-frames",
                                                                     "max-views",
                                                                     "max-upload-bytes",
                                                                     "port-file",
                                                                     "log-level",
                                                                     "metrics-listen",
                                                                     "max-request-bytes",
                                                                     "max-images-per-clip",
                                                                     "max-pixels-per-image",
                                                                     "max-gaussians",
                                                                     "max-render-bytes",
                                                                     "max-long-polls",
                                                                     "max-long-polls-per-caller",
                                                                     "max-jobs-per-owner",
                                                                     "max-blob-bytes",
                                                                     "auth-token-file",
                                                                     "tls-cert",
                                                                     "tls-key",
                                                                     "tls-client-ca",
                                                                     "tls-worker-ca"});
  if (!cl.ok() || !cl->positional().empty()) {
    std::fprintf(stderr, "pf-server: %s\n%s",
                 cl.ok() ? "unexpected arguments" : std::string(cl.status().message()).c_str(),
                 pf::kUsage);
    return 2;
  }
  pf::InitLogging(cl->Get("log-level"));
  std::signal(SIGTERM, pf::OnSignal);
  std::signal(SIGINT, pf::OnSignal);
  const absl::Status status = pf::Run(*cl);
  if (!status.ok()) {
    spdlog::error("pf-server: {}", std::string(status.message()));
    return status.code() == absl::StatusCode::kInvalidArgument ? 2 : 1;
  }
  return 0;
}
