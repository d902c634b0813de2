// pf-worker's main loop: lease a task from pf-server (WorkerService), run it
// on a background thread while this thread sends heartbeats with its
// progress, upload what it produced through BlobService and complete it, or
// fail it with the engine's status code (INVALID_ARGUMENT,
// FAILED_PRECONDITION and NOT_FOUND are permanent; the server retries other
// codes). A heartbeat answered `cancelled` or FAILED_PRECONDITION (lease
// lost) drops the task: its result is thrown away and nothing more is sent
// for it.
//
// Each attempt works in work_dir/<task_id>-<attempt>/, removed when the
// attempt ends; leftovers of an earlier run are removed at start. While the
// server is unreachable the worker retries every second. Setting `*stop`
// (SIGTERM) ends the loop: no new lease, the running task finishes first.
//
//   std::atomic<bool> stop{false};
//   return RunWorker(options, &stop);
#ifndef POINTFORWARD_WORKER_WORKER_LOOP_H_
#define POINTFORWARD_WORKER_WORKER_LOOP_H_

#include <atomic>
#include <cstdint>
#include <string>

#include "rpc/grpc_status.h"

namespace pf {

struct WorkerOptions {
  std::string server;     // pf-server's "HOST:PORT".
  std::string worker_id;  // Empty: "<hostname>-<pid>".
  std::string device = "cpu";
  int64_t cache_bytes = int64_t{2} << 30;  // Scene cache budget.
  std::string work_dir;                    // Empty: /tmp/pf-worker-<worker_id>.
  int heartbeat_ms = 1000;
  int lease_wait_ms = 5000;  // How long one LeaseTask waits for work.
  // Test hook: sleep this long at every progress step of a task (each stage
  // of a reconstruction, each view of a render chunk), so that a test can
  // kill or cancel the worker in the middle of one. 0: off.
  int stage_delay_ms = 0;
  ChannelOptions channel;  // TLS and bearer token (--tls-ca, --token-file, ...).
};

// Returns the default worker id, "<hostname>-<pid>".
std::string DefaultWorkerId();

// Fills the defaults of `options` (worker id, work dir).
WorkerOptions WithDefaults(WorkerOptions options);

// Runs the loop until `*stop` turns true; returns the process exit code (0
// after a clean stop, 1 when the work directory cannot be prepared).
int RunWorker(const WorkerOptions& options, std::atomic<bool>* stop);

}  // namespace pf

#endif  // POINTFORWARD_WORKER_WORKER_LOOP_H_
