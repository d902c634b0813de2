// A throwaway PostgreSQL server for tests: initdb in a temporary directory,
// run as the `postgres` user on a free loopback port with trust
// authentication and durability off, stopped and removed when the object
// goes away (or at exit, for the shared one).
//
//   if (auto why = PostgresServer::WhyUnavailable()) GTEST_SKIP() << *why;
//   absl::StatusOr<PostgresServer*> server = PostgresServer::Shared();
//   absl::StatusOr<std::string> url = (*server)->CreateDatabase("t1");
//   // url: "postgresql://postgres@127.0.0.1:PORT/t1"
//
// Needs root (to run the server as `postgres`, which owns the data
// directory) and the Debian PostgreSQL binaries; tests skip otherwise.
#ifndef POINTFORWARD_TESTS_POSTGRES_SERVER_H_
#define POINTFORWARD_TESTS_POSTGRES_SERVER_H_

#include <atomic>
#include <memory>
#include <optional>
#include <string>

#include "absl/status/statusor.h"

namespace pf::testing {

class PostgresServer {
 public:
  // Returns why no server can be started here (not root, no `postgres`
  // user, binaries absent), or nullopt when one can. The binaries are
  // looked for in $PF_POSTGRES_BIN_DIR, else /usr/lib/postgresql/15/bin.
  static std::optional<std::string> WhyUnavailable();

  // Starts a new server (initdb, then the server on a free port).
  static absl::StatusOr<std::unique_ptr<PostgresServer>> Start();

  // Returns the process-wide server, started on first use and stopped at
  // exit: one per test binary, with a database per test.
  static absl::StatusOr<PostgresServer*> Shared();

  ~PostgresServer();  // Stops the server and removes its directory.
  PostgresServer(const PostgresServer&) = delete;
  PostgresServer& operator=(const PostgresServer&) = delete;

  // Creates database `name` (letters, digits, '_') and returns its URL.
  absl::StatusOr<std::string> CreateDatabase(const std::string& name);
  // Creates a database with a new name ("pf_test_N") and returns its URL.
  absl::StatusOr<std::string> CreateFreshDatabase();

  // Returns the URL of database `name` on this server.
  std::string Url(const std::string& name) const;
  int port() const { return port_; }

  // Restarts the server on the same port and data (a "server restarted"
  // for reconnect tests); open connections are dropped.
  absl::Status Restart();
  // Stops the server (idempotent).
  absl::Status Stop();

 private:
  explicit PostgresServer(std::string root) : root_(std::move(root)) {}

  // Starts the server on the data directory and port_, as `postgres`.
  absl::Status StartProcess();
  // Returns `status` with the end of the server's log appended.
  absl::Status StatusWithLog(const absl::Status& status) const;

  const std::string root_;  // Temporary directory: data/, the socket, the log.
  int port_ = 0;
  bool running_ = false;
  std::atomic<int> databases_created_{0};
};

}  // namespace pf::testing

#endif  // POINTFORWARD_TESTS_POSTGRES_SERVER_H_
