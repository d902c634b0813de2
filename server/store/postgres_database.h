// SqlDatabase over one PostgreSQL connection (libpq). Parameters are sent
// as text with their types (integers as int8, doubles as float8, text left
// for the server to infer); results come back as text and are read into
// typed SqlValues by column type. Transactions run at READ COMMITTED and
// are retried when PostgreSQL reports a conflict with another connection:
// serialization failure (SQLSTATE 40001), deadlock (40P01) or a unique-key
// race (23505) all become kAborted, which SqlDatabase::Transaction retries.
//
// One connection, guarded by a mutex, so one object may be used from many
// threads (they take turns; open several objects for parallel statements).
// A connection that dropped (the server restarted) is re-established once
// per call.
//
//   ASSIGN_OR_RETURN(std::unique_ptr<PostgresDatabase> db,
//                    PostgresDatabase::Open("postgresql://pf:secret@db:5432/pf"));
#ifndef POINTFORWARD_SERVER_STORE_POSTGRES_DATABASE_H_
#define POINTFORWARD_SERVER_STORE_POSTGRES_DATABASE_H_

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "server/store/sql_database.h"

struct pg_conn;

namespace pf {

// Returns `connection` (a postgresql:// URI or a "key=value" string) with
// any password replaced by "***", for messages and logs.
std::string RedactPostgresConnection(const std::string& connection);

class PostgresDatabase : public SqlDatabase {
 public:
  // Connects to `connection`, a libpq connection string:
  // "postgresql://USER:PASS@HOST:PORT/DB" (or postgres://, or key=value
  // pairs). UNAVAILABLE when the server cannot be reached or refuses the
  // login; the message names the connection with its password redacted.
  static absl::StatusOr<std::unique_ptr<PostgresDatabase>> Open(const std::string& connection);

  ~PostgresDatabase() override;
  PostgresDatabase(const PostgresDatabase&) = delete;
  PostgresDatabase& operator=(const PostgresDatabase&) = delete;

  SqlDialect dialect() const override { return SqlDialect::kPostgres; }
  // Runs one statement in its own (implicit) transaction. When the
  // connection turns out to have dropped, reconnects and runs it once more.
  absl::StatusOr<SqlRows> Exec(const std::string& sql,
                               const std::vector<SqlValue>& params = {}) override;
  // BEGIN ISOLATION LEVEL READ COMMITTED ... COMMIT, retried on kAborted,
  // and run again once on a fresh connection when the connection dropped
  // before COMMIT was sent. A connection lost during COMMIT is UNAVAILABLE
  // (the outcome is unknown, so it is not retried).
  absl::Status Transaction(const TransactionFn& fn) override;

 private:
  class LockedExecutor;

  PostgresDatabase(pg_conn* conn, std::string redacted)
      : conn_(conn), redacted_(std::move(redacted)) {}

  // Exec with mutex_ held, no reconnecting.
  absl::StatusOr<SqlRows> ExecLocked(const std::string& sql, const std::vector<SqlValue>& params);
  // One try of Transaction, with mutex_ held. Sets *in_commit when a
  // failure happened while committing.
  absl::Status TransactionOnce(const TransactionFn& fn, bool* in_commit);
  // True when the connection is gone (not a statement error).
  bool ConnectionLost() const;
  // Re-establishes a lost connection, with mutex_ held.
  absl::Status Reconnect();

  std::mutex mutex_;
  pg_conn* conn_;
  const std::string redacted_;  // The connection string, password hidden.
};

}  // namespace pf

#endif  // POINTFORWARD_SERVER_STORE_POSTGRES_DATABASE_H_
