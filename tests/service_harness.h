// Running the service for end-to-end tests: pf-server and pf-worker as real
// child processes on loopback, each logging to a file, killable with any
// signal, plus the gRPC stubs a test talks to them with.
//
//   ServerProcess server(dir);                 // pf-server on a free port
//   ASSERT_TRUE(server.Start({"--lease-seconds", "2"}));
//   WorkerProcess w1(server.address(), dir, "w1");
//   ASSERT_TRUE(w1.Start());
//   ... RunCommand({BinPath("pf"), "--server", server.address(), ...});
//   w1.Kill(SIGKILL);
#ifndef POINTFORWARD_TESTS_SERVICE_HARNESS_H_
#define POINTFORWARD_TESTS_SERVICE_HARNESS_H_

#include <sys/types.h>

#include <chrono>
#include <functional>
#include <string>
#include <vector>

#include "rpc/grpc_status.h"

namespace pf::testing {

// True when grpc.health.v1.Health/Check at `address` answers SERVING,
// asked over a channel as `channel` says (plaintext by default; no token
// needed: health is not authenticated).
bool Serving(const std::string& address, const ChannelOptions& channel = {});

// A child process with stdout and stderr appended to `log_path`.
class ChildProcess {
 public:
  ChildProcess() = default;
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;
  // Sends SIGKILL if still running.
  ~ChildProcess();

  // Starts `argv` (argv[0] a path). False if fork/exec failed.
  bool Start(const std::vector<std::string>& argv, const std::string& log_path);
  bool running();
  // Sends `signal`; then, for SIGKILL and SIGTERM, waits up to
  // Scaled(`timeout`) for the exit and returns its status (128 + signal when
  // killed), or -1.
  int Kill(int signal, std::chrono::milliseconds timeout = std::chrono::seconds(15));
  pid_t pid() const { return pid_; }
  const std::string& log_path() const { return log_path_; }
  // The log written so far.
  std::string Log() const;

 private:
  pid_t pid_ = -1;
  int exit_status_ = -1;
  std::string log_path_;
};

// pf-server on 127.0.0.1 with a SQLite store and blob directory under
// `dir` (or the store and blob directory given, for several replicas on one
// PostgreSQL); the port is kept across restarts. Logs to `dir`/<name>.log.
class ServerProcess {
 public:
  explicit ServerProcess(std::string dir, std::string name = "server", std::string store = "",
                         std::string blobs = "")
      : dir_(std::move(dir)),
        name_(std::move(name)),
        store_(std::move(store)),
        blobs_(std::move(blobs)) {}
  // Starts pf-server with `extra` flags and waits until it answers health
  // checks (at most Scaled(20 s)).
  bool Start(const std::vector<std::string>& extra = {});
  // Same store, blobs, port and flags as the last Start.
  bool Restart();
  // How Start() reaches the server for its health checks: TLS, and a client
  // certificate under mutual TLS. Plaintext by default.
  void set_health_channel(ChannelOptions channel) { health_channel_ = std::move(channel); }
  // As ChildProcess::Kill.
  int Kill(int signal, std::chrono::milliseconds timeout = std::chrono::seconds(15)) {
    return process_.Kill(signal, timeout);
  }
  // The running pf-server's process id (-1 before the first Start).
  pid_t pid() const { return process_.pid(); }
  std::string address() const;
  std::string Log() const { return process_.Log(); }
  const std::string& dir() const { return dir_; }

 private:
  std::string dir_;
  std::string name_;
  std::string store_;
  std::string blobs_;
  int port_ = 0;
  int starts_ = 0;
  std::vector<std::string> extra_;
  ChannelOptions health_channel_;
  ChildProcess process_;
};

// pf-worker named `id`, working in `dir`/worker-<id>.
class WorkerProcess {
 public:
  WorkerProcess(std::string server_address, std::string dir, std::string id)
      : server_(std::move(server_address)), dir_(std::move(dir)), id_(std::move(id)) {}
  bool Start(const std::vector<std::string>& extra = {});
  int Kill(int signal) { return process_.Kill(signal); }
  std::string Log() const { return process_.Log(); }
  const std::string& id() const { return id_; }
  std::string work_dir() const { return dir_ + "/worker-" + id_; }

 private:
  std::string server_;
  std::string dir_;
  std::string id_;
  int starts_ = 0;
  ChildProcess process_;
};

// Polls `done` every 100 ms until it returns true or Scaled(`timeout`)
// (tests/test_util.h) passes.
bool WaitFor(const std::function<bool()>& done, std::chrono::milliseconds timeout);

// Number of non-overlapping occurrences of `needle` in `text`.
int CountOf(const std::string& text, const std::string& needle);

}  // namespace pf::testing

#endif  // POINTFORWARD_TESTS_SERVICE_HARNESS_H_
